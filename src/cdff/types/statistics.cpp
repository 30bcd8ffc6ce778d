#include "cdff/types/statistics.hpp"

#include <cmath>
#include <limits>

namespace cdff {

namespace {

// P(a, x) by its power series; converges quickly for x < a + 1.
double gammaPSeries(double a, double x) {
  double term = 1.0 / a, sum = term;
  for (int n = 1; n < 1000; ++n) {
    term *= x / (a + n);
    sum += term;
    if (std::abs(term) < std::abs(sum) * 1e-15) break;
  }
  return sum * std::exp(-x + a * std::log(x) - std::lgamma(a));
}

// Q(a, x) = 1 - P(a, x) by its continued fraction (modified Lentz); for x >= a + 1.
double gammaQContinuedFraction(double a, double x) {
  constexpr double kTiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / kTiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < 1e-15) break;
  }
  return std::exp(-x + a * std::log(x) - std::lgamma(a)) * h;
}

}  // namespace

double chiSquareCdf(double x, int dof) {
  if (dof <= 0 || std::isnan(x)) return std::numeric_limits<double>::quiet_NaN();
  if (x <= 0) return 0.0;
  const double a = 0.5 * dof, half_x = 0.5 * x;
  return half_x < a + 1.0 ? gammaPSeries(a, half_x) : 1.0 - gammaQContinuedFraction(a, half_x);
}

double chiSquareQuantile(double p, int dof) {
  if (!(p > 0.0 && p < 1.0) || dof <= 0) return std::numeric_limits<double>::quiet_NaN();
  // The CDF is monotonic: bracket, then bisect to machine precision.
  double low = 0.0, high = dof + 10.0 * std::sqrt(2.0 * dof) + 10.0;
  while (chiSquareCdf(high, dof) < p) high *= 2.0;
  for (int i = 0; i < 200 && high - low > 1e-12 * high; ++i) {
    const double mid = 0.5 * (low + high);
    (chiSquareCdf(mid, dof) < p ? low : high) = mid;
  }
  return 0.5 * (low + high);
}

}  // namespace cdff
