// PoseHypothesisSelection/IcpMisfit: each hypothesis refined by the registration library's
// point-to-plane ICP on the scene around it and scored by the misfit of FastIcp's hypothesis
// confirmation (src/cdff/registration/misfit.hpp); this DFI derives the distances from the
// model and the sensor, crops the scene and picks the pose.
#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include "PoseHypothesisSelection.gen.hpp"
#include "cdff/registration/crop.hpp"
#include "cdff/registration/icp.hpp"
#include "cdff/registration/median.hpp"
#include "cdff/registration/misfit.hpp"
#include "cdff/registration/model_symmetry.hpp"
#include "cdff/registration/quality.hpp"
#include "cdff/registration/ring_visibility.hpp"
#include "cdff/registration/scan_inputs.hpp"
#include "cdff/registration/shared_model_cache.hpp"
#include "cdff/types/cloud_extent.hpp"

namespace cdff::dfn {

class PoseHypothesisSelectionIcpMisfit final : public PoseHypothesisSelectionIcpMisfitBase {
 protected:
  Status onConfigure() override {
    model_.index.reset();
    window_.clear();
    return Status::ok();
  }

  Status onProcess() override {
    const Status status = verify();
    // A call where no hypothesis passed (no pose output) ends the window.
    if (!status.isOk() || !out.pose.hasValue()) window_.clear();
    return status;
  }

  /// One call's verification and the decision over the window of calls.
  Status verify() {
    out.pose.clear();  // set again only when a hypothesis passes
    out.found.set(false);
    out.chosen.set(-1);
    out.fitness.set(kNaN);
    out.visibility.set(kNaN);
    out.margin.set(kNaN);
    out.relative_margin.set(kNaN);
    out.ambiguous.set(false);
    Detections none;
    none.stamp = in.hypotheses->stamp;
    none.frame_id = in.scene->frame_id;
    out.candidates.set(std::move(none));
    CDFF_RETURN_IF_ERROR(prepare(*in.model));
    const PointCloud& scene = *in.scene;
    CDFF_RETURN_IF_ERROR(scene.validate("input 'scene'"));
    CDFF_RETURN_IF_ERROR(checkModelScale(scene, 2 * bounds_.radius(), "scene", "model"));
    const LidarInfo* sensor = in.sensor.get();
    CDFF_RETURN_IF_ERROR(registration::checkScanSensor(scene, sensor, "scene"));
    const Detections& hypotheses = *in.hypotheses;
    CDFF_RETURN_IF_ERROR(hypotheses.validate().withContext("input 'hypotheses'"));
    if (!hypotheses.frame_id.empty() && !scene.frame_id.empty() &&
        hypotheses.frame_id != scene.frame_id)
      return invalidInput(
          "input 'hypotheses' are in frame '{}' but input 'scene' is in frame '{}'; expected "
          "poses of the model in the scene's frame",
          hypotheses.frame_id, scene.frame_id);
    if (hypotheses.detections.empty()) return Status::ok();

    const int count =
        std::min<int>(params_.max_hypotheses, static_cast<int>(hypotheses.detections.size()));
    // Coarse: every hypothesis briefly, on a thinned crop.
    std::vector<Trial> rough = coarsePass(scene, sensor, hypotheses, count);
    // Fine: the best distinct coarse results, from where they ended, on the full crop.
    std::stable_sort(rough.begin(), rough.end(),
                     [](const Trial& a, const Trial& b) { return a.evidence > b.evidence; });
    std::vector<Eigen::Isometry3d> starts;
    std::vector<Distances> start_distances;
    for (const Trial& r : rough) {
      starts.push_back(r.pose);
      start_distances.push_back(r.distances);
    }
    Effort fine = fineEffort();
    fine.stride = scoringStride(scene, starts, start_distances, fine.points);
    std::vector<Trial> trials;
    std::vector<Eigen::Isometry3d> started;
    for (const Trial& r : rough) {
      if (static_cast<int>(started.size()) >= params_.refined_hypotheses) break;
      if (std::any_of(started.begin(), started.end(),
                      [&](const Eigen::Isometry3d& s) { return samePose(s, r.pose, r.distances); }))
        continue;
      started.push_back(r.pose);
      Result<Trial> trial = verify(scene, r.pose, sensor, r.distances, fine);
      if (!trial) continue;
      trial->hypothesis = r.hypothesis;
      trial->distances = r.distances;
      trials.push_back(std::move(trial).value());
    }
    if (trials.empty()) return Status::ok();
    addSymmetricRivals(scene, sensor, fine.stride, trials);
    pick(trials, scene);
    return Status::ok();
  }

