// cdff_dfn_describe DESCRIPTION.yaml --area AREA --source-file PATH --out OUT.json
//
// Build-time step before the DFN code generator: reads and checks a DFN description with the
// schema reader (loadDescription) and writes it as JSON with each port's C++ type from the type
// registry, so that the generator (scripts/dfn_codegen.py) has neither a YAML checker nor a type
// list of its own. An error is printed as the schema reader writes it and fails the build.
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <variant>

#include <nlohmann/json.hpp>

#include "cdff/dfn/description.hpp"
#include "cdff/types/type_registry.hpp"

namespace {

using nlohmann::json;

json portsJson(const std::vector<cdff::dfn::PortSpec>& ports) {
  json out = json::array();
  for (const auto& p : ports)
    out.push_back({{"name", p.name},
                   {"type", p.type},
                   {"cpp_type", std::string(cdff::findType(p.type).info().cpp_name)},
                   {"doc", p.doc},
                   {"optional", p.optional}});
  return out;
}

json parameterJson(const cdff::dfn::ParameterSpec& p) {
  json value = std::visit([](const auto& v) { return json(v); }, p.default_value);
  return {{"name", p.name},
          {"type", cdff::dfn::toString(p.type)},
          {"default", value},
          {"default_text", p.default_text},
          {"unit", p.unit},
          {"si_unit", cdff::dfn::siUnit(p.unit)},
          {"si_factor", cdff::dfn::siPerUnit(p.unit)},
          {"doc", p.doc},
          {"min", p.min ? json(*p.min) : json(nullptr)},
          {"max", p.max ? json(*p.max) : json(nullptr)},
          {"values", p.allowed},
          {"size", p.list_size ? json(*p.list_size) : json(nullptr)}};
}

json descriptionJson(const cdff::dfn::DfnDescription& d) {
  json impls = json::array();
  for (const auto& impl : d.implementations) {
    json parameters = json::array();
    for (const auto& p : impl.parameters) parameters.push_back(parameterJson(p));
    impls.push_back({{"name", impl.name},
                     {"doc", impl.doc},
                     {"dependencies", impl.dependencies},
                     {"parameters", parameters}});
  }
  return {{"name", d.name},
          {"doc", d.doc},
          {"area", d.area},
          {"source_file", d.source_file},
          {"inputs", portsJson(d.inputs)},
          {"outputs", portsJson(d.outputs)},
          {"implementations", impls}};
}

}  // namespace

int main(int argc, char** argv) {
  std::string description, area, source_file, out_path;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--area" && i + 1 < argc) {
      area = argv[++i];
    } else if (arg == "--source-file" && i + 1 < argc) {
      source_file = argv[++i];
    } else if (arg == "--out" && i + 1 < argc) {
      out_path = argv[++i];
    } else if (description.empty() && !arg.starts_with("-")) {
      description = arg;
    } else {
      std::fprintf(stderr,
                   "usage: cdff_dfn_describe DESCRIPTION.yaml --area AREA --source-file PATH "
                   "--out OUT.json\n");
      return 2;
    }
  }
  if (description.empty() || out_path.empty()) {
    std::fprintf(stderr, "cdff_dfn_describe: a description and --out are required\n");
    return 2;
  }
  cdff::Result<cdff::dfn::DfnDescription> d =
      cdff::dfn::loadDescription(description, area, source_file);
  if (!d) {
    std::fprintf(stderr, "error: %s\n", d.status().message().c_str());
    return 1;
  }
  const std::string text = descriptionJson(*d).dump(1) + "\n";
  {
    std::ifstream in(out_path, std::ios::binary);
    std::stringstream existing;
    existing << in.rdbuf();
    if (in && existing.str() == text) return 0;  // unchanged: keep the time stamp
  }
  std::ofstream out(out_path, std::ios::binary | std::ios::trunc);
  if (!out || !(out << text)) {
    std::fprintf(stderr, "cdff_dfn_describe: cannot write '%s'\n", out_path.c_str());
    return 1;
  }
  return 0;
}
