#include "cdff/eval/recording_evaluation.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <set>

#include "cdff/io/replay.hpp"
#include "cdff/types/bearing.hpp"
#include "cdff/types/image.hpp"

namespace cdff::eval {

namespace {

bool isPoseType(TypeId type) {
  return type == TypeId::of<PoseWithCovariance>() || type == TypeId::of<RigidBodyState>() ||
         type == TypeId::of<Transform>();
}

struct DecodedPose {
  Transform pose;
  std::optional<Matrix6d> covariance;  // none for a Transform or an all-zero covariance (truth)
  std::optional<Twist> twist;          // a RigidBodyState's
};

std::optional<Matrix6d> covarianceOf(const Matrix6d& c) {
  if (c.isZero(0)) return std::nullopt;
  return c;
}

Result<DecodedPose> decodePose(const io::ReplayMessage& m) {
  if (m.type() == TypeId::of<Transform>()) {
    Result<std::shared_ptr<const Transform>> t = m.decode<Transform>();
    if (!t) return t.status();
    return DecodedPose{**t, std::nullopt};
  }
  if (m.type() == TypeId::of<PoseWithCovariance>()) {
    Result<std::shared_ptr<const PoseWithCovariance>> p = m.decode<PoseWithCovariance>();
    if (!p) return p.status();
    return DecodedPose{(*p)->pose, covarianceOf((*p)->covariance)};
  }
  Result<std::shared_ptr<const RigidBodyState>> s = m.decode<RigidBodyState>();
  if (!s) return s.status();
  return DecodedPose{(*s)->pose, covarianceOf((*s)->covariance.topLeftCorner<6, 6>()), (*s)->twist};
}

bool isFinite(const Transform& t) {
  return t.translation.allFinite() && t.rotation.coeffs().allFinite();
}

// "/cdff/<dfpc>/<output>" -> "<dfpc>", "" when the channel is not a DFPC product.
std::string dfpcOf(const std::string& channel) {
  constexpr std::string_view prefix = "/cdff/";
  if (channel.rfind(prefix, 0) != 0) return {};
  const std::size_t end = channel.find('/', prefix.size());
  if (end == std::string::npos) return {};
  return channel.substr(prefix.size(), end - prefix.size());
}

// A DFPC's bearing products, with the track-state changes before each (as PoseSeries).
struct BearingSeries {
  std::vector<Bearing> bearings;
  std::vector<std::size_t> changes_before;
};

struct PoseSeries {
  std::vector<Transform> poses;
  std::vector<std::optional<Matrix6d>> covariances;
  std::vector<std::optional<Twist>> twists;
  // For products: how many track-state changes of their DFPC the recording held before each pose.
  std::vector<std::size_t> changes_before;
  std::string type;
};

std::string framesOf(const PoseSeries& s) {
  if (s.poses.empty()) return "(no message)";
  return fmt::format("{}_T_{}", s.poses.front().parent_frame, s.poses.front().child_frame);
}

std::string listChannels(const std::map<std::string, PoseSeries>& series) {
  std::string out;
  for (const auto& [name, s] : series)
    out += fmt::format("{}{} ({}, {})", out.empty() ? "" : ", ", name, s.type, framesOf(s));
  return out.empty() ? "none" : out;
}

std::string bearingChannels(const std::map<std::string, BearingSeries>& series) {
  std::string out;
  for (const auto& [name, s] : series) out += fmt::format("{}{}", out.empty() ? "" : ", ", name);
  return out.empty() ? "none" : out;
}

void addNote(RecordingEvaluationNotes* notes, std::string text) {
  if (notes) notes->notes.push_back(std::move(text));
}

// What the evaluation reads from a recording.
struct RecordingContents {
  std::map<std::string, PoseSeries> products, truths;
  std::map<std::string, BearingSeries> bearings;
  std::map<std::string, double> focal_px;  // camera calibration channel -> its focal length
  // dfpc -> the states its track-state changes left, in recording order, after the state before
  // the first change. A product takes the state of the changes recorded before it (not those
  // at or before its stamp: a DFPC publishes its step's products and then the change the step
  // made, at the same stamp); products before the first change take that change's earlier
  // state, so that the initial state of an UNINITIALISED track is not a tracked estimate.
  std::map<std::string, std::vector<std::optional<TrackState>>> track_states;
  std::map<std::string, std::map<Timestamp, double>> step_wall_s;  // dfpc -> stamp -> s
  std::vector<Handover> handovers;  // the DFPCs' activations, without their products' steps
};

// A "track_state_changed" event ("BEFORE -> AFTER") of /cdff/events, into track_states.
void addTrackStateChange(
    const nlohmann::json& j,
    std::map<std::string, std::vector<std::optional<TrackState>>>& track_states) {
  if (j.value("type", "") != "track_state_changed") return;
  const std::string text = j.value("message", "");
  const std::size_t arrow = text.find("-> ");
  if (arrow == std::string::npos) return;
  std::vector<std::optional<TrackState>>& states = track_states[j.value("dfpc", "")];
  if (states.empty()) {
    std::string before = text.substr(0, arrow);
    while (!before.empty() && before.back() == ' ') before.pop_back();
    states.push_back(parseTrackState(before));
  }
  states.push_back(parseTrackState(text.substr(arrow + 3)));
}

// The pose products and truths of the recording, with the DFPCs' track states and step times.
Status readRecording(io::Replay& replay, RecordingContents& out) {
  while (replay.next()) {
    const io::ReplayMessage& m = replay.message();
    const std::string& channel = m.channel();
    const std::string dfpc = dfpcOf(channel);
    if (channel == "/cdff/events") {
      Result<std::shared_ptr<const nlohmann::json>> e = m.decode<nlohmann::json>();
      if (!e) return e.status();
      addTrackStateChange(**e, out.track_states);
      const std::string type = (*e)->value("type", "");
      if ((type == "activated" || type == "deactivated") && (*e)->value("instance", "").empty())
        out.handovers.push_back({m.logTime(), (*e)->value("dfpc", ""), type, {}});
    } else if (!dfpc.empty() && channel == fmt::format("/cdff/{}/timing", dfpc)) {
      Result<std::shared_ptr<const nlohmann::json>> t = m.decode<nlohmann::json>();
      if (!t) return t.status();
      out.step_wall_s[dfpc][m.logTime()] += (*t)->value("wall_s", 0.0);
    } else if (m.type() == TypeId::of<CameraModel>()) {
      Result<std::shared_ptr<const CameraModel>> c = m.decode<CameraModel>();
      if (!c) return c.status();
      // A pixel's angle at the image centre; fx and fy differ only for non-square pixels.
      out.focal_px.emplace(channel, 0.5 * ((*c)->fx + (*c)->fy));
    } else if (m.type() == TypeId::of<Bearing>() && !dfpc.empty()) {
      Result<std::shared_ptr<const Bearing>> b = m.decode<Bearing>();
      if (!b) return b.status();
      BearingSeries& s = out.bearings[channel];
      s.bearings.push_back(**b);
      const auto states = out.track_states.find(dfpc);
      s.changes_before.push_back(states == out.track_states.end() ? 0 : states->second.size() - 1);
    } else if (isPoseType(m.type()) && (!dfpc.empty() || channel.rfind("/truth/", 0) == 0)) {
      const bool is_truth = dfpc.empty();
      Result<DecodedPose> decoded = decodePose(m);
      if (!decoded) return decoded.status();
      PoseSeries& s = (is_truth ? out.truths : out.products)[channel];
      s.type = std::string(m.type().name());
      s.poses.push_back(decoded->pose);
      s.covariances.push_back(decoded->covariance);
      s.twists.push_back(decoded->twist);
      if (!is_truth) {
        const auto states = out.track_states.find(dfpc);
        s.changes_before.push_back(states == out.track_states.end() ? 0
                                                                    : states->second.size() - 1);
      }
    }
  }
  return Status::ok();
}

// The truth channel that --pair names for `channel` (nullopt when none does); an error when it
// names a channel that is not a truth pose.
Result<std::optional<std::string>> pairedTruth(const std::string& channel,
                                               const std::map<std::string, PoseSeries>& truths,
                                               const RecordingEvaluationOptions& options) {
  const auto p = options.pairs.find(channel);
  if (p == options.pairs.end()) return std::optional<std::string>();
  if (!truths.count(p->second))
    return notFound("--pair {}={}: no truth pose channel '{}'; truth channels: {}", channel,
                    p->second, p->second, listChannels(truths));
  return std::optional<std::string>(p->second);
}

// The truth channel to measure `product` (on `channel`) against: the one --pair names, else the
// one of the same transform; "" (with a note) when there is none.
Result<std::string> truthChannelFor(const std::string& channel, const PoseSeries& product,
                                    const std::map<std::string, PoseSeries>& truths,
                                    const RecordingEvaluationOptions& options,
                                    RecordingEvaluationNotes* notes) {
  Result<std::optional<std::string>> paired = pairedTruth(channel, truths, options);
  if (!paired) return paired.status();
  if (*paired) return **paired;
  std::vector<std::string> candidates;
  for (const auto& [name, t] : truths)
    if (framesOf(t) == framesOf(product)) candidates.push_back(name);
  if (candidates.empty()) {
    addNote(notes,
            fmt::format("{} ({}): no truth channel of the same transform; truth channels: {}",
                        channel, framesOf(product), listChannels(truths)));
    return std::string();
  }
  std::string truth_channel = candidates.front();
  // Several: the documented preference, or the first by name and the user is told.
  if (candidates.size() > 1) {
    if (std::find(candidates.begin(), candidates.end(), "/truth/target_pose") != candidates.end())
      truth_channel = "/truth/target_pose";
    else
      addNote(notes,
              fmt::format("{}: {} truth channels hold {}; measured against {} (--pair chooses)",
                          channel, candidates.size(), framesOf(product), truth_channel));
  }
  return truth_channel;
}

// Whether its DFPC was tracking when a product was recorded after `changes_before` of its
// track-state changes (`states`, empty: a DFPC without a track state, always).
bool trackedAfter(const std::vector<std::optional<TrackState>>& states,
                  std::size_t changes_before) {
  if (states.empty()) return true;
  // A state this version does not know (an older recording's) is taken as tracked.
  const std::optional<TrackState>& state = states[changes_before];
  return !state || isTracked(*state);
}

// The wall time of the DFPC's step at `stamp`, where the run recorded it.
std::optional<double> latencyAt(const std::map<Timestamp, double>& walls, Timestamp stamp) {
  const auto w = walls.find(stamp);
  return w == walls.end() ? std::nullopt : std::optional<double>(w->second);
}

// A truth channel's poses in stamp order.
std::vector<Transform> sortedTruth(const std::map<std::string, PoseSeries>& truths,
                                   const std::string& channel) {
  std::vector<Transform> truth = truths.at(channel).poses;
  std::stable_sort(truth.begin(), truth.end(),
                   [](const auto& a, const auto& b) { return a.stamp < b.stamp; });
  return truth;
}

// The product's poses as estimates, in stamp order: not valid where not finite or while its
// DFPC's track was not tracking (`states`); with the latency of the step that made them; marked
// restarted when its DFPC was activated (`activations`, sorted) since the estimate before.
std::vector<EstimateSample> estimatesOf(const PoseSeries& product,
                                        const std::vector<std::optional<TrackState>>& states,
                                        const std::map<Timestamp, double>& walls,
                                        const std::vector<Timestamp>& activations) {
  std::vector<EstimateSample> estimates;
  estimates.reserve(product.poses.size());
  for (std::size_t i = 0; i < product.poses.size(); ++i) {
    const Transform& pose = product.poses[i];
    EstimateSample e;
    e.pose = pose;
    e.covariance = product.covariances[i];
    e.twist = product.twists[i];
    e.valid = isFinite(pose) && trackedAfter(states, product.changes_before[i]);
    e.latency_s = latencyAt(walls, pose.stamp);
    estimates.push_back(e);
  }
  std::stable_sort(estimates.begin(), estimates.end(),
                   [](const auto& a, const auto& b) { return a.pose.stamp < b.pose.stamp; });
  for (std::size_t i = 1; i < estimates.size(); ++i) {
    const auto next =
        std::upper_bound(activations.begin(), activations.end(), estimates[i - 1].pose.stamp);
    estimates[i].restarted = next != activations.end() && *next <= estimates[i].pose.stamp;
  }
  return estimates;
}

// The stamps at which a DFPC was activated by a rule, sorted.
std::vector<Timestamp> activationsOf(const std::vector<Handover>& handovers,
                                     const std::string& dfpc) {
  std::vector<Timestamp> stamps;
  for (const Handover& h : handovers)
    if (h.dfpc == dfpc && h.type == "activated") stamps.push_back(h.stamp);
  std::sort(stamps.begin(), stamps.end());
  return stamps;
}

// The truth channel for a bearing product (on `channel`, directions in `frame`): the one --pair
// names, else /truth/target_pose when its parent frame is `frame`, else the first by name whose
// parent frame is `frame` and child frame the target ("" with a note when there is none).
Result<std::string> truthChannelForBearing(const std::string& channel, const std::string& frame,
                                           const std::map<std::string, PoseSeries>& truths,
                                           const RecordingEvaluationOptions& options,
                                           RecordingEvaluationNotes* notes) {
  Result<std::optional<std::string>> paired = pairedTruth(channel, truths, options);
  if (!paired) return paired.status();
  if (*paired) return **paired;
  const auto fits = [&](const PoseSeries& t) {
    return !t.poses.empty() && t.poses.front().parent_frame == frame &&
           t.poses.front().child_frame == "target";
  };
  if (auto t = truths.find("/truth/target_pose"); t != truths.end() && fits(t->second))
    return t->first;
  for (const auto& [name, t] : truths)
    if (fits(t)) return name;
  addNote(notes, fmt::format("{} (bearing in '{}'): no truth channel {}_T_target; truth "
                             "channels: {}",
                             channel, frame, frame, listChannels(truths)));
  return std::string();
}

// The focal length for bearings in pixels: --focal-px, else --camera's, else the only camera
// calibration of the recording; NaN (with a note) when there are several and none is chosen.
Result<std::pair<double, std::string>> focalLength(const std::map<std::string, double>& cameras,
                                                   const RecordingEvaluationOptions& options,
                                                   RecordingEvaluationNotes* notes) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  if (std::isfinite(options.focal_px)) return std::pair{options.focal_px, std::string()};
  const auto names = [&] {
    std::vector<std::string> n;
    for (const auto& [name, f] : cameras) n.push_back(name);
    return n.empty() ? std::string("none") : fmt::format("{}", fmt::join(n, ", "));
  };
  if (!options.camera_channel.empty()) {
    auto c = cameras.find(options.camera_channel);
    if (c == cameras.end())
      return notFound("--camera {}: no camera calibration on that channel; calibrations: {}",
                      options.camera_channel, names());
    return std::pair{c->second, c->first};
  }
  if (cameras.size() == 1) return std::pair{cameras.begin()->second, cameras.begin()->first};
  addNote(notes, fmt::format("bearings in pixels need a focal length: {} camera calibrations in "
                             "the recording ({}); --camera or --focal-px chooses",
                             cameras.size(), names()));
  return std::pair{kNaN, std::string()};
}

// The bearing products' evaluations and verdicts, into `report`.
/// The phases from the target's truth (/truth/target_pose, servicer_T_target), and the plots'
/// time origin: the first truth sample of any channel.
void startPhases(const std::map<std::string, PoseSeries>& truths, EvaluationReport& report) {
  bool first = true;
  for (const auto& [channel, series] : truths)
    for (const Transform& t : series.poses)
      if (first || t.stamp < report.start) {
        report.start = t.stamp;
        first = false;
      }
  if (!truths.count("/truth/target_pose")) return;
  for (const PhaseSpan& span : phaseSpans(sortedTruth(truths, "/truth/target_pose")))
    report.phases.push_back({span, {}});
}

Timestamp stampOf(const EstimateSample& e) {
  return e.pose.stamp;
}
Timestamp stampOf(const BearingSample& e) {
  return e.bearing.stamp;
}

/// Each phase's verdicts of one product (pose or bearing): `evaluate` measures the estimates
/// made during the phase; the update rate is the longest gap in the phase, its ends included.
template <typename Sample, typename Evaluate>
void addPhaseVerdicts(const std::string& channel, const std::vector<Sample>& estimates,
                      const Evaluate& evaluate, Statistic statistic,
                      std::vector<PhaseResult>& phases) {
  for (PhaseResult& phase : phases) {
    const PhaseSpan& span = phase.span;
    std::vector<Sample> during;
    std::vector<Timestamp> valid;
    for (const Sample& e : estimates) {
      if (stampOf(e) < span.start || stampOf(e) > span.end) continue;
      during.push_back(e);
      if (e.valid) valid.push_back(stampOf(e));
    }
    if (valid.empty()) continue;
    auto evaluation = evaluate(during);
    if (!evaluation) continue;  // the whole product's evaluation has reported it
    evaluation->channel = channel;
    const double gap = longestGapWithin(valid, span.start, span.end);
    evaluation->min_rate_hz = gap > 0 ? 1.0 / gap : std::numeric_limits<double>::infinity();
    for (RequirementVerdict& v : checkRequirements(*evaluation, statistic)) {
      if (v.verdict == Verdict::kNotApplicable) continue;
      v.note = v.quantity == "update_rate_hz"
                   ? fmt::format(
                         "1 / longest time without a valid estimate in the {}, its "
                         "start and end included",
                         span.phase.name)
                   : fmt::format("{}; {}", span.phase.name, v.note);
      phase.verdicts.push_back(std::move(v));
    }
  }
}

Status evaluateBearingProducts(RecordingContents& contents,
                               const RecordingEvaluationOptions& options,
                               RecordingEvaluationNotes* notes, EvaluationReport& report) {
  if (contents.bearings.empty()) return Status::ok();
  Result<std::pair<double, std::string>> focal = focalLength(contents.focal_px, options, notes);
  if (!focal) return focal.status();
  for (auto& [channel, series] : contents.bearings) {
    const std::string& frame = series.bearings.front().frame_id;
    Result<std::string> truth_channel =
        truthChannelForBearing(channel, frame, contents.truths, options, notes);
    if (!truth_channel) return truth_channel.status();
    if (truth_channel->empty()) continue;
    const std::vector<Transform> truth = sortedTruth(contents.truths, *truth_channel);
    const std::string dfpc = dfpcOf(channel);
    const std::vector<std::optional<TrackState>>& states = contents.track_states[dfpc];
    const std::map<Timestamp, double>& walls = contents.step_wall_s[dfpc];
    std::vector<BearingSample> estimates;
    for (std::size_t i = 0; i < series.bearings.size(); ++i) {
      BearingSample e;
      e.bearing = series.bearings[i];
      e.valid = trackedAfter(states, series.changes_before[i]);
      e.latency_s = latencyAt(walls, e.bearing.stamp);
      estimates.push_back(std::move(e));
    }
    std::stable_sort(estimates.begin(), estimates.end(), [](const auto& a, const auto& b) {
      return a.bearing.stamp < b.bearing.stamp;
    });
    Result<BearingEvaluation> evaluation =
        evaluateBearings(estimates, truth, focal->first, options.pose);
    if (!evaluation)
      return evaluation.status().withContext(
          fmt::format("evaluating {} against {}", channel, *truth_channel));
    evaluation->channel = channel;
    evaluation->truth_channel = *truth_channel;
    evaluation->camera_channel = focal->second;
    for (RequirementVerdict& v : checkRequirements(*evaluation, options.statistic))
      report.requirements.push_back(std::move(v));
    report.bearings.push_back(std::move(evaluation).value());
    addPhaseVerdicts(
        channel, estimates,
        [&](const std::vector<BearingSample>& during) {
          return evaluateBearings(during, truth, focal->first, options.pose);
        },
        options.statistic, report.phases);
  }
  return Status::ok();
}

}  // namespace

