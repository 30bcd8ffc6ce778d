#pragma once
// Reading and checking DFN parameters against their ParameterSpecs. The generated code of each
// DFI calls these, one line per parameter; errors name the file, line, key, value and the
// accepted range.

#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "cdff/dfn/description.hpp"
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
  std::string where(const YAML::Node& node) const;
  template <typename T>
  void readScalar(const ParameterSpec& spec, T& value, const char* type_name);

  YAML::Node node_;
  std::string source_;
  std::string owner_;
  Status status_;
};

/// Ok when `value` satisfies `spec`'s range; otherwise a message "parameter 'x' = v is out of
/// range; expected [a, b]" (without location).
Status checkNumber(const ParameterSpec& spec, double value, const std::string& value_text);
Status checkString(const ParameterSpec& spec, const std::string& value);
Status checkList(const ParameterSpec& spec, const std::vector<double>& value);

}  // namespace cdff::dfn
