#include "cdff/tracking/edge_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <span>

#include <opencv2/imgproc.hpp>

#include "ModelBasedTracking.gen.hpp"
#include "cdff/tracking/contours.hpp"
#include "cdff/types/opencv.hpp"
#include "tracking_common.hpp"

namespace cdff::dfn {

class ModelBasedTrackingEdgeTracker final : public ModelBasedTrackingEdgeTrackerBase {
 protected:
  Status onConfigure() override {
    const Parameters& p = params_;
    tracking::EdgeTrackerOptions o;
    o.model.cylinder_segments = p.cylinder_segments;
    o.model.circle_segments = p.cylinder_segments;
    o.visibility.near_clipping = p.near_clipping;
    o.visibility.far_clipping = p.far_clipping;
    o.visibility.max_view_angle = p.max_view_angle;
    o.visibility.min_crease_angle = p.min_crease_angle;
    o.visibility.two_sided_faces = p.two_sided_faces;
    o.visibility.min_segment_length = p.min_segment_length;
    o.sampling.step = p.sample_step;
    o.sampling.max_samples = p.max_samples;
    o.search.search_distance = p.search_distance;
    o.search.angular_threshold = p.angular_threshold;
    o.search.min_gradient = p.min_gradient;
    o.search.relative_gradient = p.relative_gradient;
    o.search.noise_sigmas = p.noise_sigmas;
    o.search.min_gradient_floor = p.min_gradient_floor;
    o.search.max_candidates = p.max_candidates;
    o.search.half_width = p.mask_half_width;
    o.solver.max_iterations = p.max_iterations;
    o.solver.convergence_translation = p.convergence_translation;
    o.solver.convergence_rotation = p.convergence_rotation;
    o.solver.divergence_translation = p.divergence_translation;
    o.solver.divergence_rotation = p.divergence_rotation;
    o.solver.tukey_constant = p.tukey_constant;
    o.solver.min_edge_sigma = p.min_edge_sigma;
    o.solver.inlier_threshold = p.inlier_threshold;
    o.solver.depth_weight = p.depth_weight;
    o.solver.min_depth_sigma = p.min_depth_sigma;
    o.depth.step_x = o.depth.step_y = p.depth_step;
    o.depth.max_distance = p.depth_max_distance;
    o.refinement_passes = p.refinement_passes;
    o.refinement_search_distance = p.refinement_search_distance;
    acquisition_sigmas_ = p.acquisition_sigmas;
    acquisition_max_search_ = p.acquisition_max_search_distance;
    lateral_first_ = p.acquisition_lateral_first;
    coarse_search_ = p.acquisition_coarse_search;
    coarse_canny_low_ = p.acquisition_canny_low;
    o.min_inlier_ratio = p.min_inlier_ratio;
    o.degraded_inlier_ratio = p.degraded_inlier_ratio;
    o.min_camera_match_ratio = p.min_camera_match_ratio;
    o.visibility_update_translation = p.visibility_update_translation;
    o.visibility_update_rotation = p.visibility_update_rotation;
    Result<Eigen::Isometry3d> depth_T_camera = mbt::depthExtrinsics(p.depth_extrinsics);
    if (!depth_T_camera) return depth_T_camera.status();
    CDFF_RETURN_IF_ERROR(models_.load(p.model_file));
    options_ = o;
    depth_T_camera_ = *depth_T_camera;
    tracker_ = tracking::EdgeTracker();  // new parameters, new model tessellation
    awaiting_confirmation_ = false;
    reacquisition_covariance_.reset();
    // OpenCV's first Canny and distance transform calls initialise the library (8 ms of the
    // stereo graph's first frame, where no undistortion has called OpenCV before): done now
    // rather than in the first frame, the acquisition's, whose budget is that of every frame.
    if (coarse_search_) warmUpCoarseSearch();
    // The model file's tracking form is built now rather than in the first frame, which also
    // runs the acquisition and has the same time budget as the others.
    if (std::shared_ptr<const PolygonModel> file_model = models_.useFileModel())
      CDFF_RETURN_IF_ERROR(
          tracker_.setModel(*file_model, options_.model).withContext("parameter 'model_file'"));
    return Status::ok();
  }

