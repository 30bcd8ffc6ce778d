// Detection and tracking as two DFPCs (the seed's Figure 5): the Orchestrator runs the detection
// DFPC only while the tracker is UNINITIALISED or LOST, the tracker starts from the detection's
// product; stereo pairs made from two image channels of a recording.
#include <gtest/gtest.h>

#include "cdff/dfpc/stereo_pairing.hpp"
#include "test_helpers.hpp"

namespace cdff::dfpc {
namespace {

using testing::makeDfpc;
using testing::number;
using testing::values;

const std::string kDetection = R"(name: detection
inputs: [{name: frame, type: Double, channel: /camera/frame}]
outputs: [{name: detection, type: Double}]
nodes:
  detector: {dfn: ProbeDetector, dfi: Oracle}
connections: [frame -> detector.measurement, detector.detection -> detection]
)";

const std::string kTracking = R"(name: tracking
inputs:
  - {name: frame, type: Double, channel: /camera/frame}
  - {name: initial, type: Double, channel: /cdff/tracking/initial}
outputs: [{name: pose, type: Double}]
track_state: {from: tracker.status, initial: UNINITIALISED}
nodes:
  tracker:
    dfn: ProbeTracker
    dfi: Gated
    trigger: {on: [measurement, initial]}
connections: [frame -> tracker.measurement, initial -> tracker.initial, tracker.estimate -> pose]
)";

std::unique_ptr<Orchestrator> detectThenTrack(MemorySink& sink) {
  OrchestratorOptions options;
  options.sink = &sink;
  auto o = std::make_unique<Orchestrator>(options);
  EXPECT_OK(o->add(makeDfpc(kDetection)));
  // The tracker's initial input reads the detection's product (cdff run --map).
  std::string tracking = kTracking;
  tracking.replace(tracking.find("/cdff/tracking/initial"), 22, "/cdff/detection/detection");
  EXPECT_OK(o->add(makeDfpc(tracking)));
  Result<ActivationRule> rule = parseActivationRule("detection=tracking:UNINITIALISED,LOST");
  EXPECT_OK(rule.status());
  EXPECT_OK(o->runWhile(std::move(rule).value()));
  EXPECT_OK(o->startAll());
  return o;
}

TEST(DetectThenTrack, DetectionRunsOnlyWhileTheTrackerIsUninitialisedOrLost) {
  MemorySink sink;
  auto o = detectThenTrack(sink);
  const double nan = std::nan("");
  // Tracked from frame 0 (detected there); lost at 2 (a jump) and re-detected at 3; lost at 4
  // (not visible) and re-detected at 5.
  const std::vector<double> frames{1.0, 1.1, 5.0, 5.1, nan, 5.2, 5.3};
  for (std::size_t k = 0; k < frames.size(); ++k)
    ASSERT_OK(o->process(number("/camera/frame", static_cast<double>(k), frames[k])));
  EXPECT_EQ(values(sink, "/cdff/tracking/pose"), (std::vector<double>{1.0, 1.1, 5.1, 5.2, 5.3}));
  EXPECT_EQ(values(sink, "/cdff/detection/detection"), (std::vector<double>{1.0, 5.1, 5.2}));
  std::vector<std::pair<EventType, Timestamp>> activation;
  for (const Event& e : sink.events())
    if (e.kind() == EventKind::kActivation && e.dfpc == "detection") {
      activation.emplace_back(e.type, e.stamp);
      EXPECT_TRUE(e.instance.empty());
    }
  using P = std::pair<EventType, Timestamp>;
  EXPECT_EQ(activation, (std::vector<P>{{EventType::kDeactivated, fromSeconds(1)},
                                        {EventType::kActivated, fromSeconds(3)},
                                        {EventType::kDeactivated, fromSeconds(4)},
                                        {EventType::kActivated, fromSeconds(5)},
                                        {EventType::kDeactivated, fromSeconds(6)}}));
  std::vector<Timestamp> started;  // the rule's starts carry the stream time of the start
  for (const Event& e : sink.events(EventType::kStarted))
    if (e.dfpc == "detection") started.push_back(e.stamp);
  EXPECT_EQ(started, (std::vector<Timestamp>{0, fromSeconds(3), fromSeconds(5)}));
  const std::vector<Event> deactivated = sink.events(EventType::kDeactivated);
  ASSERT_FALSE(deactivated.empty());
  EXPECT_EQ(deactivated[0].message,
            "'tracking' is TRACKING; 'detection' runs while it is UNINITIALISED or LOST");
  EXPECT_EQ(o->status("detection")->messages, 3u);  // frames 0, 3 and 5
}

