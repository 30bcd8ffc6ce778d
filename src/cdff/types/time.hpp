#pragma once
// Time in CDFF is an int64 count of microseconds (see docs/conventions.md).

#include <cstdint>

namespace cdff {

/// Microseconds since an epoch chosen by the data source (simulation start, UNIX epoch, ...).
using Timestamp = std::int64_t;

constexpr Timestamp kMicrosecondsPerSecond = 1'000'000;

constexpr double toSeconds(Timestamp t) { return static_cast<double>(t) * 1e-6; }
constexpr Timestamp fromSeconds(double seconds) {
  return static_cast<Timestamp>(seconds * 1e6 + (seconds >= 0 ? 0.5 : -0.5));
}

}  // namespace cdff