  Status onProcess() override {
    Result<PoseWithCovariance> predicted_input = mbt::prediction(in);
    if (!predicted_input) return predicted_input.status();
    PoseWithCovariance predicted = *predicted_input;
    if (reacquisition_covariance_ &&
        reacquisition_covariance_->trace() > predicted.covariance.trace()) {
      // An acquisition the next frame did not confirm has pulled the filter's state to a wrong
      // alignment with a covariance that no longer covers the truth: acquire again, as wide as
      // the acquisition that went wrong.
      predicted.covariance = *reacquisition_covariance_;
    }
    bool changed = false;
    Result<std::shared_ptr<const PolygonModel>> model = models_.select(in.model, changed);
    if (!model) return model.status();
    if (changed || !tracker_.hasModel()) {
      CDFF_RETURN_IF_ERROR(tracker_.setModel(**model, options_.model).withContext("model"));
    }
    Result<mbt::Cameras> cameras = mbt::gatherCameras(in, predicted.pose.parent_frame);
    if (!cameras) return cameras.status();
    if (cameras->frames.empty() && !in.depth.hasValue())
      return invalidInput("no 'image', 'stereo_images' or 'depth'; expected at least one sensor");
    if (in.depth.hasValue())
      CDFF_RETURN_IF_ERROR(in.depth->validate().withContext("input 'depth'"));

    const DepthMap* depth = in.depth.hasValue() ? in.depth.get() : nullptr;
    Transform start = predicted.pose;
    // Built once per frame, for the coarse alignment and both hypotheses.
    std::vector<std::vector<Image>> pyramid;
    bool coarse_placed = false;
    coarse_note_.clear();
    if (coarse_search_ && !cameras->frames.empty()) {
      Result<std::optional<Transform>> aligned = coarseAlign(cameras->frames, predicted, pyramid);
      if (!aligned) return aligned.status();
      coarse_placed = aligned->has_value();
      if (coarse_placed) start = **aligned;
    }
    const Transform coarse_start = start;
    Result<bool> acquired =
        acquire(cameras->frames, depth, predicted, start, lateral_first_, pyramid);
    if (!acquired) return acquired.status();
    Result<tracking::TrackingResult> result =
        tracker_.track(cameras->frames, depth, depth_T_camera_, start, options_);
    if (!result) return result.status();
    // After a coarse placement the lateral offset comes from the image's edges, and the
    // lateral-first acquisition from it is kept when it is not lost and the prediction admits it
    // (at long range it is DEGRADED, its inlier ratio below 0.5 as for any track there; the plain
    // one never did better at 8 or 17 m and doubled the acquisition frame's time).
    const bool lateral_accepted = *acquired && result->status != TrackingStatus::kLost &&
                                  (coarse_placed || result->status == TrackingStatus::kTracking) &&
                                  admittedByPrediction(*result, predicted);
    if (acquisition_ran_ && lateral_first_ && !lateral_accepted) {
      // Two hypotheses: neither acquisition works everywhere (the lateral-first one locks on at
      // 8 m where the plain one diverges, and the reverse happens at 2.7 m). The plain one runs
      // only when the lateral-first one gave no track that is tracking (or, after a coarse
      // placement, not lost) and that the prediction admits (running both on every acquisition
      // doubled its time: the first frame was over its budget); the full-resolution result with
      // the higher inlier ratio is then kept.
      const std::string lateral_failure = acquisition_failure_;
      Transform plain_start = coarse_start;
      Result<bool> plain = acquire(cameras->frames, depth, predicted, plain_start, false, pyramid);
      if (!plain) return plain.status();
      if (*plain) {
        Result<tracking::TrackingResult> other =
            tracker_.track(cameras->frames, depth, depth_T_camera_, plain_start, options_);
        if (!other) return other.status();
        const bool lateral_ok = *acquired && result->status != TrackingStatus::kLost;
        if (other->status != TrackingStatus::kLost &&
            (!lateral_ok || other->inlier_ratio > result->inlier_ratio)) {
          result = std::move(other);
          acquired = true;
        }
      }
      if (!*acquired)
        acquisition_failure_ =
            "lateral first: " + lateral_failure + "; plain: " + acquisition_failure_;
    }
    if (!*acquired) {
      result->status = TrackingStatus::kLost;
      result->reason = "acquisition from the initial pose failed: " + acquisition_failure_;
      result->reference_T_model = predicted.pose;
      result->covariance = tracking::noInformationCovariance();
    } else if (result->status == TrackingStatus::kLost) {
      result->reference_T_model = predicted.pose;
    } else if (acquisition_ran_) {
      // A wide acquisition can lock onto a wrong alignment (at long range the model's image is
      // small next to the search); one the prediction's own uncertainty does not admit is lost.
      double m = 0;
      if (!admittedByPrediction(*result, predicted, &m)) {
        const Vector6d d = differenceFromPrediction(*result, predicted);
        result->status = TrackingStatus::kLost;
        result->reason = fmt::format(
            "the acquired pose is {:.3f} m and {:.2f} deg from the prediction, a squared "
            "Mahalanobis distance of {:.1f} under its covariance (gate {:.2f}: chi-square, 6 dof, "
            "0.999)",
            d.head<3>().norm(), d.tail<3>().norm() * 180 / M_PI, m, kAcquisitionGate);
        result->reference_T_model = predicted.pose;
        result->covariance = tracking::noInformationCovariance();
      }
    }
    confirmAcquisition(*result, predicted);
    if (acquisition_ran_ && !coarse_note_.empty()) result->reason += " (" + coarse_note_ + ")";
    if (result->status != TrackingStatus::kTracking)
      warn(fmt::format("{}: {}", toString(result->status), result->reason));

    PoseWithCovariance pose;
    pose.pose = result->reference_T_model;  // the prediction when lost
    pose.covariance = result->covariance;
    out.pose.set(std::move(pose));
    mbt::publishStatus(out, result->status);
    // Not yet a track: `cdff eval` and the DFPC's conditions take ACQUIRING as not tracking.
    if (acquisition_ran_ && result->status != TrackingStatus::kLost)
      out.track_state.set(TrackState::kAcquiring);
    out.inlier_ratio.set(result->inlier_ratio);
    out.feature_count.set(static_cast<int>(result->inliers + result->depth_points));
    return Status::ok();
  }

