// Builds without the recording library (src/cdff/io) cannot write MCAP: say so.
#include "sim_command.hpp"

namespace cdff::app {

Result<std::unique_ptr<egse::SimulationSink>> openMcapSink(const std::string& path) {
  return Status(
      StatusCode::kNotFound,
      fmt::format(
          "cannot write '{}': this build of cdff has no recording library (src/cdff/io), so "
          "`cdff sim` can only --check scenarios and --export-model",
          path));
}

}  // namespace cdff::app
