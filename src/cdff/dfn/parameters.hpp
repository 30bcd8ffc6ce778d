#pragma once
// Reading and checking DFN parameters against their ParameterSpecs, with the schema reader (one
// error format: file:line:column, the DFN, key, value, what was expected). The generated code of
// each DFI calls these, one line per parameter.

#include <memory>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "cdff/dfn/description.hpp"
#include "cdff/schema/field.hpp"
#include "cdff/types/status.hpp"

namespace cdff::dfn {

class ParameterReader {
 public:
  /// `node` is a YAML map (or null: all defaults); `source` names where it came from (a file
  /// path, or "<inline>"); `owner` names the DFN and DFI ("EdgeDetection/Canny").
  ParameterReader(const YAML::Node& node, std::string source, std::string owner);

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

  schema::Field root_;
  std::string owner_;
  Status status_;
};

}  // namespace cdff::dfn