 private:
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  /// The coarse pass refines every hypothesis on an eighth of max_points (at least min_returns)
  /// for a third of the iterations: enough to move a hypothesis within a voting bin into its
  /// basin and to rank it (a wrong one stays far from the scene's returns); the fine pass then
  /// costs a full run for refined_hypotheses only.
  static constexpr int kCoarseThinning = 8;
  static constexpr int kCoarseIterationShare = 3;
  /// Beyond the best refined_hypotheses of them (as many as the hypotheses refined: a coarse run
  /// on a thinned sparse crop may stop short of its basin), a near-symmetric rival is refined to
  /// the end when its coarse evidence is within this many standard deviations of the best
  /// rival's: two poses that both fit differ in evidence by noise of about 2 per square root of
  /// a return (min_margin's doc), so a rival farther behind cannot be the one that decides the
  /// margin, while rivals the scene does not tell apart (the turns of a six-fold near-symmetric
  /// bus) are all refined and listed as candidates.
  static constexpr double kRivalSigmas = 3.0;

  /// The distances of this call, from the parameters or (0) from the model and the sensor.
  struct Distances {
    double inlier = 0, start = 0, crop = 0, distinct = 0;
  };

  /// One hypothesis refined and scored on its crop.
  struct Trial {
    int hypothesis = -1;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    registration::Quality quality;
    double visibility = kNaN;
    double evidence = -std::numeric_limits<double>::infinity();
    std::size_t returns = 0;
    std::size_t stride = 1;  // of the scene subsample it was scored on
    bool passes = false;
    Distances distances;
  };

  /// Every one of the first `count` hypotheses refined briefly and scored (coarseEffort).
  std::vector<Trial> coarsePass(const PointCloud& scene, const LidarInfo* sensor,
                                const Detections& hypotheses, int count) {
    std::vector<Eigen::Isometry3d> starts;
    std::vector<Distances> start_distances;
    for (int i = 0; i < count; ++i) {
      starts.push_back(hypotheses.detections[i].pose.isometry());
      start_distances.push_back(distances(scene, sensor, starts.back()));
    }
    Effort coarse = coarseEffort();
    coarse.stride = scoringStride(scene, starts, start_distances, coarse.points);
    std::vector<Trial> rough;
    for (int i = 0; i < count; ++i) {
      Result<Trial> trial = verify(scene, starts[i], sensor, start_distances[i], coarse);
      if (!trial) {
        warn(fmt::format("hypothesis {} not verified: {}", i, trial.status().message()));
        continue;
      }
      trial->hypothesis = i;
      trial->distances = start_distances[i];
      rough.push_back(std::move(trial).value());
    }
    return rough;
  }

  Status prepare(const PointCloud& model) {
    Result<std::shared_ptr<const registration::ModelIndex>> index =
        registration::SharedModelCache::index(model, model_.index);
    if (!index) return index.status().withContext("input 'model'");
    if (*index == model_.index) return Status::ok();
    model_.index = std::move(index).value();
    model_.grid = registration::SharedModelCache::grid(*model_.index, {});
    spacing_ = registration::modelSpacing(*model_.index);
    bounds_ = registration::modelBounds(*model_.index);
    symmetries_.clear();
    if (params_.symmetry_rivals) {
      registration::SymmetryOptions symmetry;
      symmetry.min_overlap = params_.min_symmetry_overlap;
      symmetries_ = registration::motionsOf(registration::nearSymmetries(*model_.index, symmetry));
    }
    return Status::ok();
  }