TEST(DetectThenTrack, ADfpcACallerStoppedStaysStopped) {
  MemorySink sink;
  auto o = detectThenTrack(sink);
  ASSERT_OK(o->process(number("/camera/frame", 0, 1.0)));  // detected, tracked
  ASSERT_OK(o->process(number("/camera/frame", 1, 9.0)));  // lost (a jump)
  ASSERT_OK(o->process(number("/camera/frame", 2, 9.1)));  // detection runs again: tracked
  ASSERT_OK(o->stop("detection"));
  ASSERT_OK(o->process(number("/camera/frame", 3, 20.0)));  // lost
  ASSERT_OK(o->process(number("/camera/frame", 4, 20.1)));  // the rule would start detection
  EXPECT_EQ(o->status("detection")->state, DfpcState::kStopped);
  EXPECT_EQ(o->status("tracking")->track_state, TrackState::kUninitialised);
  EXPECT_EQ(values(sink, "/cdff/detection/detection"), (std::vector<double>{1.0, 9.1}));
}

TEST(DetectThenTrack, BadRulesAreRefusedWithWhatWasExpected) {
  for (const char* text :
       {"detection", "detection=tracking", "=tracking:LOST", "detection=tracking:LOST,LOSING"}) {
    Result<ActivationRule> rule = parseActivationRule(text);
    ASSERT_FALSE(rule) << text;
    EXPECT_NE(rule.status().message().find("expected DFPC=TRACKER:STATE"), std::string::npos)
        << rule.status().message();
  }
  EXPECT_NE(parseActivationRule("d=t:LOSING")
                .status()
                .message()
                .find("'LOSING' is not a track state (UNINITIALISED, ACQUIRING, TRACKING"),
            std::string::npos);

  MemorySink sink;
  Orchestrator o({&sink});
  ASSERT_OK(o.add(makeDfpc(kDetection)));
  ASSERT_OK(o.add(makeDfpc(kTracking)));
  const auto refusal = [&](const std::string& text) {
    return o.runWhile(parseActivationRule(text).value()).message();
  };
  EXPECT_NE(refusal("detection=tracker:LOST").find("no DFPC 'tracker'"), std::string::npos);
  EXPECT_NE(refusal("detection=detection:LOST").find("cannot follow its own track state"),
            std::string::npos);
  EXPECT_NE(refusal("tracking=detection:LOST").find("DFPC 'detection' declares no track_state"),
            std::string::npos);
  ASSERT_OK(o.runWhile(parseActivationRule("detection=tracking:LOST").value()));
  EXPECT_NE(refusal("detection=tracking:UNINITIALISED").find("one rule per DFPC"),
            std::string::npos);
}

TEST(DetectThenTrack, AnInputFedByAnotherDfpcsOutputNeedsNoChannelInTheRecording) {
  MemorySink sink;
  auto o = detectThenTrack(sink);
  MemoryStream frames({number("/camera/frame", 0, 1.0), number("/camera/frame", 1, 1.1)});
  ASSERT_OK(o->run(frames).status());
  EXPECT_EQ(values(sink, "/cdff/tracking/pose"), (std::vector<double>{1.0, 1.1}));
}

// ------------------------------------------------------------------------------- stereo pairs

