#include <numeric>
#include <stdexcept>

#include "FrameworkProbe.gen.hpp"

namespace cdff::dfn {

class FrameworkProbeArithmetic final : public FrameworkProbeArithmeticBase {
 protected:
  Status onProcess() override {
    const double value = *in.value;
    if (value < 0) return numericalFailure("value {} is negative; expected >= 0", value);
    if (value == 13) throw std::runtime_error("unlucky value");
    if (value > 100) warn("value above 100");
    double result = value;
    if (params_.enabled) {
      for (int i = 0; i < params_.iterations; ++i)
        result = params_.mode == "add" ? result + params_.gain : result * params_.gain;
    }
    if (in.scale.hasValue()) result *= *in.scale;
    result += std::accumulate(params_.offsets.begin(), params_.offsets.end(), 0.0);
    out.result.set(result);
    out.calls.set(calls_ += 1);
    return Status::ok();
  }

 private:
  int calls_ = 0;
};

CDFF_REGISTER_DFI(FrameworkProbeArithmetic);

}  // namespace cdff::dfn
