#pragma once
// Distributions that consistency checks and gates need (NEES / NIS tests, innovation gating).

namespace cdff {

/// P(X <= x) for X ~ chi-square with `dof` degrees of freedom (regularised lower incomplete gamma).
double chiSquareCdf(double x, int dof);
/// The x with chiSquareCdf(x, dof) = p, for p in (0, 1); NaN outside.
double chiSquareQuantile(double p, int dof);

}  // namespace cdff
