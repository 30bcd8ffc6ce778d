#pragma once
// The execution clock that ProbeRelay advances by its `duration_s` during a call, so that a
// test can make a DFN call take a known time without sleeping.
#include "cdff/dfpc/clock.hpp"

namespace cdff::dfpc::testing {
SimulatedClock& probeExecutionClock();
}  // namespace cdff::dfpc::testing