  /// The best passing trial's near-symmetric poses (the model turned by each of its
  /// near-symmetries), verified as the hypotheses are: a voting or a correspondence grouping
  /// often proposes one of them and not the other, and the margin must count the rival the
  /// scene may fit as well. Each briefly first, as the hypotheses; the best of them to the end
  /// (kRivalSigmas).
  void addSymmetricRivals(const PointCloud& scene, const LidarInfo* sensor, std::size_t stride,
                          std::vector<Trial>& trials) {
    const Trial* best = nullptr;
    for (const Trial& t : trials)
      if (t.passes && (best == nullptr || t.evidence > best->evidence)) best = &t;
    if (best == nullptr) return;
    const Eigen::Isometry3d pose = best->pose;
    const int hypothesis = best->hypothesis;
    std::vector<Eigen::Isometry3d> rivals;
    std::vector<Distances> rival_distances;
    for (const Eigen::Isometry3d& motion : symmetries_) {
      const Eigen::Isometry3d rival = pose * motion;
      const Distances d = distances(scene, sensor, rival);
      const bool known = std::any_of(trials.begin(), trials.end(),
                                     [&](const Trial& t) { return samePose(t.pose, rival, d); });
      if (known) continue;  // already refined from a hypothesis of its own
      rivals.push_back(rival);
      rival_distances.push_back(d);
    }
    Effort coarse = coarseEffort();
    coarse.stride = scoringStride(scene, rivals, rival_distances, coarse.points);
    Effort fine = fineEffort();
    fine.stride = stride;
    std::vector<Trial> rough;
    for (std::size_t i = 0; i < rivals.size(); ++i) {
      const Distances& d = rival_distances[i];
      Result<Trial> trial = verify(scene, rivals[i], sensor, d, coarse);
      if (!trial) continue;                     // a crop too small to refine: no rival there
      trial->hypothesis = static_cast<int>(i);  // the rival's index until refined
      trial->distances = d;
      rough.push_back(std::move(trial).value());
    }
    std::stable_sort(rough.begin(), rough.end(),
                     [](const Trial& a, const Trial& b) { return a.evidence > b.evidence; });
    for (std::size_t i = 0; i < rough.size(); ++i) {
      const Trial& r = rough[i];
      const double behind = rough.front().evidence - r.evidence;
      const double sigma =
          2.0 * std::sqrt(static_cast<double>(std::max<std::size_t>(r.returns, 1)));
      if (static_cast<int>(i) >= params_.refined_hypotheses && behind > kRivalSigmas * sigma) break;
      // From the twin itself: the coarse run ranks it but, on a thinned sparse crop, may slide
      // it out of its basin.
      Result<Trial> trial = verify(scene, rivals[r.hypothesis], sensor, r.distances, fine);
      if (!trial) continue;
      trial->hypothesis = hypothesis;
      trial->distances = r.distances;
      trials.push_back(std::move(trial).value());
    }
  }

  /// The range noise (1 sigma) at `range` from the sensor's description or the parameters; the
  /// model's point spacing when neither states one.
  double rangeNoise(const LidarInfo* sensor, double range) const {
    if (sensor != nullptr) return sensor->range_noise;
    if (params_.noise_constant > 0 || params_.noise_quadratic > 0)
      return params_.noise_constant + params_.noise_quadratic * range * range;
    return spacing_;
  }

  /// The distances for a hypothesis: from the parameters, or (0) from the model and the range
  /// noise at the range of the returns it covers.
  Distances distances(const PointCloud& scene, const LidarInfo* sensor,
                      const Eigen::Isometry3d& hypothesis) {
    Distances d;
    const double radius = bounds_.radius();
    const double range = rangeOfReturns(scene, hypothesis);
    d.inlier = params_.inlier_distance > 0
                   ? params_.inlier_distance
                   : std::max(2.0 * spacing_, 3.0 * rangeNoise(sensor, range));
    d.start = params_.max_correspondence_distance > 0 ? params_.max_correspondence_distance
                                                      : std::max(0.1 * radius, 2.0 * d.inlier);
    d.start = std::max(d.start, d.inlier);
    d.crop = radius + (params_.crop_margin > 0 ? params_.crop_margin : d.inlier);
    d.distinct = params_.distinct_distance > 0 ? params_.distinct_distance : 0.1 * radius;
    return d;
  }

