#pragma once
// What a DFN type is, as written in its YAML description file: ports, parameters and
// implementations (DFIs). The build generates one DfnDescription per file (scripts/dfn_codegen.py),
// so the running code and its description cannot disagree.

#include <optional>
#include <string>
#include <vector>

namespace cdff::dfn {

struct PortSpec {
  std::string name;
  std::string type;  // a PortTypeName, e.g. "Image"
  std::string doc;
  bool optional = false;  // inputs only: process() may run without it
};

enum class ParameterType { kBool, kInt, kDouble, kString, kDoubleList };

const char* toString(ParameterType type);

struct ParameterSpec {
  std::string name;
  ParameterType type = ParameterType::kDouble;
  std::string default_text;   // the default as written in YAML
  std::string unit;           // SI unit, "" when dimensionless
  std::optional<double> min;  // inclusive bounds for numbers (and list elements)
  std::optional<double> max;
  std::vector<std::string> allowed;      // for strings: the accepted values (empty: any)
  std::optional<std::size_t> list_size;  // for lists: the required length (empty: any)
  std::string doc;

  /// "[0, 255]", "{a, b}", "any" ...
  std::string acceptedText() const;
};

struct ImplementationSpec {
  std::string name;
  std::string doc;
  std::vector<std::string> dependencies;  // external libraries, e.g. "OpenCV"
  std::vector<ParameterSpec> parameters;  // the DFN's common parameters come first
};

struct DfnDescription {
  std::string name;
  std::string area;  // folder under dfns/, e.g. "image"
  std::string doc;
  std::string source_file;  // the YAML file it was generated from (repository-relative)
  std::vector<PortSpec> inputs;
  std::vector<PortSpec> outputs;
  std::vector<ImplementationSpec> implementations;

  const ImplementationSpec* findImplementation(const std::string& name) const;
};

}  // namespace cdff::dfn
