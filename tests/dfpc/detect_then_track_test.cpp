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

// The second form of a rule: a condition over the DFPCs' track states, ranges and products (the
// seed's Table 1 hand-overs: a DFPC runs from a range on, while another tracks).
const std::string kRanging = R"(name: ranging
inputs: [{name: pose, type: PoseWithCovariance, channel: /ranging/pose}]
outputs:
  - {name: state, type: RigidBodyState, role: target_state, timeout_s: 1.5}
nodes:
  to_state: {dfn: StateFromPose, dfi: UnknownTwist}
connections: [pose -> to_state.pose, to_state.state -> state]
)";

Message poseAt(double seconds, double range) {
  PoseWithCovariance p;
  p.pose = Transform::identity("servicer", "target", fromSeconds(seconds));
  p.pose.translation = Eigen::Vector3d(range, 0, 0);
  p.covariance = Matrix6d::Identity() * 0.01;
  return Message::of<PoseWithCovariance>("/ranging/pose", fromSeconds(seconds), p);
}

std::vector<std::pair<EventType, Timestamp>> activations(const MemorySink& sink,
                                                         const std::string& dfpc) {
  std::vector<std::pair<EventType, Timestamp>> out;
  for (const Event& e : sink.events())
    if (e.kind() == EventKind::kActivation && e.dfpc == dfpc) out.emplace_back(e.type, e.stamp);
  return out;
}

TEST(ConditionRule, ADfpcRunsFromARangeOnWhileAnotherDoesNotTrack) {
  MemorySink sink;
  Orchestrator o({&sink});
  ASSERT_OK(o.add(makeDfpc(kRanging)));
  ASSERT_OK(o.add(makeDfpc(kDetection)));
  std::string tracking = kTracking;
  tracking.replace(tracking.find("/cdff/tracking/initial"), 22, "/cdff/detection/detection");
  ASSERT_OK(o.add(makeDfpc(tracking)));
  Result<ActivationRule> rule = parseActivationRule(
      "detection: ranging.range < 10 and tracking.track_state in [UNINITIALISED, LOST]");
  ASSERT_OK(rule.status());
  EXPECT_EQ(rule->dfpc, "detection");
  ASSERT_OK(o.runWhile(std::move(rule).value()));
  ASSERT_OK(o.startAll());
  // 0 s: 20 m away, no detection; 1 s: 8 m, so from the next message (1.5 s: a rule reads what
  // the messages before made) the detection runs and the tracker takes its product; 2 s:
  // tracked, the detection stops; 3 s: lost (a jump), it runs again; from 4.6 s
  // the range is older than its output's timeout (1.5 s): unset, the detection stops.
  ASSERT_OK(o.process(poseAt(0, 20)));
  ASSERT_OK(o.process(number("/camera/frame", 0.5, 1.0)));
  ASSERT_OK(o.process(poseAt(1, 8)));
  ASSERT_OK(o.process(number("/camera/frame", 1.5, 1.1)));
  ASSERT_OK(o.process(poseAt(2, 7)));
  ASSERT_OK(o.process(number("/camera/frame", 2.5, 1.2)));
  ASSERT_OK(o.process(poseAt(3.0, 6)));
  ASSERT_OK(o.process(number("/camera/frame", 3.5, 9.0)));
  ASSERT_OK(o.process(number("/camera/frame", 4.2, 9.1)));
  ASSERT_OK(o.process(number("/camera/frame", 4.6, 9.2)));
  using P = std::pair<EventType, Timestamp>;
  EXPECT_EQ(activations(sink, "detection"),
            (std::vector<P>{{EventType::kDeactivated, 0},
                            {EventType::kActivated, fromSeconds(1.5)},
                            {EventType::kDeactivated, fromSeconds(2)},
                            {EventType::kActivated, fromSeconds(4.2)},
                            {EventType::kDeactivated, fromSeconds(4.6)}}));
  EXPECT_EQ(values(sink, "/cdff/detection/detection"), (std::vector<double>{1.1, 9.1}));
  // The events say what the rule read.
  const std::vector<Event> activated = sink.events(EventType::kActivated);
  ASSERT_FALSE(activated.empty());
  EXPECT_EQ(activated[0].message,
            "'ranging.range < 10 and tracking.track_state in [UNINITIALISED, LOST]' holds "
            "(ranging.range = 8.00 m, tracking.track_state = UNINITIALISED); 'detection' runs "
            "while it holds");
  const std::vector<Event> deactivated = sink.events(EventType::kDeactivated);
  ASSERT_EQ(deactivated.size(), 3u);
  EXPECT_NE(deactivated[2].message.find("ranging.range = unset"), std::string::npos)
      << deactivated[2].message;
}