  /// The median range of the scene's returns within the model's bounding sphere at `pose` (its
  /// bounding centre's range when there are none): where the range noise of the returns the pose
  /// explains is. Not the bounding centre's own range, which differs between a pose and its
  /// near-symmetric twin when the model is lopsided (a single solar wing moves the box's centre
  /// by metres), and with it a range-dependent noise, so that the twin whose centre is farther
  /// would score the same returns at a larger noise, i.e. better.
  double rangeOfReturns(const PointCloud& scene, const Eigen::Isometry3d& pose) {
    const Eigen::Vector3f centre = (pose * bounds_.centre()).cast<float>();
    const Eigen::Vector3f origin = viewpoint();
    registration::pointsWithin(scene, {&centre, 1}, static_cast<float>(bounds_.radius()), inside_);
    if (inside_.empty()) return (centre - origin).norm();
    ranges_.clear();
    for (const Eigen::Vector3f& p : inside_) ranges_.push_back((p - origin).norm());
    return registration::median(ranges_);
  }

  /// How hard a hypothesis is refined: the crop's returns kept for the ICP, its iterations, and
  /// the scene subsample the refined pose is scored on (every stride-th return of the scene).
  struct Effort {
    int points = 0, iterations = 0;
    std::size_t stride = 1;
  };
  Effort coarseEffort() const {
    return {std::max(params_.min_returns, params_.max_points / kCoarseThinning),
            std::max(1, params_.iterations / kCoarseIterationShare)};
  }
  Effort fineEffort() const { return {params_.max_points, params_.iterations}; }

  Result<Trial> verify(const PointCloud& scene, const Eigen::Isometry3d& hypothesis,
                       const LidarInfo* sensor, const Distances& d, const Effort& effort) {
    cropAround(scene, hypothesis, d.crop, effort.points);
    Trial trial;
    trial.returns = points_.size();
    registration::IcpOptions o;
    o.max_correspondence_distance = d.start;
    o.min_correspondence_distance = d.inlier;
    o.association.viewpoint = viewpoint();
    icp_.configure(o);
    icp_.setModel(model_);
    if (points_.size() < static_cast<std::size_t>(params_.min_returns)) {
      trial.pose = hypothesis;
      return trial;  // nothing there to confirm it
    }
    Result<registration::IcpRun> run = icp_.iterate(
        points_, registration::IcpRun::startingAt(hypothesis, d.start), effort.iterations);
    if (!run) return run.status();
    trial.pose = run->pose;
    trial.pose.linear() = Eigen::Quaterniond(run->pose.linear()).normalized().toRotationMatrix();
    // Scored on the refined pose's own crop (the ICP may have moved the model onto returns the
    // first crop cut) of the subsample that every pose compared with it is scored on.
    const Eigen::Vector3f centre = (trial.pose * bounds_.centre()).cast<float>();
    registration::pointsWithin(scene, {&centre, 1}, static_cast<float>(d.crop), points_,
                               effort.stride);
    trial.returns = points_.size();
    trial.stride = effort.stride;
    if (points_.size() < static_cast<std::size_t>(params_.min_returns)) return trial;
    trial.quality = registration::evaluate(points_, *model_.index, trial.pose, d.inlier,
                                           params_.covariance_inflation);
    if (sensor != nullptr &&
        visibility_.setScan(inSight(scene, trial.pose, d.crop), viewpoint(), lasers_.of(sensor)))
      trial.visibility = visibility_.evaluate(*model_.index, spacing_, trial.pose, 3.0 * d.inlier);
    // The misfit below that of explaining nothing (every return unmatched).
    trial.evidence =
        registration::kUnmatchedCost * static_cast<double>(points_.size()) -
        registration::misfit(trial.quality, points_.size(), d.inlier, trial.visibility);
    trial.passes = trial.quality.fitness >= params_.min_fitness &&
                   (std::isnan(trial.visibility) || trial.visibility >= params_.min_visibility);
    return trial;
  }

