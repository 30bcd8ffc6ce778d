#include "cdff/egse/rng.hpp"

#include <array>
#include <cmath>

namespace cdff::egse {

std::uint64_t mix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

std::uint64_t hashName(std::string_view name) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (char c : name) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001b3ULL;
  }
  return h;
}

Rng Rng::stream(std::uint64_t seed, std::string_view name, std::uint64_t index) {
  return Rng(mix64(mix64(seed) ^ hashName(name)) ^ mix64(index + 0x632be59bd9b4e019ULL));
}

std::uint64_t Rng::below(std::uint64_t n) {
  // Rejects the top partial copy of [0, n) so that every value is equally likely.
  const std::uint64_t limit = ~std::uint64_t{0} - (~std::uint64_t{0} % n);
  std::uint64_t x;
  do x = next();
  while (x >= limit);
  return x % n;
}

namespace {

// Ziggurat tables for the standard normal with 256 layers (Marsaglia & Tsang 2000, "The
// ziggurat method for generating random variables"): x[i] are the layer edges, f[i] = pdf(x[i]).
struct ZigguratTables {
  static constexpr int kLayers = 256;
  static constexpr double kR = 3.6541528853610088;  // the base layer's edge for 256 layers
  static constexpr double kV = 0.00492867323399;    // the area of each layer
  std::array<double, kLayers + 1> x{};
  std::array<double, kLayers + 1> f{};

  ZigguratTables() {
    auto pdf = [](double v) { return std::exp(-0.5 * v * v); };
    x[0] = kV / pdf(kR);  // the base strip is a rectangle plus the tail
    x[1] = kR;
    for (int i = 2; i < kLayers; ++i)
      x[i] = std::sqrt(-2.0 * std::log(kV / x[i - 1] + pdf(x[i - 1])));
    x[kLayers] = 0.0;
    for (int i = 0; i <= kLayers; ++i) f[i] = pdf(x[i]);
  }
};

const ZigguratTables& ziggurat() {
  static const ZigguratTables tables;
  return tables;
}

}  // namespace

double Rng::normal() {
  const ZigguratTables& z = ziggurat();
  for (;;) {
    const std::uint64_t bits = next();
    const int layer = static_cast<int>(bits & 0xff);
    const bool negative = (bits >> 8) & 1;
    // 53 bits of the rest form a uniform in [0, 1).
    const double u = static_cast<double>(bits >> 11) * 0x1.0p-53;
    const double candidate = u * z.x[layer];
    if (candidate < z.x[layer + 1]) return negative ? -candidate : candidate;  // inside the core
    if (layer == 0) {
      // The tail beyond R (Marsaglia's method).
      double tail_x, tail_y;
      do {
        tail_x = -std::log(1.0 - uniform()) / ZigguratTables::kR;
        tail_y = -std::log(1.0 - uniform());
      } while (2.0 * tail_y < tail_x * tail_x);
      const double value = ZigguratTables::kR + tail_x;
      return negative ? -value : value;
    }
    // The wedge between the rectangle and the curve.
    const double y = z.f[layer] + uniform() * (z.f[layer + 1] - z.f[layer]);
    if (y < std::exp(-0.5 * candidate * candidate)) return negative ? -candidate : candidate;
  }
}

std::int64_t Rng::poisson(double lambda) {
  if (!(lambda > 0.0)) return 0;
  if (lambda < 30.0) {
    // Knuth: multiply uniforms until the product drops below exp(-lambda).
    const double limit = std::exp(-lambda);
    std::int64_t k = 0;
    double product = uniform();
    while (product > limit) {
      ++k;
      product *= uniform();
    }
    return k;
  }
  const double value = std::floor(lambda + std::sqrt(lambda) * normal() + 0.5);
  return value < 0.0 ? 0 : static_cast<std::int64_t>(value);
}

}  // namespace cdff::egse
