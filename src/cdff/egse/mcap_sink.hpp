#pragma once
// The simulator's MCAP output: a SimulationSink writing every message through cdff::io::Recorder
// (what `cdff sim -o` and the Python binding's cdff.sim.run write).

#include <memory>
#include <string>

#include "cdff/egse/sink.hpp"
#include "cdff/types/status.hpp"

namespace cdff::egse {

/// A sink writing `path` (MCAP), or an error saying why there is none.
Result<std::unique_ptr<SimulationSink>> openMcapSink(const std::string& path);

}  // namespace cdff::egse