  /// The passing trial with the most evidence onto the outputs, with its margin over the best
  /// distinct rival that was scored, passing or not (a twin that misses min_fitness by a hair
  /// explains the scene about as well, and the threshold must not turn a coin toss into a
  /// decision); else the
  /// best-scored trial's fitness and visibility only.
  void pick(const std::vector<Trial>& trials, const PointCloud& scene) {
    const Trial* best = nullptr;
    const Trial* best_any = &trials.front();
    for (const Trial& t : trials) {
      if (t.evidence > best_any->evidence) best_any = &t;
      if (t.passes && (best == nullptr || t.evidence > best->evidence)) best = &t;
    }
    if (best == nullptr) {
      out.fitness.set(best_any->quality.fitness);
      out.visibility.set(best_any->visibility);
      return;
    }
    const Trial* rival = nullptr;
    for (const Trial& t : trials)
      if (&t != best && std::isfinite(t.evidence) &&
          !samePose(t.pose, best->pose, best->distances) &&
          (rival == nullptr || t.evidence > rival->evidence))
        rival = &t;
    setCandidates(trials, rival, scene);
    decide(*best, rival, scene);
  }

  /// The distinct passing trials and the rival, most evidence first, onto the candidates output.
  void setCandidates(const std::vector<Trial>& trials, const Trial* rival,
                     const PointCloud& scene) {
    std::vector<const Trial*> passing;
    for (const Trial& t : trials)
      if (t.passes || &t == rival) passing.push_back(&t);
    std::stable_sort(passing.begin(), passing.end(),
                     [](const Trial* a, const Trial* b) { return a->evidence > b->evidence; });
    Detections candidates;
    candidates.stamp = in.hypotheses->stamp;
    candidates.frame_id = scene.frame_id;
    std::vector<const Trial*> kept;
    for (const Trial* t : passing) {
      if (std::any_of(kept.begin(), kept.end(),
                      [&](const Trial* k) { return samePose(k->pose, t->pose, k->distances); }))
        continue;
      kept.push_back(t);
      Detection d;
      d.pose = Transform::fromIsometry(t->pose, scene.frame_id, in.model->frame_id,
                                       in.hypotheses->stamp);
      d.pose.rotation.normalize();
      d.similarity = std::clamp(t->quality.fitness, 0.0, 1.0);
      d.template_id = fmt::format("hypothesis {}", t->hypothesis);
      candidates.detections.push_back(std::move(d));
    }
    out.candidates.set(std::move(candidates));
  }