 private:
  // A wide acquisition can lock onto a wrong alignment that the prediction's gate admits and whose
  // inlier ratio is good (at 17 m from a 5 % / 5 degree start after two lost frames: 1.19 m and
  // 16.6 degrees off, inlier ratio above 0.5). An acquired pose is therefore reported DEGRADED,
  // track state ACQUIRING, until the next frame, tracked from the filter's prediction by the normal
  // passes, confirms it: not lost, and admitted by that prediction's covariance. A failed
  // confirmation is lost, and the next frames acquire again from a covariance as wide as the
  // unconfirmed acquisition's.
  void confirmAcquisition(tracking::TrackingResult& result, const PoseWithCovariance& predicted) {
    if (acquisition_ran_) {
      if (result.status == TrackingStatus::kLost) return;
      awaiting_confirmation_ = true;
      acquisition_covariance_ = predicted.covariance;
      if (result.status == TrackingStatus::kTracking) {
        result.status = TrackingStatus::kDegraded;
        result.reason = "acquired; not tracking until the next frame confirms the acquired pose";
      }
      return;
    }
    if (!awaiting_confirmation_) return;
    awaiting_confirmation_ = false;
    double m = 0;
    if (result.status != TrackingStatus::kLost &&
        admittedByPrediction(result, confirmationGate(result, predicted), &m)) {
      reacquisition_covariance_.reset();
      return;
    }
    result.reason = fmt::format(
        "the next frame did not confirm the acquired pose ({}; squared Mahalanobis distance "
        "{:.1f} from the prediction, gate {:.2f}): acquiring again",
        result.status == TrackingStatus::kLost ? result.reason : "tracked", m, kAcquisitionGate);
    result.status = TrackingStatus::kLost;
    result.reference_T_model = predicted.pose;
    result.covariance = tracking::noInformationCovariance();
    reacquisition_covariance_ = acquisition_covariance_;
  }

  // The covariance of the difference between the confirming estimate and the prediction: the
  // filter's pose covariance carried to the image's time with its velocity covariance (the
  // filter's state is that of its last correction, by the acquired pose, with a small pose
  // covariance; the motion since then is what the velocity's covariance allows), plus the
  // estimate's own.
  Matrix6d confirmationCovariance(const tracking::TrackingResult& result,
                                  const PoseWithCovariance& predicted) const {
    Matrix6d c = predicted.covariance;
    if (in.predicted_state.hasValue()) {
      const RigidBodyState& state = *in.predicted_state;
      const double dt = std::max(0.0, toSeconds(mbt::sensorStamp(in) - state.pose.stamp));
      Eigen::Matrix<double, 6, 12> f;
      f << Matrix6d::Identity(), dt * Matrix6d::Identity();
      c = f * state.covariance * f.transpose();
    }
    if (result.covariance.allFinite()) c += result.covariance;
    return c;
  }
  PoseWithCovariance confirmationGate(const tracking::TrackingResult& result,
                                      const PoseWithCovariance& predicted) const {
    PoseWithCovariance gate = predicted;
    gate.covariance = confirmationCovariance(result, predicted);
    return gate;
  }

  // The estimate minus the prediction: [translation, rotation vector], both in the reference
  // frame (the covariance's perturbation convention).
  static Vector6d differenceFromPrediction(const tracking::TrackingResult& result,
                                           const PoseWithCovariance& predicted) {
    const Eigen::Isometry3d p = predicted.pose.isometry();
    const Eigen::Isometry3d e = result.reference_T_model.isometry();
    Vector6d d;
    d.head<3>() = e.translation() - p.translation();
    d.tail<3>() = logSO3(Eigen::Quaterniond(e.linear() * p.linear().transpose()));
    return d;
  }

