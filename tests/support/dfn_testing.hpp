#pragma once
// Helpers shared by the DFN unit tests: a configured instance, and the check that a rejected call
// reports the expected fault and leaves every output as it was.

#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "cdff/dfn/registry.hpp"

namespace cdff::testing {

/// A DFI of `dfn` typed as T (the DFN's generated class), configured from inline YAML.
template <typename T>
std::unique_ptr<T> makeDfn(const std::string& dfn, const std::string& dfi,
                           const std::string& yaml = "{}") {
  auto node = dfn::Registry::instance().createAs<T>(dfn, dfi);
  EXPECT_TRUE(node.isOk()) << node.status().toString();
  if (!node) return nullptr;
  const Status configured = node.value()->configure(YAML::Load(yaml));
  EXPECT_TRUE(configured.isOk()) << configured.toString();
  return std::move(node).value();
}

/// Runs process() and expects it to fail with `code` and a message containing `fragment`,
/// without touching any output.
inline void expectRejected(dfn::Node& node, const std::string& fragment,
                           StatusCode code = StatusCode::kInvalidInput) {
  std::vector<const void*> before;
  for (const dfn::OutputPortBase* out : node.outputs()) before.push_back(out->anyValue().raw());
  const Status s = node.process();
  EXPECT_EQ(s.code(), code) << s.toString();
  EXPECT_NE(s.message().find(fragment), std::string::npos)
      << "'" << fragment << "' not in: " << s.message();
  for (std::size_t i = 0; i < before.size(); ++i)
    EXPECT_EQ(node.outputs()[i]->anyValue().raw(), before[i])
        << "output '" << node.outputs()[i]->name() << "' changed by a rejected call";
}

}  // namespace cdff::testing
