#pragma once
// Shared by the benchmark programs.

#include <memory>
#include <string>

#include <yaml-cpp/yaml.h>

#include "cdff/dfn/registry.hpp"

namespace cdff::bench {

/// A DFI typed as its DFN's generated class and configured from inline YAML; null on failure
/// (the benchmark then reports the error with SkipWithError).
template <typename Dfn>
std::unique_ptr<Dfn> createConfigured(const std::string& dfn, const std::string& dfi,
                                      const std::string& yaml = "{}") {
  auto node = dfn::Registry::instance().createAs<Dfn>(dfn, dfi);
  if (!node || !node.value()->configure(YAML::Load(yaml))) return nullptr;
  return std::move(node).value();
}

}  // namespace cdff::bench