  // Whether the prediction's covariance admits the estimate: its squared Mahalanobis distance
  // (written to `distance`) is at most the acquisition gate. A singular covariance admits all.
  static bool admittedByPrediction(const tracking::TrackingResult& result,
                                   const PoseWithCovariance& predicted,
                                   double* distance = nullptr) {
    const Vector6d d = differenceFromPrediction(result, predicted);
    const Eigen::LDLT<Matrix6d> ldlt(predicted.covariance);
    const double m = ldlt.info() == Eigen::Success ? d.dot(ldlt.solve(d)) : 0.0;
    if (distance) *distance = m;
    return ldlt.info() != Eigen::Success || m <= kAcquisitionGate;
  }

  // How far, in pixels, the prediction's uncertainty moves the model's image in the reference
  // camera: acquisition_sigmas standard deviations of the lateral position, of the range (which
  // scales the image about its centre) and of the attitude (which swings the model's extent).
  double predictionSpreadPx(const tracking::CameraFrame& frame,
                            const PoseWithCovariance& predicted) const {
    if (acquisition_sigmas_ <= 0 || !tracker_.hasModel()) return 0;
    const Matrix6d& c = predicted.covariance;
    if (!c.allFinite() || c.diagonal().maxCoeff() <= 0 || c.diagonal().maxCoeff() >= 1e5) return 0;
    const Eigen::Isometry3d c_T_m = frame.camera_T_reference.isometry() * predicted.pose.isometry();
    const double z = (c_T_m * tracker_.model().centre).z();
    if (z <= options_.visibility.near_clipping) return 0;
    const double r = tracker_.model().radius;
    const Eigen::Matrix3d p = c.topLeftCorner<3, 3>();
    const double lateral = std::sqrt(std::max(0.0, p(0, 0) + p(1, 1)));
    const double range = std::sqrt(std::max(0.0, p(2, 2)));
    const double attitude = std::sqrt(std::max(0.0, c.bottomRightCorner<3, 3>().trace()));
    const double f = std::max(frame.camera.fx, frame.camera.fy);
    return acquisition_sigmas_ * f / z * (lateral + range * r / z + attitude * r);
  }

  static constexpr double kMinModelPx = 96;

  // The diameter of the model's bounding sphere in the image, at the prediction.
  double modelSizePx(const tracking::CameraFrame& frame,
                     const PoseWithCovariance& predicted) const {
    const Eigen::Isometry3d c_T_m = frame.camera_T_reference.isometry() * predicted.pose.isometry();
    const double z = (c_T_m * tracker_.model().centre).z();
    if (z <= options_.visibility.near_clipping) return 0;
    return 2 * tracker_.model().radius * std::max(frame.camera.fx, frame.camera.fy) / z;
  }

  // Half the resolution by 2x2 averaging, with the camera model of the smaller image.
  static Image halve(const Image& image) {
    const int w = image.width / 2, h = image.height / 2;
    std::vector<std::uint8_t> out(static_cast<std::size_t>(w) * h);
    for (int y = 0; y < h; ++y) {
      const std::uint8_t* r0 = image.row(2 * y);
      const std::uint8_t* r1 = image.row(2 * y + 1);
      for (int x = 0; x < w; ++x)
        out[static_cast<std::size_t>(y) * w + x] = static_cast<std::uint8_t>(
            (r0[2 * x] + r0[2 * x + 1] + r1[2 * x] + r1[2 * x + 1] + 2) / 4);
    }
    Image half = Image::fromBytes(std::move(out), w, h, PixelFormat::kGray8).value();
    half.stamp = image.stamp;
    half.frame_id = image.frame_id;
    return half;
  }
  static CameraModel halve(const CameraModel& c) {
    CameraModel h = c;
    h.width = c.width / 2;
    h.height = c.height / 2;
    h.fx = c.fx / 2;
    h.fy = c.fy / 2;
    h.cx = (c.cx + 0.5) / 2 - 0.5;
    h.cy = (c.cy + 0.5) / 2 - 0.5;
    return h;
  }