Result<EvaluationReport> evaluateRecording(const std::vector<std::string>& paths,
                                           const RecordingEvaluationOptions& options,
                                           RecordingEvaluationNotes* notes) {
  io::Replay replay;
  CDFF_RETURN_IF_ERROR(replay.open(paths));
  RecordingContents contents;
  CDFF_RETURN_IF_ERROR(readRecording(replay, contents));
  auto& [products, truths, bearings, focal_px, track_states, step_wall_s, handovers] = contents;
  const std::set<std::string> wanted(options.products.begin(), options.products.end());
  // A damaged recording is evaluated up to the damage, and says so.
  if (Status s = replay.status(); !s.isOk())
    addNote(notes,
            fmt::format("the recording is damaged; evaluated up to the damage: {}", s.message()));

  for (const std::string& w : wanted)
    if (!products.count(w) && !bearings.count(w))
      return notFound(
          "product channel '{}' is not a pose or bearing product of the recording; its pose "
          "products: {}; its bearing products: {}",
          w, listChannels(products), bearingChannels(bearings));
  if (!wanted.empty()) {
    std::erase_if(products, [&](const auto& p) { return !wanted.count(p.first); });
    std::erase_if(bearings, [&](const auto& p) { return !wanted.count(p.first); });
  }
  if (products.empty() && bearings.empty())
    return notFound(
        "no pose product (/cdff/<dfpc>/<output> of type PoseWithCovariance, "
        "RigidBodyState or Transform) and no bearing product (Bearing) in {}",
        fmt::join(paths, ", "));
  if (truths.empty())
    return notFound(
        "no ground truth (/truth/* of a pose type) in {}; run `cdff run` with the "
        "simulator's recording as input (it copies /truth/ channels)",
        fmt::join(paths, ", "));

  EvaluationReport report;
  report.input = fmt::format("{}", fmt::join(paths, ", "));
  report.statistic = toString(options.statistic);
  startPhases(truths, report);
  for (auto& [channel, product] : products) {
    Result<std::string> truth_channel = truthChannelFor(channel, product, truths, options, notes);
    if (!truth_channel) return truth_channel.status();
    if (truth_channel->empty()) continue;
    const std::vector<Transform> truth = sortedTruth(truths, *truth_channel);
    const std::string dfpc = dfpcOf(channel);
    const std::vector<EstimateSample> estimates =
        estimatesOf(product, track_states[dfpc], step_wall_s[dfpc], activationsOf(handovers, dfpc));
    Result<PoseEvaluation> evaluation = evaluatePoses(estimates, truth, options.pose);
    if (!evaluation)
      return evaluation.status().withContext(
          fmt::format("evaluating {} against {}", channel, *truth_channel));
    evaluation->channel = channel;
    evaluation->truth_channel = *truth_channel;
    for (RequirementVerdict& v : checkRequirements(*evaluation, options.statistic))
      report.requirements.push_back(std::move(v));
    report.products.push_back(std::move(evaluation).value());
    addPhaseVerdicts(
        channel, estimates,
        [&](const std::vector<EstimateSample>& during) {
          return evaluatePoses(during, truth, options.pose);
        },
        options.statistic, report.phases);
  }
  CDFF_RETURN_IF_ERROR(evaluateBearingProducts(contents, options, notes, report));
  report.handovers = handovers;
  for (Handover& h : report.handovers)
    for (const PoseEvaluation& p : report.products) {
      const double sigma =
          p.continuity.maxWithin(h.stamp, h.stamp + fromSeconds(Handover::kWindowS));
      if (std::isfinite(sigma)) h.max_step_sigma.emplace_back(p.channel, sigma);
    }
  if (report.products.empty() && report.bearings.empty())
    return notFound(
        "no pose product has a truth channel of the same transform; products: {}; bearing "
        "products: {}; truth: {} (pair them with --pair PRODUCT=TRUTH)",
        listChannels(products), bearingChannels(bearings), listChannels(truths));
  return report;
}

}  // namespace cdff::eval
