#pragma once
// The MCAP output of `cdff sim`: a SimulationSink writing through cdff::io::Recorder
// (sim_recording.cpp).

#include <memory>
#include <string>

#include "cdff/egse/sink.hpp"

namespace cdff::app {

/// A sink writing `path` (MCAP), or an error saying why there is none.
Result<std::unique_ptr<egse::SimulationSink>> openMcapSink(const std::string& path);

}  // namespace cdff::app