  /// The candidate over the last `confirmations` calls: this call's best pose and its rival are
  /// recorded as the candidate's and its rival's (or the other way round when this call's rival
  /// is the candidate: the same pose, moved little since the last call); a best pose that is
  /// neither starts the window anew. The sums decide: the margin is the candidate's evidence
  /// less its rival's, summed, over the square root of the summed returns; the relative margin
  /// 1 less the ratio of their summed misfits per return, each over the returns of both crops (a
  /// return outside a pose's crop is one it leaves unexplained: a pose on a small part of the
  /// scene must not gain by the returns it does not look at). A window whose rival has summed
  /// more evidence swaps the two.
  void decide(const Trial& best, const Trial* rival, const PointCloud& scene) {
    const double compared =
        static_cast<double>(rival != nullptr ? returnsOfEither(scene, best, *rival) : best.returns);
    auto misfitPerReturn = [&](const Trial& t) {
      return (registration::kUnmatchedCost * compared - t.evidence) / std::max(1.0, compared);
    };
    const bool continues_best =
        !window_.empty() && samePose(window_.back().candidate, best.pose, best.distances);
    const bool continues_rival = !continues_best && rival != nullptr && rival->passes &&
                                 !window_.empty() &&
                                 samePose(window_.back().candidate, rival->pose, rival->distances);
    if (!continues_best && !continues_rival) window_.clear();
    const Trial& mine = continues_rival ? *rival : best;
    const Trial* other = continues_rival ? &best : rival;
    Record r;
    r.candidate = mine.pose;
    r.rival_pose = other ? std::optional<Eigen::Isometry3d>(other->pose) : std::nullopt;
    r.evidence = mine.evidence - (other ? other->evidence : 0.0);
    r.misfit = misfitPerReturn(mine);
    r.rival_misfit = other ? misfitPerReturn(*other) : 0.0;
    r.returns = static_cast<double>(mine.returns);
    r.has_rival = other != nullptr;
    window_.push_back(r);
    if (static_cast<int>(window_.size()) > params_.confirmations) window_.pop_front();

    double evidence = 0, misfit = 0, rival_misfit = 0, returns = 0;
    bool any_rival = false;
    for (const Record& w : window_) {
      if (!w.has_rival) continue;
      any_rival = true;
      evidence += w.evidence;
      misfit += w.misfit;
      rival_misfit += w.rival_misfit;
      returns += w.returns;
    }
    const Trial* chosen = &mine;
    if (any_rival && evidence < 0 && other != nullptr && other->passes) {
      // The rival has explained the window better: it is the candidate from now on.
      for (Record& w : window_)
        if (w.rival_pose) {
          std::swap(w.candidate, *w.rival_pose);
          w.evidence = -w.evidence;
          std::swap(w.misfit, w.rival_misfit);
        }
      evidence = -evidence;
      std::swap(misfit, rival_misfit);
      chosen = other;
    }
    const double inf = std::numeric_limits<double>::infinity();
    const double margin = any_rival ? evidence / std::sqrt(std::max(returns, 1.0)) : inf;
    const double relative = any_rival ? 1.0 - misfit / std::max(rival_misfit, 1e-12) : inf;

    out.fitness.set(chosen->quality.fitness);
    out.visibility.set(chosen->visibility);
    out.margin.set(margin);
    out.relative_margin.set(relative);
    PoseWithCovariance pose;
    pose.pose = Transform::fromIsometry(chosen->pose, scene.frame_id, in.model->frame_id,
                                        in.hypotheses->stamp);
    pose.pose.rotation.normalize();
    pose.covariance = chosen->quality.covariance;
    out.pose.set(std::move(pose));
    out.chosen.set(chosen->hypothesis);
    const bool decided = margin >= params_.min_margin && relative >= params_.min_relative_margin;
    const bool enough = static_cast<int>(window_.size()) >= params_.confirmations;
    out.ambiguous.set(!decided);
    out.found.set(decided && enough);
  }

  /// The returns of the subsample `a` and `b` were scored on that lie in the crop of either.
  std::size_t returnsOfEither(const PointCloud& scene, const Trial& a, const Trial& b) const {
    const Eigen::Vector3f ca = (a.pose * bounds_.centre()).cast<float>();
    const Eigen::Vector3f cb = (b.pose * bounds_.centre()).cast<float>();
    const auto ra = static_cast<float>(a.distances.crop * a.distances.crop);
    const auto rb = static_cast<float>(b.distances.crop * b.distances.crop);
    std::size_t count = 0;
    for (std::size_t i = 0; i < scene.points.size(); i += a.stride) {
      const Eigen::Vector3f p = scene.points[i].vec();
      count += (p - ca).squaredNorm() <= ra || (p - cb).squaredNorm() <= rb;
    }
    return count;
  }

  bool samePose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, const Distances& d) const {
    const double angle = Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
    const Eigen::Vector3d centre = bounds_.centre();
    return angle < params_.distinct_angle && ((a * centre) - (b * centre)).norm() < d.distinct;
  }