  // Coarse-to-fine acquisition from an uncertain prediction: a pass on an image pyramid level
  // where the prediction's spread fits the search distance, then one pass per finer level;
  // `start` becomes their estimate. False (acquisition_failure_ says why) when a pass lost the
  // track. The final pass at full resolution (the caller's) checks the inlier ratio.
  Result<bool> acquire(std::span<const tracking::CameraFrame> frames, const DepthMap* depth,
                       const PoseWithCovariance& predicted, Transform& start, bool lateral_first,
                       std::vector<std::vector<Image>>& pyramid) {
    acquisition_ran_ = false;
    if (frames.empty()) return true;
    const std::size_t reference = referenceCamera(frames);
    const double spread = predictionSpreadPx(frames[reference], predicted);
    const int search = options_.search.search_distance;
    if (spread <= search) return true;
    acquisition_ran_ = true;
    // Pyramid levels below full resolution: as many as the spread needs, while the model's image
    // at the level stays large enough to fix the pose (kMinModelPx across).
    const double model_px = modelSizePx(frames[reference], predicted);
    const auto fits = [&](int level) { return model_px / (1 << level) >= kMinModelPx; };
    int levels = 0;
    while (levels < 3 && spread / (1 << levels) > 2 * search && fits(levels + 1)) ++levels;
    tracking::EdgeTrackerOptions coarse = options_;
    coarse.refinement_passes = 0;
    coarse.visibility_update_translation = coarse.visibility_update_rotation = 0;
    coarse.min_inlier_ratio = 0;
    coarse.degraded_inlier_ratio = 0;
    // The passes may move as far as the prediction is uncertain.
    const Matrix6d& c = predicted.covariance;
    coarse.solver.divergence_translation =
        std::max(options_.solver.divergence_translation,
                 2 * acquisition_sigmas_ * std::sqrt(c.topLeftCorner<3, 3>().trace()));
    coarse.solver.divergence_rotation =
        std::max(options_.solver.divergence_rotation,
                 2 * acquisition_sigmas_ * std::sqrt(c.bottomRightCorner<3, 3>().trace()));
    // Below full resolution only the reference camera: the coarse levels place the model within
    // the full-resolution search, which one camera does as well as two (the second doubled the
    // stereo acquisition frame's passes); at full resolution every camera contributes.
    for (std::size_t i = 0; i < frames.size(); ++i)
      if (frames[i].image) pyramidLevel(frames, i, i == reference ? levels : 0, pyramid);
    for (int level = levels; level >= 0; --level) {
      std::vector<tracking::CameraFrame> scaled;
      for (std::size_t i = 0; i < frames.size(); ++i) {
        if (level > 0 && i != reference) continue;
        tracking::CameraFrame frame = frames[i];
        for (int l = 0; l < level; ++l) frame.camera = halve(frame.camera);
        if (frames[i].image) frame.image = &pyramid[i][static_cast<std::size_t>(level)];
        scaled.push_back(frame);
      }
      const double level_spread = spread / (1 << level);
      // The coarsest level first finds the lateral offset alone with the wide search, then all
      // six degrees of freedom from there with the usual one.
      const bool coarsest = level == levels;
      for (int step = coarsest && lateral_first ? 0 : 1; step < 2; ++step) {
        coarse.solver.lateral_only = step == 0;
        coarse.search.search_distance = coarsest && (step == 0 || !lateral_first)
                                            ? std::clamp(static_cast<int>(std::ceil(level_spread)),
                                                         search, acquisition_max_search_)
                                            : search;
        Result<tracking::TrackingResult> pass =
            tracker_.track(scaled, level == 0 ? depth : nullptr, depth_T_camera_, start, coarse);
        if (!pass) return pass.status();
        if (pass->status == TrackingStatus::kLost) {
          acquisition_failure_ = fmt::format("at pyramid level {} (search distance {} px{}): {}",
                                             level, coarse.search.search_distance,
                                             step == 0 ? ", lateral only" : "", pass->reason);
          return false;
        }
        start = pass->reference_T_model;
      }
    }
    return true;
  }

  // The first camera with an image (the left one unless it failed): the one the acquisition's
  // spread, model size and coarse alignment are measured in.
  static std::size_t referenceCamera(std::span<const tracking::CameraFrame> frames) {
    std::size_t reference = 0;
    while (reference + 1 < frames.size() && !frames[reference].image) ++reference;
    return reference;
  }

  // The image of camera `i` at pyramid `level` (2x2 averaging per level), each level built once
  // per frame for the coarse alignment and both acquisition hypotheses.
  static const Image& pyramidLevel(std::span<const tracking::CameraFrame> frames, std::size_t i,
                                   int level, std::vector<std::vector<Image>>& pyramid) {
    if (pyramid.size() < frames.size()) pyramid.resize(frames.size());
    std::vector<Image>& levels = pyramid[i];
    if (levels.empty()) levels.push_back(*frames[i].image);
    while (static_cast<int>(levels.size()) <= level) levels.push_back(halve(levels.back()));
    return levels[static_cast<std::size_t>(level)];
  }

