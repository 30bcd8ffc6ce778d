// Every DFI agrees with its DFN's YAML description: the registry, the running instances and the
// description files on disk are compared, so a description cannot drift from the code.
#include <gtest/gtest.h>

#include <filesystem>
#include <set>

#include <yaml-cpp/yaml.h>

#include "cdff/dfn/registry.hpp"
#include "support/synthetic.hpp"

namespace cdff::dfn {
namespace {

std::vector<std::string> names(const YAML::Node& list) {
  std::vector<std::string> out;
  for (const auto& item : list) out.push_back(item["name"].as<std::string>());
  return out;
}

template <typename Specs>
std::vector<std::string> names(const Specs& specs) {
  std::vector<std::string> out;
  for (const auto& s : specs) out.push_back(s.name);
  return out;
}

TEST(Descriptions, TheFoundationDfnTypesAreAllRegistered) {
  const auto& registry = Registry::instance();
  for (const char* dfn : {"ImageUndistortion", "EdgeDetection", "FeaturesExtraction2D",
                          "FeaturesMatching2D", "StereoRectification", "EstimationFilter"}) {
    EXPECT_NE(registry.findDescription(dfn), nullptr) << dfn << " is not registered";
  }
}

TEST(Descriptions, EveryListedImplementationIsRegisteredAndViceVersa) {
  const auto& registry = Registry::instance();
  for (const DfnDescription* d : registry.descriptions()) {
    for (const auto& impl : d->implementations)
      EXPECT_TRUE(registry.hasImplementation(d->name, impl.name))
          << d->source_file << " lists " << impl.name << " but no DFI registers it";
  }
  for (const auto& [dfn, dfi] : registry.implementations()) {
    const DfnDescription* d = registry.findDescription(dfn);
    ASSERT_NE(d, nullptr) << "DFI " << dfi << " registers under unknown DFN " << dfn;
    EXPECT_NE(d->findImplementation(dfi), nullptr)
        << dfn << "/" << dfi << " is registered but not listed in " << d->source_file;
  }
}

TEST(Descriptions, InstancesHaveTheDescribedPortsAndParameters) {
  const auto& registry = Registry::instance();
  for (const DfnDescription* d : registry.descriptions()) {
    for (const auto& impl : d->implementations) {
      SCOPED_TRACE(d->name + "/" + impl.name);
      auto node = registry.create(d->name, impl.name);
      ASSERT_TRUE(node.isOk()) << node.status().toString();
      Node& n = *node.value();
      ASSERT_EQ(n.inputs().size(), d->inputs.size());
      for (std::size_t i = 0; i < d->inputs.size(); ++i) {
        EXPECT_EQ(n.inputs()[i]->name(), d->inputs[i].name);
        EXPECT_EQ(n.inputs()[i]->type().name(), d->inputs[i].type);
        EXPECT_EQ(n.inputs()[i]->optional(), d->inputs[i].optional);
      }
      ASSERT_EQ(n.outputs().size(), d->outputs.size());
      for (std::size_t i = 0; i < d->outputs.size(); ++i) {
        EXPECT_EQ(n.outputs()[i]->name(), d->outputs[i].name);
        EXPECT_EQ(n.outputs()[i]->type().name(), d->outputs[i].type);
      }
      // The defaults written in the description are accepted by the code.
      EXPECT_OK(n.configureDefaults());
      const YAML::Node params = n.parametersAsYaml();
      std::vector<std::string> keys;
      for (const auto& kv : params) keys.push_back(kv.first.as<std::string>());
      std::vector<std::string> expected = names(impl.parameters);
      std::sort(keys.begin(), keys.end());
      std::sort(expected.begin(), expected.end());
      EXPECT_EQ(keys, expected);
      // Feeding the current parameters back must be accepted and change nothing (angles go
      // through degrees and back).
      EXPECT_OK(n.configure(params, "<round trip>"));
      EXPECT_EQ(YAML::Dump(n.parametersAsYaml()), YAML::Dump(params));
    }
  }
}

TEST(Descriptions, RegisteredDescriptionsMatchTheFilesOnDisk) {
  for (const DfnDescription* d : Registry::instance().descriptions()) {
    SCOPED_TRACE(d->source_file);
    const std::filesystem::path path = std::filesystem::path(CDFF_SOURCE_DIR) / d->source_file;
    ASSERT_TRUE(std::filesystem::exists(path));
    const YAML::Node file = YAML::LoadFile(path.string());
    EXPECT_EQ(file["name"].as<std::string>(), d->name);
    EXPECT_EQ(names(file["inputs"]), names(d->inputs));
    EXPECT_EQ(names(file["outputs"]), names(d->outputs));
    EXPECT_EQ(names(file["implementations"]), names(d->implementations));
    for (const auto& impl_node : file["implementations"]) {
      const ImplementationSpec* impl = d->findImplementation(impl_node["name"].as<std::string>());
      ASSERT_NE(impl, nullptr);
      std::vector<std::string> expected =
          file["parameters"] ? names(file["parameters"]) : std::vector<std::string>{};
      if (impl_node["parameters"])
        for (const auto& n : names(impl_node["parameters"])) expected.push_back(n);
      EXPECT_EQ(names(impl->parameters), expected) << impl->name;
    }
  }
}

TEST(Descriptions, EveryDfnAreaHasAUnitTest) {
  for (const DfnDescription* d : Registry::instance().descriptions()) {
    const std::filesystem::path folder =
        (std::filesystem::path(CDFF_SOURCE_DIR) / d->source_file).parent_path();
    if (d->area == "probe") continue;  // the framework's own test fixture
    bool has_test = false;
    for (const auto& entry : std::filesystem::directory_iterator(folder))
      has_test |= entry.path().filename().string().ends_with("_test.cpp");
    EXPECT_TRUE(has_test) << d->name << " has no *_test.cpp in " << folder;
  }
}

TEST(Descriptions, EveryPortTypeNameResolvesToTheRunningPortsType) {
  // The DFPC layer checks connections and reads recordings by type name (findType); the name
  // must give the very type the generated ports hold.
  std::set<std::string_view> names;
  for (TypeId t : allTypes()) {
    EXPECT_TRUE(names.insert(t.name()).second) << "type name " << t.name() << " is used twice";
    EXPECT_EQ(findType(t.name()), t);
  }
  EXPECT_FALSE(findType("Imgae").valid());
  EXPECT_EQ(TypeId().name(), "none");
  for (const DfnDescription* d : Registry::instance().descriptions()) {
    for (const auto& impl : d->implementations) {
      auto node = Registry::instance().create(d->name, impl.name);
      ASSERT_TRUE(node.isOk()) << node.status().toString();
      for (const InputPortBase* in : node.value()->inputs()) {
        EXPECT_EQ(findType(in->type().name()), in->type()) << d->name << " input " << in->name();
        const PortSpec* spec = nullptr;
        for (const PortSpec& p : d->inputs)
          if (p.name == in->name()) spec = &p;
        ASSERT_NE(spec, nullptr) << d->name << " input " << in->name();
        EXPECT_EQ(spec->type, in->type().name()) << d->name << " input " << in->name();
      }
      for (const OutputPortBase* out : node.value()->outputs()) {
        EXPECT_EQ(findType(out->type().name()), out->type())
            << d->name << " output " << out->name();
        const PortSpec* spec = nullptr;
        for (const PortSpec& p : d->outputs)
          if (p.name == out->name()) spec = &p;
        ASSERT_NE(spec, nullptr) << d->name << " output " << out->name();
        EXPECT_EQ(spec->type, out->type().name()) << d->name << " output " << out->name();
      }
    }
  }
}

}  // namespace
}  // namespace cdff::dfn
