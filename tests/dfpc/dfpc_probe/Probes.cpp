// The test-only DFIs of the DFPC framework tests.
#include <cmath>

#include "ProbeDetector.gen.hpp"
#include "ProbePair.gen.hpp"
#include "ProbeRelay.gen.hpp"
#include "ProbeTicker.gen.hpp"
#include "ProbeTracker.gen.hpp"
#include "probe_clock.hpp"

namespace cdff::dfpc::testing {
SimulatedClock& probeExecutionClock() {
  static SimulatedClock clock(0);
  return clock;
}
}  // namespace cdff::dfpc::testing

namespace cdff::dfn {

namespace {
template <typename Base>
class Relay : public Base {
 protected:
  Status onProcess() override {
    const auto& p = this->params_;
    if (p.duration_s > 0) dfpc::testing::probeExecutionClock().advanceBy(fromSeconds(p.duration_s));
    const double a = *this->in.a;
    if (a > p.fail_above)
      return numericalFailure("a = {} is above fail_above = {}", a, p.fail_above);
    double out = a + p.offset;
    if (this->in.b.hasValue()) out += *this->in.b;
    this->out.result.set(out);
    this->out.calls.set(++calls_);
    return Status::ok();
  }

 private:
  int calls_ = 0;
};
}  // namespace

class ProbeRelayPlain final : public Relay<ProbeRelayPlainBase> {};
CDFF_REGISTER_DFI(ProbeRelayPlain);
class ProbeRelayAlternative final : public Relay<ProbeRelayAlternativeBase> {};
CDFF_REGISTER_DFI(ProbeRelayAlternative);

class ProbeTrackerGated final : public ProbeTrackerGatedBase {
 protected:
  Status onProcess() override {
    if (in.initial.isFresh()) {
      estimate_ = *in.initial;
      initialised_ = true;
    }
    if (in.measurement.isFresh()) {
      const double m = *in.measurement;
      if (!initialised_) {
        out.status.set(TrackState::kUninitialised);
        return Status::ok();
      }
      if (!std::isfinite(m) || std::abs(m - estimate_) > params_.gate) {
        initialised_ = false;
        out.status.set(TrackState::kLost);
        return Status::ok();
      }
      estimate_ = m;
    }
    if (initialised_) {
      out.estimate.set(estimate_);
      out.status.set(TrackState::kTracking);
    }
    return Status::ok();
  }

 private:
  bool initialised_ = false;
  double estimate_ = 0;
};
CDFF_REGISTER_DFI(ProbeTrackerGated);

class ProbeDetectorOracle final : public ProbeDetectorOracleBase {
 protected:
  Status onProcess() override {
    if (!std::isfinite(*in.measurement)) {
      warn("no target in view");
      return Status::ok();
    }
    out.detection.set(*in.measurement);
    return Status::ok();
  }
};
CDFF_REGISTER_DFI(ProbeDetectorOracle);

class ProbePairEcho final : public ProbePairEchoBase {
 protected:
  Status onProcess() override {
    out.left_seen.set(*in.left);
    out.right_seen.set(*in.right);
    return Status::ok();
  }
};
CDFF_REGISTER_DFI(ProbePairEcho);

class ProbeTickerCounter final : public ProbeTickerCounterBase {
 protected:
  Status onProcess() override {
    out.ticks.set(++ticks_);
    if (in.time.isFresh()) out.time_seen.set(*in.time);
    return Status::ok();
  }

 private:
  int ticks_ = 0;
};
CDFF_REGISTER_DFI(ProbeTickerCounter);

}  // namespace cdff::dfn
