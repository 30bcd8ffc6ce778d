#pragma once
// Node: the base of every DFN implementation (DFI).
//
// A DFN has two control entry points, configure() and process() (seed §4.2). The framework does
// the shared work around them so that a DFI only writes its algorithm:
//  - configure() parses parameters from YAML against the DFN description (unknown keys, wrong
//    types and out-of-range values are errors naming file, line, key, value and accepted range);
//  - process() checks that required inputs are present, times the call (wall and CPU), turns an
//    escaping exception into an error status, and on any error restores the outputs as they
//    were before the call, so that a failed call never leaves half-written results;
//  - diagnostics() keeps per-instance status, last error, warnings, call count and timings.

#include <chrono>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "cdff/dfn/description.hpp"
#include "cdff/dfn/port.hpp"
#include "cdff/types/status.hpp"

namespace cdff::dfn {

struct Diagnostics {
  Status last_status;
  std::string last_error;            // message of the most recent failed call ("" if none)
  std::deque<std::string> warnings;  // the most recent warnings (bounded)
  std::uint64_t warning_count = 0;
  std::uint64_t call_count = 0;
  std::uint64_t error_count = 0;
  double last_wall_s = 0, total_wall_s = 0, max_wall_s = 0;
  double last_cpu_s = 0, total_cpu_s = 0;

  double meanWallSeconds() const { return call_count ? total_wall_s / call_count : 0.0; }
  double meanCpuSeconds() const { return call_count ? total_cpu_s / call_count : 0.0; }
};

class Node {
 public:
  virtual ~Node() = default;
  Node(const Node&) = delete;
  Node& operator=(const Node&) = delete;

  const DfnDescription& description() const { return description_; }
  const ImplementationSpec& implementation() const { return implementation_; }
  /// "EdgeDetection/Canny", or the instance name a DFPC gave it.
  const std::string& name() const { return name_; }
  void setName(std::string name) { name_ = std::move(name); }

  /// Sets parameters from a YAML map (null: all defaults), angles in degrees as the description
  /// says (`unit: deg`). On error the previous parameters stay.
  Status configure(const YAML::Node& parameters, const std::string& source = "<inline>") {
    return configureIn(parameters, source, ParameterUnits::kYaml);
  }
  /// Loads a YAML file holding a map of parameters.
  Status configureFromFile(const std::string& path);
  /// Defaults for every parameter.
  Status configureDefaults() { return configure(YAML::Node(), "<defaults>"); }
  bool isConfigured() const { return configured_; }

  /// Runs the DFI on its current inputs. Configures with defaults first if never configured.
  Status process();

  const Diagnostics& diagnostics() const { return diagnostics_; }
  void resetDiagnostics() { diagnostics_ = {}; }

  const std::vector<InputPortBase*>& inputs() const { return inputs_; }
  const std::vector<OutputPortBase*>& outputs() const { return outputs_; }
  InputPortBase* findInput(std::string_view name) const;
  OutputPortBase* findOutput(std::string_view name) const;

  /// The current parameters as YAML, in its units (angles in degrees), for logs and
  /// `cdff dfn info`; configure() accepts it back.
  virtual YAML::Node parametersAsYaml() const = 0;

 protected:
  Node(const DfnDescription& description, const std::string& implementation);

  void registerInput(InputPortBase& port) { inputs_.push_back(&port); }
  void registerOutput(OutputPortBase& port) { outputs_.push_back(&port); }

  /// configure(), with the map's values in `units` (kSi: a C++ parameter struct, in radians).
  Status configureIn(const YAML::Node& parameters, const std::string& source, ParameterUnits units);
  /// Generated per DFI: parse `parameters`, in `units`, into the DFI's parameter struct (or fail).
  virtual Status applyParameters(const YAML::Node& parameters, const std::string& source,
                                 ParameterUnits units) = 0;
  /// DFI hook after parameters changed (build detectors, allocate buffers...).
  virtual Status onConfigure() { return Status::ok(); }
  /// The DFI's algorithm: read inputs, write outputs, return a status with a reason on failure.
  virtual Status onProcess() = 0;

  /// Records a warning in the diagnostics (e.g. "few features found"); the call still succeeds.
  void warn(std::string message);

 private:
  const DfnDescription& description_;
  const ImplementationSpec& implementation_;
  std::string name_;
  bool configured_ = false;
  std::vector<InputPortBase*> inputs_;
  std::vector<OutputPortBase*> outputs_;
  Diagnostics diagnostics_;
};

}  // namespace cdff::dfn