  void warmUpCoarseSearch() const {
    cv::Mat image(64, 64, CV_8UC1, cv::Scalar(0)), edges, distance, labels;
    cv::rectangle(image, cv::Rect(16, 16, 32, 32), cv::Scalar(255), cv::FILLED);
    cv::Canny(image, edges, coarse_canny_low_, 3 * coarse_canny_low_);
    cv::bitwise_not(edges, edges);
    cv::distanceTransform(edges, distance, labels, cv::DIST_L2, cv::DIST_MASK_5,
                          cv::DIST_LABEL_PIXEL);
  }

  // The oriented chamfer cost of a contour sample at each pixel of a window of the image:
  // min(truncation, distance to the nearest edge pixel) + truncation * (1 - |cos|) of the angle
  // between the sample's normal and that edge pixel's gradient, stored as `base` - |a . normal|
  // so that the score's inner loop has no branch but the window's bound. Outside the window
  // (beyond the image) a sample costs `truncation`.
  struct ChamferMap {
    struct Cell {
      float base, ax, ay;
    };
    cv::Rect window;
    std::vector<Cell> cells;
    float truncation = 6;
    int edge_pixels = 0;

    float cost(int x, int y, float nx, float ny) const {
      if (static_cast<unsigned>(x) >= static_cast<unsigned>(window.width) ||
          static_cast<unsigned>(y) >= static_cast<unsigned>(window.height))
        return truncation;
      const Cell& c = cells[static_cast<std::size_t>(y) * window.width + x];
      return c.base - std::abs(c.ax * nx + c.ay * ny);
    }
  };

  // Canny edges, their distance transform and the gradient direction of each pixel's nearest
  // edge pixel (distanceTransform's labels), in `window` of `image` only: the part of the image
  // that the search can reach.
  ChamferMap chamferMap(const Image& image, cv::Rect window, float truncation) const {
    ChamferMap map;
    map.window = window;
    map.truncation = truncation;
    const cv::Mat full = toMat(image);
    const cv::Mat part = full(window);
    cv::Mat edges, not_edges, distance, labels;
    cv::Canny(part, edges, coarse_canny_low_, 3 * coarse_canny_low_);
    map.edge_pixels = cv::countNonZero(edges);
    map.cells.assign(static_cast<std::size_t>(window.area()), {2 * truncation, 0.f, 0.f});
    if (map.edge_pixels == 0) return map;
    cv::bitwise_not(edges, not_edges);
    cv::distanceTransform(not_edges, distance, labels, cv::DIST_L2, cv::DIST_MASK_5,
                          cv::DIST_LABEL_PIXEL);
    // Labels number the edge pixels from 1 in raster order; each gets its Sobel gradient
    // direction, from the whole image so that the window's border does not bias it.
    const auto pixel = [&](int x, int y) {
      return static_cast<float>(
          full.at<std::uint8_t>(std::clamp(y, 0, full.rows - 1), std::clamp(x, 0, full.cols - 1)));
    };
    std::vector<cv::Vec2f> label_direction(1, cv::Vec2f(0, 0));
    label_direction.reserve(static_cast<std::size_t>(map.edge_pixels) + 1);
    for (int y = 0; y < edges.rows; ++y) {
      const std::uint8_t* e = edges.ptr<std::uint8_t>(y);
      for (int x = 0; x < edges.cols; ++x) {
        if (!e[x]) continue;
        const int u = x + window.x, v = y + window.y;
        const float gx = pixel(u + 1, v - 1) + 2 * pixel(u + 1, v) + pixel(u + 1, v + 1) -
                         pixel(u - 1, v - 1) - 2 * pixel(u - 1, v) - pixel(u - 1, v + 1);
        const float gy = pixel(u - 1, v + 1) + 2 * pixel(u, v + 1) + pixel(u + 1, v + 1) -
                         pixel(u - 1, v - 1) - 2 * pixel(u, v - 1) - pixel(u + 1, v - 1);
        const float n = std::max(1e-6f, std::hypot(gx, gy));
        label_direction.push_back(cv::Vec2f(gx / n, gy / n));
      }
    }
    for (int y = 0; y < window.height; ++y) {
      const float* d = distance.ptr<float>(y);
      const int* l = labels.ptr<int>(y);
      ChamferMap::Cell* cell = &map.cells[static_cast<std::size_t>(y) * window.width];
      for (int x = 0; x < window.width; ++x) {
        const cv::Vec2f dir = l[x] >= 0 && l[x] < static_cast<int>(label_direction.size())
                                  ? label_direction[static_cast<std::size_t>(l[x])]
                                  : cv::Vec2f(0, 0);
        cell[x] = {std::min(truncation, d[x]) + truncation, truncation * dir[0],
                   truncation * dir[1]};
      }
    }
    return map;
  }