  /// The scene's returns within `radius` of the model's bounding-box centre at `pose`, evenly
  /// thinned to `most` of them, into points_.
  void cropAround(const PointCloud& scene, const Eigen::Isometry3d& pose, double radius, int most) {
    const Eigen::Vector3f centre = (pose * bounds_.centre()).cast<float>();
    registration::pointsWithin(scene, {&centre, 1}, static_cast<float>(radius), inside_);
    registration::thinEvenly(inside_, static_cast<std::size_t>(most), points_);
  }

  /// The stride that keeps at most `most` returns in the largest of the crops around `poses`
  /// (radii from `d`): poses compared by their evidence are scored on the same subsample of the
  /// scene, every stride-th return. Thinning each crop to `most` on its own would not do: the
  /// evidence sums over the returns scored, so a pose whose crop holds fewer returns (a lopsided
  /// model's twin whose sphere covers a part of the target) would have each of them weigh more.
  std::size_t scoringStride(const PointCloud& scene, const std::vector<Eigen::Isometry3d>& poses,
                            const std::vector<Distances>& d, int most) {
    std::size_t largest = 0;
    for (std::size_t i = 0; i < poses.size(); ++i) {
      const Eigen::Vector3f centre = (poses[i] * bounds_.centre()).cast<float>();
      registration::pointsWithin(scene, {&centre, 1}, static_cast<float>(d[i].crop), inside_);
      largest = std::max(largest, inside_.size());
    }
    const auto m = static_cast<std::size_t>(std::max(1, most));
    return std::max<std::size_t>(1, (largest + m - 1) / m);
  }

  /// The scene's returns on the lines of sight through the model's bounding sphere (radius
  /// `radius`) at `pose`, up to its far side, into sight_: the crop and whatever is in front of
  /// it. A laser whose return lies in front of the model (an occluder, even one outside the
  /// sphere) confirms that the model's surface there is hidden rather than absent.
  const std::vector<Eigen::Vector3f>& inSight(const PointCloud& scene,
                                              const Eigen::Isometry3d& pose, double radius) {
    const Eigen::Vector3f origin = viewpoint();
    const Eigen::Vector3f centre = (pose * bounds_.centre()).cast<float>() - origin;
    const float distance = centre.norm();
    const auto r = static_cast<float>(radius);
    const float far = distance + r;
    // Within the sphere's cone: the angle to the centre at most asin(r / distance).
    const float min_cos =
        distance > r ? std::sqrt(std::max(0.0f, 1.0f - (r / distance) * (r / distance))) : -1.0f;
    sight_.clear();
    for (const Point4f& p : scene.points) {
      const Eigen::Vector3f d = p.vec() - origin;
      const float range = d.norm();
      if (range <= far && d.dot(centre) >= min_cos * range * distance) sight_.push_back(p.vec());
    }
    return sight_;
  }

  Eigen::Vector3f viewpoint() const {
    return Eigen::Vector3f(params_.viewpoint[0], params_.viewpoint[1], params_.viewpoint[2]);
  }

  registration::Icp icp_;
  registration::ModelSearch model_;
  double spacing_ = 0.01;
  registration::ModelBounds bounds_;
  std::vector<Eigen::Isometry3d> symmetries_;  // the model's near-symmetries (model frame)
  /// One call's comparison of the candidate with its best distinct rival.
  struct Record {
    Eigen::Isometry3d candidate = Eigen::Isometry3d::Identity();
    std::optional<Eigen::Isometry3d> rival_pose;
    double evidence = 0;                  // the candidate's less the rival's
    double misfit = 0, rival_misfit = 0;  // per return
    double returns = 0;                   // the candidate's crop
    bool has_rival = false;
  };
  std::deque<Record> window_;  // the last `confirmations` calls
  registration::RingVisibility visibility_;
  registration::LaserElevations lasers_;
  std::vector<Eigen::Vector3f> inside_, points_, sight_;
  std::vector<float> ranges_;
};

CDFF_REGISTER_DFI(PoseHypothesisSelectionIcpMisfit);

}  // namespace cdff::dfn
