// End to end: the detection DFPC (dfpcs/detection.yaml) through the Orchestrator on simulated
// stereo frames of the procedural target (simulator's Prosilica pair, distorted, unrectified),
// each a drawn attitude (uniform on SO(3)), range and pointing under the lighting of a library
// scenario, evaluated against the simulator's truth. The templates come from `cdff train` (the
// test fixture `detection_templates`: 4-8 m, 20 degree steps, for the rectified left camera).
// Frames: the evaluation draws' seeds (data/evaluation/draws.yaml), none tuned on.
//
// DetectionTofSimulated: the ToF detection DFPC (dfpcs/detection_tof.yaml) on the ToF camera's
// depth maps of the same kind of draws, with the ToF fixture's templates (`cdff train --sensor
// tof`: 3.4-8.3 m, 20 degree steps). The two suites are discovered apart, each with its fixture.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>

#include "cdff/eval/draws.hpp"
#include "simulated_views.hpp"
#include "support/synthetic.hpp"

#ifndef CDFF_SOURCE_DIR
#define CDFF_SOURCE_DIR "."
#endif

namespace cdff::detection_demo {
namespace {

constexpr double kDeg = M_PI / 180.0;

std::vector<std::string> settings() {
  return {std::string("detect.template_file=") + CDFF_DETECTION_TEMPLATES};
}

std::vector<eval::Draw> draws(std::size_t n) {
  Result<eval::DrawSets> sets =
      eval::loadDrawSets(std::string(CDFF_SOURCE_DIR) + "/data/evaluation/draws.yaml");
  EXPECT_OK(sets.status());
  return sets ? sets->evaluationDraws(n) : std::vector<eval::Draw>{};
}

/// What the detection made of `n` evaluation draws' frames.
struct Tally {
  std::size_t frames = 0, detected = 0, right = 0, wrong = 0, errors = 0;
};

/// Runs `detector` on the frames of the first `n` evaluation draws, one line each; `check_right`
/// gets every frame detected right (within 1 % of the range and 2 degrees).
Tally runDraws(
    Detector& detector, const ViewOptions& options, std::size_t n,
    const std::function<void(const SimulatedView&, const DetectionOutcome&)>& check_right) {
  Tally t;
  double nees_sum = 0, cpu_sum = 0;
  for (const eval::Draw& draw : draws(n)) {
    Result<SimulatedView> view = simulateView(options, draw.simulator_seed);
    EXPECT_OK(view.status());
    if (!view) return t;
    Result<DetectionOutcome> r = detector.run(*view);
    EXPECT_OK(r.status());
    if (!r) return t;
    ++t.frames;
    t.errors += r->dfn_errors;
    cpu_sum += r->cpu_s;
    std::printf(
        "draw %llu (%s, %.2f m): detected %d, error %.3f m %.2f deg, NEES %.1f, fitness %.2f, "
        "confirmed %.2f, misfit %.2f, %.0f ms\n",
        static_cast<unsigned long long>(draw.number), view->lighting.c_str(), view->range,
        r->detected, r->position_error, r->angle_error / kDeg, r->nees, r->fitness, r->confirmed,
        r->misfit, r->cpu_s * 1e3);
    if (!r->detected) continue;
    ++t.detected;
    if (r->position_error <= 0.01 * view->range && r->angle_error <= 2 * kDeg) {
      ++t.right;
      nees_sum += r->nees;
      check_right(*view, *r);
    } else {
      ++t.wrong;
    }
  }
  std::printf("%zu frames: detected %zu, right %zu, wrong %zu; mean NEES %.1f; %.0f ms per frame\n",
              t.frames, t.detected, t.right, t.wrong, t.right ? nees_sum / t.right : NAN,
              t.frames ? cpu_sum / t.frames * 1e3 : NAN);
  return t;
}

// Frames of the target at 4-8.5 m (the fixture's template ranges). The bounds are regression
// bounds near today's figures (2026-12-06: 4 of 12 detected, all right within 1 % of the range
// and 2 degrees; the others get no candidate near the truth or are reported ambiguous); the
// issue's goal, 95 % right, is not met yet (docs/detection.md).
TEST(DetectionSimulated, DetectsTheTargetUnderTheLibrarysLighting) {
  ViewOptions options;
  options.min_range = 4.0;
  options.max_range = 8.5;
  Result<std::unique_ptr<Detector>> detector = Detector::create(settings());
  ASSERT_OK(detector.status());
  const Tally t =
      runDraws(**detector, options, 12, [](const SimulatedView& view, const DetectionOutcome& r) {
        // The same pose through the frame chain (rectified left -> left optical -> servicer).
        EXPECT_EQ(r.pose.pose.parent_frame, view.truth.parent_frame);
        EXPECT_LE((r.pose.pose.translation - view.truth.translation).norm(), 0.01 * view.range);
        EXPECT_LE(angularDistance(r.pose.pose.rotation, view.truth.rotation), 2 * kDeg);
        EXPECT_GT(r.pose.covariance(6, 6), 0.0);  // the twist is unknown, not exact
      });
  EXPECT_EQ(t.errors, 0u);
  EXPECT_GE(t.right, 3u);
  EXPECT_EQ(t.wrong, 0u);
}

// Frames with the cameras turned away from the target (stars, the Earth, empty space): never a
// detection (the goal: at most 1 % of frames).
TEST(DetectionSimulated, FramesWithoutTheTargetGiveNoDetection) {
  Result<std::unique_ptr<Detector>> detector = Detector::create(settings());
  ASSERT_OK(detector.status());
  for (const eval::Draw& draw : draws(6)) {
    Result<SimulatedView> view = simulateView(ViewOptions{}, draw.simulator_seed, false);
    ASSERT_OK(view.status());
    Result<DetectionOutcome> r = (*detector)->run(*view);
    ASSERT_OK(r.status());
    EXPECT_FALSE(r->detected) << "draw " << draw.number << " (" << view->lighting << ")";
    EXPECT_EQ(r->dfn_errors, 0u);
  }
}

// A missing template file is refused when the graph is built, naming the node, the parameter and
// the file.
TEST(DetectionSimulated, AMissingTemplateFileIsAClearError) {
  Result<std::unique_ptr<Detector>> detector =
      Detector::create({"detect.template_file=/nonexistent/templates.yml.gz"});
  ASSERT_FALSE(detector.isOk());
  const std::string message = detector.status().message();
  EXPECT_NE(message.find("/nonexistent/templates.yml.gz"), std::string::npos) << message;
  EXPECT_NE(message.find("detect"), std::string::npos) << message;
}

std::vector<std::string> tofSettings() {
  return {std::string("detect.template_file=") + CDFF_DETECTION_TOF_TEMPLATES};
}

Result<std::unique_ptr<Detector>> tofDetector(const std::vector<std::string>& s = tofSettings()) {
  return Detector::create(s, "", DepthSource::kTof);
}

// Depth maps of the target at 4-8 m (within the fixture's template ranges). The bounds are
// regression bounds near today's figures (2026-12-06: 5 of 12 detected, all within 1 % of the
// range and 2 degrees; the others withheld, mostly because a half turn fits the depth about as
// well); the goal is 95 % within 1 % of the range and 2 degrees (docs/detection.md).
TEST(DetectionTofSimulated, DetectsTheTargetInTheToFDepth) {
  ViewOptions options;
  options.source = DepthSource::kTof;
  options.min_range = 4.0;
  options.max_range = 8.0;
  Result<std::unique_ptr<Detector>> detector = tofDetector();
  ASSERT_OK(detector.status());
  const Tally t =
      runDraws(**detector, options, 12, [](const SimulatedView& view, const DetectionOutcome& r) {
        EXPECT_EQ(r.pose.pose.parent_frame, view.truth.parent_frame);
        EXPECT_GT(r.pose.covariance(6, 6), 0.0);  // the twist is unknown, not exact
      });
  EXPECT_EQ(t.errors, 0u);
  EXPECT_GE(t.right, 4u);
  EXPECT_LE(t.wrong, 1u);
}

// Depth maps with the ToF camera turned away from the target: never a detection.
TEST(DetectionTofSimulated, DepthMapsWithoutTheTargetGiveNoDetection) {
  Result<std::unique_ptr<Detector>> detector = tofDetector();
  ASSERT_OK(detector.status());
  ViewOptions options;
  options.source = DepthSource::kTof;
  for (const eval::Draw& draw : draws(4)) {
    Result<SimulatedView> view = simulateView(options, draw.simulator_seed, false);
    ASSERT_OK(view.status());
    Result<DetectionOutcome> r = (*detector)->run(*view);
    ASSERT_OK(r.status());
    EXPECT_FALSE(r->detected) << "draw " << draw.number;
    EXPECT_EQ(r->dfn_errors, 0u);
  }
}

// A missing template file is refused when the graph is built, naming the node and the file.
TEST(DetectionTofSimulated, AMissingTemplateFileIsAClearError) {
  Result<std::unique_ptr<Detector>> detector =
      tofDetector({"detect.template_file=/nonexistent/tof_templates.yml.gz"});
  ASSERT_FALSE(detector.isOk());
  const std::string message = detector.status().message();
  EXPECT_NE(message.find("/nonexistent/tof_templates.yml.gz"), std::string::npos) << message;
  EXPECT_NE(message.find("detect"), std::string::npos) << message;
}

}  // namespace
}  // namespace cdff::detection_demo