  // Coarse alignment before the acquisition: at 17 m a 5 % / 5 degree initial error moves the
  // model's image by more than the 1D edge searches reach, so the passes lock onto wrong edges.
  // The model's contours at the prediction are slid and scaled over a truncated distance transform
  // of the image's Canny edges (a chamfer score) on a pyramid level where the model is kMinModelPx
  // or more across; the best shift and scale move the prediction across the line of sight and in
  // range (the attitude is left to the passes). Only when the acquisition would run; no value when
  // it did not run or found nothing to align with.
  Result<std::optional<Transform>> coarseAlign(std::span<const tracking::CameraFrame> frames,
                                               const PoseWithCovariance& predicted,
                                               std::vector<std::vector<Image>>& pyramid) {
    const std::size_t reference = referenceCamera(frames);
    const tracking::CameraFrame& frame = frames[reference];
    if (!frame.image || !tracker_.hasModel()) return std::optional<Transform>();
    const double spread = predictionSpreadPx(frame, predicted);
    if (spread <= options_.search.search_distance) return std::optional<Transform>();
    const double model_px = modelSizePx(frame, predicted);
    // A model wider than the image is seen in part: the chamfer score of its clipped contours is
    // biased towards whatever edges lie inside, and the coarse-to-fine passes reach far enough
    // there.
    if (model_px >= std::min(frame.camera.width, frame.camera.height))
      return std::optional<Transform>();
    int level = 0;
    while (level < 3 && model_px / (2 << level) >= kMinModelPx) ++level;
    CameraModel camera = frame.camera;
    for (int l = 0; l < level; ++l) camera = halve(camera);
    const Eigen::Isometry3d c_T_r = frame.camera_T_reference.isometry();
    const Eigen::Isometry3d c_T_m = c_T_r * predicted.pose.isometry();
    Result<ModelContours> contours = tracking::computeContours(
        tracker_.model(), camera, Transform::fromIsometry(c_T_m, "c", "m"),
        frame.camera_T_reference, options_.visibility);
    if (!contours) return contours.status();
    tracking::SamplingOptions sampling;
    sampling.step = 2;
    sampling.max_samples = 600;
    const ContourSamples samples =
        tracking::sampleContours(std::make_shared<const ModelContours>(*contours), sampling);
    if (samples.samples.size() < 20) return std::optional<Transform>();
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    Eigen::AlignedBox2d box;
    for (const ContourSample& s : samples.samples) {
      mean += s.pixel;
      box.extend(s.pixel);
    }
    mean /= static_cast<double>(samples.samples.size());
    const Matrix6d& c = predicted.covariance;
    const Eigen::Vector3d centre = c_T_m * tracker_.model().centre;
    const double z = centre.z();
    const double lateral =
        acquisition_sigmas_ * std::sqrt(std::max(0.0, c(0, 0) + c(1, 1))) * camera.fx / z;
    const double range = acquisition_sigmas_ * std::sqrt(std::max(0.0, c(2, 2))) / z;
    const int reach = std::clamp(static_cast<int>(std::ceil(lateral)), 1, 200);
    const float truncation = 6;
    const int scale_steps = 4;
    const double scale_step = std::min(range, 0.3) / scale_steps;
    const int grid = 5;
    // The window the search can reach: the contours scaled about their mean by the largest scale
    // (the grid's and the refinements' 0.7 step more), shifted by the reach and the refinements'
    // 7 px, plus the truncation so that distances up to it are those of the whole image.
    const double max_scale = 1 + (scale_steps + 0.7) * scale_step;
    const Eigen::Vector2d low = mean + max_scale * (box.min() - mean);
    const Eigen::Vector2d high = mean + max_scale * (box.max() - mean);
    const int margin = reach + 7 + static_cast<int>(truncation) + 2;
    const cv::Rect window =
        cv::Rect(cv::Point(static_cast<int>(std::floor(low.x())) - margin,
                           static_cast<int>(std::floor(low.y())) - margin),
                 cv::Point(static_cast<int>(std::ceil(high.x())) + margin + 1,
                           static_cast<int>(std::ceil(high.y())) + margin + 1)) &
        cv::Rect(0, 0, camera.width, camera.height);
    const ChamferMap map =
        chamferMap(pyramidLevel(frames, reference, level, pyramid), window, truncation);
    // The contour is sampled every 2 px: with fewer edge pixels in the whole window than samples,
    // no placement can put even half of it on edges, and the search would only pick the least bad
    // clutter (a back-lit target against black space: LOST on every frame, and the search paid on
    // each).
    if (map.edge_pixels < static_cast<int>(samples.samples.size())) {
      coarse_note_ = fmt::format(
          "coarse alignment skipped: {} edge pixels in its {}x{} px search window at pyramid level "
          "{}, fewer than the {} samples of the model's contour",
          map.edge_pixels, window.width, window.height, level, samples.samples.size());
      return std::optional<Transform>();
    }

    // Any scale and shift, with the nearest pixel of each sample.
    const auto score = [&](double s, double dx, double dy) {
      float total = 0;
      for (const ContourSample& q : samples.samples) {
        const double u = mean.x() + s * (q.pixel.x() - mean.x()) + dx;
        const double v = mean.y() + s * (q.pixel.y() - mean.y()) + dy;
        total += map.cost(static_cast<int>(std::lround(u)) - window.x,
                          static_cast<int>(std::lround(v)) - window.y,
                          static_cast<float>(q.normal.x()), static_cast<float>(q.normal.y()));
      }
      return static_cast<double>(total);
    };
    // A grid as coarse as the truncation allows (the score still falls towards the minimum
    // within it), then finer grids around the best. On the grid the shifts are whole pixels, so
    // each sample's pixel is rounded once per scale; a shift stops being scored once its partial
    // sum reaches the best (the costs are not negative).
    double best = score(1, 0, 0), best_s = 1, best_x = 0, best_y = 0;
    struct Placed {
      int x, y;
      float nx, ny;
    };
    std::vector<Placed> placed(samples.samples.size());
    for (int k = -scale_steps; k <= scale_steps; ++k) {
      const double s = 1 + scale_step * k;
      for (std::size_t i = 0; i < samples.samples.size(); ++i) {
        const ContourSample& q = samples.samples[i];
        placed[i] = {
            static_cast<int>(std::lround(mean.x() + s * (q.pixel.x() - mean.x()))) - window.x,
            static_cast<int>(std::lround(mean.y() + s * (q.pixel.y() - mean.y()))) - window.y,
            static_cast<float>(q.normal.x()), static_cast<float>(q.normal.y())};
      }
      for (int dy = -reach; dy <= reach; dy += grid)
        for (int dx = -reach; dx <= reach; dx += grid) {
          float total = 0;
          const float bound = static_cast<float>(best);
          for (const Placed& p : placed) {
            total += map.cost(p.x + dx, p.y + dy, p.nx, p.ny);
            if (total >= bound) break;
          }
          if (total < bound) best = total, best_s = s, best_x = dx, best_y = dy;
        }
    }
    for (double step = 2; step >= 0.5; step /= 2) {
      const double s0 = best_s, x0 = best_x, y0 = best_y;
      for (int k = -1; k <= 1; ++k)
        for (int dy = -2; dy <= 2; ++dy)
          for (int dx = -2; dx <= 2; ++dx) {
            const double s = s0 + k * scale_step * step / grid;
            const double v = score(s, x0 + dx * step, y0 + dy * step);
            if (v < best) best = v, best_s = s, best_x = x0 + dx * step, best_y = y0 + dy * step;
          }
    }
    // The model's centre moves with the contours' image; its depth scales inversely.
    const Eigen::Vector2d centre_px(camera.fx * centre.x() / z + camera.cx,
                                    camera.fy * centre.y() / z + camera.cy);
    const Eigen::Vector2d moved_px =
        mean + best_s * (centre_px - mean) + Eigen::Vector2d(best_x, best_y);
    const double moved_z = z / best_s;
    const Eigen::Vector3d moved((moved_px.x() - camera.cx) / camera.fx * moved_z,
                                (moved_px.y() - camera.cy) / camera.fy * moved_z, moved_z);
    Eigen::Isometry3d aligned = c_T_m;
    aligned.pretranslate(moved - centre);
    return std::optional<Transform>(
        Transform::fromIsometry(c_T_r.inverse() * aligned, predicted.pose.parent_frame,
                                predicted.pose.child_frame, predicted.pose.stamp));
  }

  bool coarse_search_ = false;
  std::string coarse_note_;  // why this frame's coarse alignment did not run, for the LOST reason
  double coarse_canny_low_ = 20;  // acquisition_canny_low
  double acquisition_sigmas_ = 3;
  int acquisition_max_search_ = 64;
  bool lateral_first_ = true;
  bool acquisition_ran_ = false;
  bool awaiting_confirmation_ = false;
  Matrix6d acquisition_covariance_ = Matrix6d::Zero();
  std::optional<Matrix6d> reacquisition_covariance_;
  // The chi-square 0.999 quantile for 6 degrees of freedom.
  static constexpr double kAcquisitionGate = 22.46;
  std::string acquisition_failure_;
  tracking::EdgeTrackerOptions options_;
  Eigen::Isometry3d depth_T_camera_ = Eigen::Isometry3d::Identity();
  mbt::ModelSource models_;
  tracking::EdgeTracker tracker_;
};

CDFF_REGISTER_DFI(ModelBasedTrackingEdgeTracker);

}  // namespace cdff::dfn
