#include "cdff/registration/robust_kernel.hpp"

#include <cmath>

namespace cdff::registration {

RobustKernel robustKernelNamed(const std::string& name) {
  if (name == "huber") return RobustKernel::kHuber;
  if (name == "tukey") return RobustKernel::kTukey;
  if (name == "geman_mcclure") return RobustKernel::kGemanMcClure;
  return RobustKernel::kNone;
}

double robustWeight(RobustKernel kernel, double r, double s) {
  switch (kernel) {
    case RobustKernel::kNone:
      return 1.0;
    case RobustKernel::kHuber: {
      const double k = 1.345 * s;
      return std::abs(r) <= k ? 1.0 : k / std::abs(r);
    }
    case RobustKernel::kTukey: {
      const double c = 4.685 * s;
      if (std::abs(r) >= c) return 0.0;
      const double u = 1.0 - (r / c) * (r / c);
      return u * u;
    }
    case RobustKernel::kGemanMcClure: {
      const double c = 2.0 * s;
      const double u = c * c / (c * c + r * r);
      return u * u;
    }
  }
  return 1.0;
}

}  // namespace cdff::registration