TEST(ConditionRule, ReadsAScalarProductAndItsOwnTrackState) {
  MemorySink sink;
  Orchestrator o({&sink});
  ASSERT_OK(o.add(makeDfpc(kDetection)));
  ASSERT_OK(o.add(makeDfpc(kTracking)));
  // The tracker runs while the detection's last product is above 2, or while it tracks itself
  // (a bare track_state is the ruled DFPC's own).
  ASSERT_OK(o.runWhile(
      parseActivationRule("tracking: detection.detection > 2 or track_state == TRACKING").value()));
  ASSERT_OK(o.startAll());
  ASSERT_OK(o.process(number("/camera/frame", 0, 1.0)));  // unset: the tracker stops
  ASSERT_OK(o.process(number("/camera/frame", 1, 3.0)));  // detection 1 before it: stopped
  // Detection 3: it runs from here, initialised.
  ASSERT_OK(o.process(number("/cdff/tracking/initial", 1.5, 2.5)));
  ASSERT_OK(o.process(number("/camera/frame", 2, 1.9)));  // detection 3: runs, tracks 1.9
  ASSERT_OK(o.process(number("/camera/frame", 3, 1.8)));  // detection 1.9, but it tracks
  using P = std::pair<EventType, Timestamp>;
  EXPECT_EQ(
      activations(sink, "tracking"),
      (std::vector<P>{{EventType::kDeactivated, 0}, {EventType::kActivated, fromSeconds(1.5)}}));
  EXPECT_EQ(o.status("tracking")->track_state, TrackState::kTracking);
  EXPECT_NE(sink.events(EventType::kActivated)[0].message.find("detection.detection = 3"),
            std::string::npos)
      << sink.events(EventType::kActivated)[0].message;
}

TEST(ConditionRule, TrackStateIsTheDfpcsEvenWithAnOutputOfThatName) {
  // The tracker also publishes its status as an output named track_state (lidar_tracking
  // does): unset until the tracker first runs, where the DFPC's track state has its initial
  // value from the start.
  std::string tracking = kTracking;
  tracking.replace(tracking.find("outputs: [{name: pose, type: Double}]"), 37,
                   "outputs: [{name: pose, type: Double}, {name: track_state, type: TrackState}]");
  tracking.replace(tracking.find("tracker.estimate -> pose]"), 25,
                   "tracker.estimate -> pose, tracker.status -> track_state]");
  MemorySink sink;
  Orchestrator o({&sink});
  ASSERT_OK(o.add(makeDfpc(kDetection)));
  ASSERT_OK(o.add(makeDfpc(tracking)));
  ASSERT_OK(
      o.runWhile(parseActivationRule("detection: tracking.track_state == UNINITIALISED").value()));
  ASSERT_OK(o.startAll());
  ASSERT_OK(o.process(number("/cdff/tracking/initial", 0, 1.0)));
  ASSERT_OK(o.process(number("/camera/frame", 1, 1.0)));  // the tracker tracks from here
  ASSERT_OK(o.process(number("/camera/frame", 2, 1.0)));
  // Held at 0 s (the output was unset then) and 1 s; stopped once the tracker tracks.
  using P = std::pair<EventType, Timestamp>;
  EXPECT_EQ(activations(sink, "detection"),
            (std::vector<P>{{EventType::kDeactivated, fromSeconds(2)}}));
}

TEST(ConditionRule, BadConditionsAreRefusedWithWhatWasExpected) {
  const auto parseError = [](const std::string& text) {
    return parseActivationRule(text).status().message();
  };
  EXPECT_NE(parseError("detection: ").find("the condition is empty"), std::string::npos);
  EXPECT_NE(parseError(": tracking.track_state == LOST").find("the DFPC's name is empty"),
            std::string::npos);
  EXPECT_NE(parseError("detection: tracking.range <").find("condition 'tracking.range <'"),
            std::string::npos)
      << parseError("detection: tracking.range <");

  MemorySink sink;
  Orchestrator o({&sink});
  ASSERT_OK(o.add(makeDfpc(kRanging)));
  ASSERT_OK(o.add(makeDfpc(kDetection)));
  ASSERT_OK(o.add(makeDfpc(kTracking)));
  const auto refusal = [&](const std::string& text) {
    Result<ActivationRule> rule = parseActivationRule(text);
    return rule ? o.runWhile(*rule).message() : rule.status().message();
  };
  EXPECT_NE(refusal("detection: tracker.track_state == LOST").find("no DFPC 'tracker'"),
            std::string::npos);
  EXPECT_NE(refusal("detection: tracking.speed > 1")
                .find("DFPC 'tracking' has no output 'speed'; expected one of {track_state, pose}"),
            std::string::npos)
      << refusal("detection: tracking.speed > 1");
  EXPECT_NE(refusal("detection: tracking.range > 1").find("no product to take a range from"),
            std::string::npos);
  EXPECT_NE(refusal("detection: ranging.track_state == LOST").find("declares no track_state"),
            std::string::npos);
  EXPECT_NE(refusal("detection: ranging.state > 1").find("can only be compared with unset"),
            std::string::npos)
      << refusal("detection: ranging.state > 1");
  EXPECT_NE(refusal("detection: tracking.track_state == LOSING").find("LOSING"), std::string::npos);
  EXPECT_NE(refusal("nobody: ranging.range < 3").find("no DFPC 'nobody'"), std::string::npos);
  ASSERT_OK(o.runWhile(parseActivationRule("detection: ranging.range < 3").value()));
  EXPECT_NE(refusal("detection=tracking:LOST").find("one rule per DFPC"), std::string::npos);
}

}  // namespace
}  // namespace cdff::dfpc