Image grey(Timestamp stamp, const std::string& frame) {
  Image image =
      Image::fromBytes(std::vector<std::uint8_t>(4 * 3, 7), 4, 3, PixelFormat::kGray8).value();
  image.stamp = stamp;
  image.frame_id = frame;
  return image;
}

Message mounting(const std::string& frame, const Eigen::Vector3d& position) {
  Eigen::Isometry3d servicer_T_frame = Eigen::Isometry3d::Identity();
  servicer_T_frame.translation() = position;
  servicer_T_frame.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return Message::of("/chaser/tf/" + frame, 0,
                     Transform::fromIsometry(servicer_T_frame, "servicer", frame, 0));
}

const StereoPairing kPairing{"/chaser/stereo/pair", "/left", "/right"};

TEST(StereoPairs, ImagesOfOneInstantArePairedWithTheRelativeMounting) {
  MemoryStream recording({mounting("left_optical", {0.1, 0, 0}),
                          mounting("right_optical", {-0.1, 0, 0}),
                          Message::of("/left", 0, grey(0, "left_optical")),
                          Message::of("/right", 0, grey(0, "right_optical")),
                          Message::of("/left", 100, grey(100, "left_optical")),  // partner lost
                          Message::of("/right", 200, grey(200, "right_optical")),
                          Message::of("/left", 200, grey(200, "left_optical"))});
  StereoPairStream paired(recording, {kPairing});
  const std::vector<ChannelInfo> channels = paired.channels();
  ASSERT_EQ(channels.back().channel, "/chaser/stereo/pair");
  EXPECT_EQ(channels.back().type.name(), "StereoImagePair");
  std::vector<Message> out;
  for (;;) {
    Result<std::optional<Message>> next = paired.next();
    ASSERT_OK(next.status());
    if (!next.value()) break;
    out.push_back(*next.value());
  }
  ASSERT_EQ(out.size(), 9u);  // the 7 messages and 2 pairs, each after its second image
  const StereoImagePair* first = out[4].as<StereoImagePair>();
  const StereoImagePair* second = out[8].as<StereoImagePair>();
  ASSERT_TRUE(first && second);
  EXPECT_EQ(out[4].stamp, 0);
  EXPECT_EQ(out[8].stamp, 200);
  EXPECT_EQ(second->left.stamp, 200);
  EXPECT_EQ(second->right.stamp, 200);
  // Both cameras turned 0.1 rad about y, 0.2 m apart along the servicer's x: the right
  // camera's origin, seen from the left camera, is 0.2 m along -x of the servicer.
  const Eigen::Isometry3d right_T_left = first->right_T_left.isometry();
  const Eigen::Vector3d right_origin_in_left =
      Eigen::AngleAxisd(-0.1, Eigen::Vector3d::UnitY()) * Eigen::Vector3d(-0.2, 0, 0);
  EXPECT_NEAR((right_T_left * right_origin_in_left).norm(), 0.0, 1e-12);
  EXPECT_EQ(first->right_T_left.parent_frame, "right_optical");
  EXPECT_EQ(first->right_T_left.child_frame, "left_optical");
}

TEST(StereoPairs, AnImageWithoutItsMountingIsAnErrorThatNamesTheFrame) {
  MemoryStream recording({mounting("left_optical", {0.1, 0, 0}),
                          Message::of("/left", 0, grey(0, "left_optical")),
                          Message::of("/right", 0, grey(0, "right_optical"))});
  StereoPairStream paired(recording, {kPairing});
  Status status;
  for (int i = 0; i < 4 && status; ++i) status = paired.next().status();
  EXPECT_NE(status.message().find("no mounting of frame 'right_optical' (the images of '/right')"),
            std::string::npos)
      << status.message();
  for (const char* text : {"/pair=/left", "/pair=/left,/left", "=/left,/right", "/pair"})
    EXPECT_FALSE(parseStereoPairing(text)) << text;
  EXPECT_EQ(parseStereoPairing("/p=/l,/r")->right, "/r");
}

}  // namespace
}  // namespace cdff::dfpc
