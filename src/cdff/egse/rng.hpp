#pragma once
// Reproducible random numbers for the simulator.
//
// std::mt19937_64 is specified bit for bit by the C++ standard, but std:: distributions are not
// (each standard library may turn the same engine output into different numbers). The simulator
// therefore draws from the engine's raw 64-bit output and turns it into numbers with its own
// code: 53-bit uniforms, a ziggurat for normals (Marsaglia & Tsang, 2000) whose tables are built
// at start-up, and Knuth/normal-approximation Poisson draws. The same seed gives the same numbers
// with any compiler and standard library (up to the last bit of std::exp/std::log, which glibc
// rounds correctly).
//
// Every sensor draws from its own stream, derived from the run's seed, the sensor's name and the
// measurement index (Rng::stream), so enabling one sensor never changes another one's noise and a
// measurement can be regenerated on its own.

#include <cstdint>
#include <random>
#include <string_view>

namespace cdff::egse {

class Rng {
 public:
  explicit Rng(std::uint64_t seed = 0) : engine_(seed) {}

  /// The stream of measurement `index` of the sensor (or process) `name` in a run seeded `seed`.
  static Rng stream(std::uint64_t seed, std::string_view name, std::uint64_t index = 0);

  std::uint64_t next() { return engine_(); }
  /// Uniform in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  double uniform(double low, double high) { return low + (high - low) * uniform(); }
  /// Uniform integer in [0, n), without modulo bias; n > 0.
  std::uint64_t below(std::uint64_t n);
  bool bernoulli(double p) { return uniform() < p; }
  /// Standard normal.
  double normal();
  double normal(double mean, double sigma) { return mean + sigma * normal(); }
  /// Poisson with mean `lambda` (exact below 30, normal approximation above).
  std::int64_t poisson(double lambda);

 private:
  std::mt19937_64 engine_;
};

/// SplitMix64 finaliser: a well-mixed 64-bit hash of `x`, used to derive stream seeds.
std::uint64_t mix64(std::uint64_t x);
/// FNV-1a hash of a name.
std::uint64_t hashName(std::string_view name);

}  // namespace cdff::egse
