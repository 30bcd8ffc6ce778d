#pragma once
// What a DFN type is, as written in its YAML description file: ports, parameters and
// implementations (DFIs). loadDescription() reads and checks a file (the one schema reader,
// cdff/schema); at build time `cdff_dfn_describe` runs it on every description and hands the
// checked result, with each port's C++ type from the type registry, to the code generator
// (scripts/dfn_codegen.py), so the running code and its description cannot disagree.

#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "cdff/types/status.hpp"

namespace cdff::dfn {

struct PortSpec {
  std::string name;
  std::string type;  // a data type name of the type registry, e.g. "Image"
  std::string doc;
  bool optional = false;  // inputs only: process() may run without it
};

enum class ParameterType { kBool, kInt, kDouble, kString, kDoubleList };

const char* toString(ParameterType type);
/// "bool", "int", "double", "string", "double[]" -> the type; none otherwise.
std::optional<ParameterType> parameterTypeNamed(std::string_view name);

/// Angles are written in degrees in YAML (a person reasons in degrees) and held in radians in
/// C++ (SI, as every computation uses them): a parameter whose description says `unit: deg` or
/// `unit: deg/s` has its default, range and YAML values in degrees, and its C++ field in rad or
/// rad/s. Every other unit is the same in YAML and in C++.
inline constexpr double kRadiansPerDegree = std::numbers::pi / 180.0;

/// How many SI units (those of the C++ field) one unit of a description's `unit` is:
/// kRadiansPerDegree for "deg" and "deg/s", 1 otherwise.
double siPerUnit(std::string_view unit);
/// The unit of the C++ field: "rad" for "deg", "rad/s" for "deg/s", `unit` otherwise.
std::string siUnit(std::string_view unit);

/// The units of the values of a parameter map: as written in YAML (degrees for `unit: deg`), or
/// as the C++ parameter struct holds them (SI: radians), for a struct set from C++.
enum class ParameterUnits { kYaml, kSi };

/// A parameter's default value, typed as its ParameterType (kInt: long long).
using ParameterValue = std::variant<bool, long long, double, std::string, std::vector<double>>;

struct ParameterSpec {
  std::string name;
  ParameterType type = ParameterType::kDouble;
  std::string default_text;      // the default as written in YAML
  ParameterValue default_value;  // in `unit`, as written
  std::string unit;              // the YAML unit ("deg" for angles), "" when dimensionless
  std::optional<double> min;     // inclusive bounds for numbers (and list elements), in `unit`
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

/// Reads and checks a DFN description file: keys, names (CamelCase types, snake_case ports and
/// parameters, not C++ keywords), port types (registered data types), parameter types, defaults
/// within their ranges and choices, no name twice, angles in degrees (`deg`, `deg/s`; not `rad`,
/// `rad/s`). `area` is the folder under dfns/, `source_file` the repository-relative path
/// recorded in the description. Errors have the schema reader's format: file:line:column, key
/// path, value, expected.
Result<DfnDescription> loadDescription(const std::string& path, const std::string& area,
                                       const std::string& source_file);

}  // namespace cdff::dfn
