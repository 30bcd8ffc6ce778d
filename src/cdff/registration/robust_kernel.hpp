#pragma once
// Robust kernels of the ICP's iteratively reweighted least squares: each pair's weight
// w(r) = rho'(r) / r, with each kernel's usual tuning constant in units of the residual scale s
// (95 % efficiency on Gaussian noise for Huber and Tukey). The scale adapts to the residuals
// (1.4826 x their median absolute value, as in KISS-ICP) unless it is fixed.

#include <string>

namespace cdff::registration {

enum class RobustKernel { kNone, kHuber, kTukey, kGemanMcClure };

/// The kernel named "none", "huber", "tukey" or "geman_mcclure" (any other name: none).
RobustKernel robustKernelNamed(const std::string& name);

/// The weight of residual `r` at scale `s`.
double robustWeight(RobustKernel kernel, double r, double s);

}  // namespace cdff::registration
