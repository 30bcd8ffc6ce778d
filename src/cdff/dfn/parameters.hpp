#pragma once
// Reading and checking DFN parameters against their ParameterSpecs, with the schema reader (one
// error format: file:line:column, the DFN, key, value, what was expected). The generated code of
// each DFI calls these, one line per parameter. A parameter in degrees (`unit: deg`, `deg/s`) is
// read, range-checked and reported in degrees and stored in radians (description.hpp).

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "cdff/dfn/description.hpp"
#include "cdff/schema/field.hpp"
#include "cdff/types/status.hpp"

namespace cdff::dfn {

class ParameterReader {
 public:
  /// `node` is a YAML map (or null: all defaults); `source` names where it came from (a file
  /// path, or "<inline>"); `owner` names the DFN and DFI ("EdgeDetection/Canny"). `units`: the
  /// map's values are as written in YAML (degrees), or SI (radians, from a C++ struct; checked
  /// against the range converted to radians).
  ParameterReader(const YAML::Node& node, std::string source, std::string owner,
                  ParameterUnits units = ParameterUnits::kYaml);

  void read(const ParameterSpec& spec, bool& value);
  void read(const ParameterSpec& spec, int& value);
  void read(const ParameterSpec& spec, double& value);
  void read(const ParameterSpec& spec, std::string& value);
  void read(const ParameterSpec& spec, std::vector<double>& value);

  /// The first error met, or an error for any key of the map that is not in `specs`.
  Status finish(const std::vector<ParameterSpec>& specs) const;

 private:
  /// The parameter's field when the map gives it and no error came before.
  std::optional<schema::Field> given(const ParameterSpec& spec) const;
  void keep(Status status);

  /// The spec's range in the units of the map, and the factor from those to the C++ field's.
  schema::Range rangeOf(const ParameterSpec& spec) const;
  double factorOf(const ParameterSpec& spec) const;

  schema::Field root_;
  std::string owner_;
  ParameterUnits units_;
  Status status_;
};

/// A C++ (SI) value in `units` for a parameter of the description's `unit`: with
/// ParameterUnits::kYaml and `deg`, the shortest number of degrees that reads back as the same
/// radians (when one does); unchanged otherwise (the generated toYaml()).
double inUnits(double value, std::string_view unit, ParameterUnits units);
std::vector<double> inUnits(const std::vector<double>& values, std::string_view unit,
                            ParameterUnits units);

}  // namespace cdff::dfn
