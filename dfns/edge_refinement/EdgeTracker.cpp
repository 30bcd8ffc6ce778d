// EdgeRefinement/EdgeTracker: every candidate acquired and tracked by the edge tracker
// (tracking::AcquiringEdgeTracker, ModelBasedTracking/EdgeTracker's code); the converged poses
// compared where their contours differ.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "EdgeRefinement.gen.hpp"
#include "cdff/registration/model_symmetry.hpp"
#include "cdff/tracking/acquiring_edge_tracker.hpp"
#include "cdff/tracking/contours.hpp"
#include "cdff/tracking/edge_search.hpp"
#include "cdff/types/mesh.hpp"
#include "cdff/types/opencv.hpp"

namespace cdff::dfn {

namespace {

// The chance lines' distance from a contour sample, in evidence distances: outside its own
// window, near enough to cross the same surface.
constexpr double kChanceShift = 3.0;

// One converged candidate.
struct Converged {
  tracking::TrackingResult result;
  int candidate = -1;
  std::vector<Eigen::Vector2d> pixels;  // its visible contour samples in the image
  std::vector<bool> supported;          // whether each has an image edge within the evidence
  std::vector<int> by_chance;  // per sample: on how many of the two shifted lines an edge is
  int wins = 0;
  std::vector<double> margin;  // per other pose: own support minus its, where they differ (NaN)
};

// The model's near-symmetries (model frame, x -> s x): registration::nearSymmetries on points
// sampled uniformly over its faces (fan-triangulated; its lines, cylinders and circles are left
// out), 20000 of them whatever its size.
Result<std::vector<Eigen::Isometry3d>> nearSymmetriesOf(const PolygonModel& model,
                                                        double min_overlap) {
  std::vector<Eigen::Vector3f> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  for (const Eigen::Vector3d& p : model.points) vertices.push_back(p.cast<float>());
  for (const PolygonModel::Face& face : model.faces)
    for (std::size_t k = 1; k + 1 < face.points.size(); ++k)
      triangles.push_back({face.points[0], face.points[k], face.points[k + 1]});
  if (triangles.empty()) return std::vector<Eigen::Isometry3d>{};
  TriangleMesh surface;
  surface.vertices = Buffer<Eigen::Vector3f>::fromVector(std::move(vertices));
  surface.triangles = Buffer<std::array<std::uint32_t, 3>>::fromVector(std::move(triangles));
  Result<PointCloud> samples = sampleSurface(surface, 20'000, 1, SampleNormals::kFace);
  if (!samples) return samples.status().withContext("the model's faces");
  registration::ModelIndex index;
  CDFF_RETURN_IF_ERROR(index.update(*samples).withContext("the model's faces"));
  registration::SymmetryOptions options;
  options.min_overlap = min_overlap;
  return registration::motionsOf(registration::nearSymmetries(index, options));
}

}  // namespace

class EdgeRefinementEdgeTracker final : public EdgeRefinementEdgeTrackerBase {
 protected:
  Status onConfigure() override {
    file_model_.reset();
    if (!params_.model_file.empty()) {
      Result<PolygonModel> model = loadCao(params_.model_file);
      if (!model) return model.status().withContext("parameter 'model_file'");
      file_model_ = std::make_shared<const PolygonModel>(std::move(model).value());
    }
    options_ = {};
    tracking::EdgeTrackerOptions& o = options_.tracking;
    o.search.search_distance = params_.search_distance;
    o.search.relative_gradient = params_.relative_gradient;
    o.visibility.min_crease_angle = params_.min_crease_angle;
    o.refinement_passes = 2;
    o.min_inlier_ratio = 0.1;  // a weak fit still competes; `refined` applies min_inlier_ratio
    options_.acquisition.restarts = 0;  // the candidates are the restarts
    prepared_ = nullptr;
    // The file's model is prepared now, so that the first frame does not wait for it.
    if (file_model_)
      CDFF_RETURN_IF_ERROR(prepare(file_model_).withContext("parameter 'model_file'"));
    return Status::ok();
  }

  Status onProcess() override {
    const Detections& detections = *in.candidates;
    CDFF_RETURN_IF_ERROR(detections.validate().withContext("input 'candidates'"));
    const std::shared_ptr<const PolygonModel> model =
        in.model.hasValue() ? in.model.shared() : file_model_;
    if (!model)
      return invalidInput("no model: expected the 'model' input or the parameter model_file");
    const Image& image = *in.image;
    if (!image.camera)
      return invalidInput(
          "input 'image' ({}x{}, frame '{}') has no camera model; expected a calibrated, "
          "distortion-free image",
          image.width, image.height, image.frame_id);
    CDFF_RETURN_IF_ERROR(tracking::checkPinhole(*image.camera, "input 'image'"));
    if (!detections.frame_id.empty() && !image.frame_id.empty() &&
        detections.frame_id != image.frame_id)
      return invalidInput(
          "input 'candidates' are in frame '{}' but input 'image' is in frame '{}'; expected the "
          "candidates of this image",
          detections.frame_id, image.frame_id);
    Result<Image> grey = tracking::toGray8(image, "input 'image'");
    if (!grey) return grey.status();
    if (model != prepared_) CDFF_RETURN_IF_ERROR(prepare(model).withContext("input 'model'"));

    const std::vector<tracking::CameraFrame> cameras = {
        {&*grey, *image.camera, Transform::identity(image.frame_id, image.frame_id)}};
    const Frame frame{*grey, {cameras, nullptr, Eigen::Isometry3d::Identity()}, *model};
    std::vector<Converged> converged;
    const int count = std::min<int>(params_.candidates, detections.detections.size());
    for (int i = 0; i < count; ++i)
      CDFF_RETURN_IF_ERROR(trackFrom(detections.detections[i].pose, i, frame, converged));
    // A near-symmetric target converges onto whichever of its symmetric poses is nearest the
    // start: each converged pose moved by the model's near-symmetries is tried too, so that the
    // poses the comparison must tell apart are all there.
    const std::size_t found = converged.size();
    for (std::size_t k = 0; k < found; ++k) {
      const Transform pose = converged[k].result.reference_T_model;
      for (const Eigen::Isometry3d& turn : symmetries_) {
        const Transform start = Transform::fromIsometry(pose.isometry() * turn, pose.parent_frame,
                                                        pose.child_frame, pose.stamp);
        CDFF_RETURN_IF_ERROR(trackFrom(start, converged[k].candidate, frame, converged));
      }
    }

    out.alternatives.set(static_cast<int>(converged.size()));
    if (converged.empty()) {
      out.ambiguous.set(false);
      out.candidate.set(-1);
      out.refined.set(false);
      out.inlier_ratio.set(std::numeric_limits<double>::quiet_NaN());
      return Status::ok();
    }
    compare(converged);
    const auto chosen = std::max_element(
        converged.begin(), converged.end(), [](const Converged& a, const Converged& b) {
          return a.wins != b.wins ? a.wins < b.wins : a.result.inlier_ratio < b.result.inlier_ratio;
        });
    const Converged& best = *chosen;
    const bool ambiguous = isAmbiguous(converged, best);
    out.ambiguous.set(ambiguous);
    PoseWithCovariance pose;
    pose.pose = best.result.reference_T_model;
    pose.pose.stamp = detections.stamp;
    pose.covariance = best.result.covariance;
    out.pose.set(std::move(pose));
    out.candidate.set(best.candidate);
    out.inlier_ratio.set(best.result.inlier_ratio);
    out.refined.set(best.result.inlier_ratio >= params_.min_inlier_ratio && !ambiguous);
    return Status::ok();
  }

 private:
  struct Frame {
    const Image& grey;
    tracking::FrameMeasurements measurements;
    const PolygonModel& model;
  };

  // Tracks from `start` as a first frame (nothing carries over from the previous start); a pose
  // that converged and is not one already found joins `converged`.
  Status trackFrom(const Transform& start, int candidate, const Frame& frame,
                   std::vector<Converged>& converged) {
    const double range = start.translation.norm();
    tracking::PosePrediction prediction;
    prediction.pose.pose = start;
    prediction.pose.pose.stamp = frame.grey.stamp;
    prediction.pose.covariance.diagonal()
        << Eigen::Vector3d::Constant(std::pow(params_.position_sigma * range, 2)),
        Eigen::Vector3d::Constant(std::pow(params_.attitude_sigma, 2));
    tracker_.configure(options_);
    CDFF_RETURN_IF_ERROR(tracker_.setModel(frame.model).withContext("model"));
    Result<tracking::AcquiringTrackingResult> tracked =
        tracker_.track(frame.measurements, prediction);
    if (!tracked) return tracked.status();
    const tracking::TrackingResult& r = tracked->tracking;
    if (r.status == TrackingStatus::kLost) return Status::ok();
    const bool repeat = std::any_of(converged.begin(), converged.end(), [&](const Converged& c) {
      return angularDistance(c.result.reference_T_model.rotation, r.reference_T_model.rotation) <
                 2 * M_PI / 180 &&
             (c.result.reference_T_model.translation - r.reference_T_model.translation).norm() <
                 0.01 * range;
    });
    if (repeat) return Status::ok();
    Converged c;
    c.result = r;
    c.candidate = candidate;
    CDFF_RETURN_IF_ERROR(evidence(frame.grey, c));
    converged.push_back(std::move(c));
    return Status::ok();
  }

  // The converged pose's visible contour samples in the image and whether an image edge supports
  // each one within evidence_distance (the edge search's orientation test included).
  Status evidence(const Image& grey, Converged& c) const {
    const tracking::EdgeTrackerOptions& o = options_.tracking;
    const Transform identity = Transform::identity(grey.frame_id, grey.frame_id);
    Result<ModelContours> contours =
        tracking::computeContours(tracker_.tracker().model(), *grey.camera,
                                  c.result.reference_T_model, identity, o.visibility);
    if (!contours) return contours.status();
    tracking::SamplingOptions sampling = o.sampling;
    sampling.step = 2.0;  // dense: the parts that differ may be a few samples long
    sampling.max_samples = 4000;
    const ContourSamples samples = tracking::sampleContours(
        std::make_shared<const ModelContours>(std::move(*contours)), sampling);
    // Out to the shifted lines, every edge: the strongest few would hide the near ones.
    const double e = params_.evidence_distance, shift = kChanceShift * e;
    tracking::EdgeSearchOptions search = o.search;
    search.search_distance = static_cast<int>(std::ceil(shift + e));
    search.max_candidates = 4 * search.search_distance;
    Result<ContourSamples> searched = tracking::searchEdges(grey, samples, search);
    if (!searched) return searched.status();
    for (const ContourSample& s : searched->samples) {
      bool near = false, before = false, after = false;
      for (std::uint32_t k = 0; k < s.candidate_count; ++k) {
        const double offset = searched->candidates[s.first_candidate + k].offset;
        near = near || std::abs(offset) <= e;
        before = before || std::abs(offset + shift) <= e;
        after = after || std::abs(offset - shift) <= e;
      }
      c.pixels.push_back(s.pixel);
      c.supported.push_back(near);
      c.by_chance.push_back((before ? 1 : 0) + (after ? 1 : 0));
    }
    return Status::ok();
  }

  // Pairwise: each pose is judged on its samples where the other shows none; the one whose
  // samples there find edges more often wins the pair.
  void compare(std::vector<Converged>& converged) const {
    const CameraModel& camera = *in.image->camera;
    for (Converged& c : converged)
      c.margin.assign(converged.size(), std::numeric_limits<double>::quiet_NaN());
    for (std::size_t i = 0; i < converged.size(); ++i)
      for (std::size_t j = i + 1; j < converged.size(); ++j) {
        const double a = supportWhereDifferent(converged[i], converged[j], camera);
        const double b = supportWhereDifferent(converged[j], converged[i], camera);
        converged[i].margin[j] = a - b;
        converged[j].margin[i] = b - a;
        if (std::isnan(a) || std::isnan(b) || a == b) continue;
        ++(a > b ? converged[i] : converged[j]).wins;
      }
  }

  // Ambiguous: another pose fits the edges nearly as well and where the two differ the image does
  // not clearly favour the chosen one (a symmetric target's distinguishing part dark, edge-on or
  // out of view; a NaN margin, too few differing samples, does not favour it either).
  bool isAmbiguous(const std::vector<Converged>& converged, const Converged& best) const {
    for (std::size_t k = 0; k < converged.size(); ++k) {
      if (&converged[k] == &best) continue;
      const bool rival =
          converged[k].result.inlier_ratio >= best.result.inlier_ratio - params_.rival_inlier_gap;
      if (rival && !(best.margin[k] >= params_.min_evidence_margin)) return true;
    }
    return false;
  }

  // Over `p`'s samples farther than evidence_distance from every sample of `q`: the fraction that
  // an image edge supports, less the fraction that the same lines shifted kChanceShift times the
  // evidence distance to either side find (the rate at which the image's texture and clutter
  // there support any contour by chance: a dark part drawn over a textured surface finds some of
  // the texture's edges, one drawn over empty space none); NaN with fewer than
  // min_evidence_samples such samples.
  double supportWhereDifferent(const Converged& p, const Converged& q,
                               const CameraModel& camera) const {
    // q's samples drawn into a mask, dilated by the evidence distance.
    cv::Mat mask = cv::Mat::zeros(camera.height, camera.width, CV_8UC1);
    for (const Eigen::Vector2d& px : q.pixels)
      cv::circle(
          mask,
          cv::Point(static_cast<int>(std::lround(px.x())), static_cast<int>(std::lround(px.y()))),
          static_cast<int>(std::ceil(params_.evidence_distance)), cv::Scalar(255), cv::FILLED);
    std::size_t differing = 0, supported = 0, by_chance = 0;
    for (std::size_t k = 0; k < p.pixels.size(); ++k) {
      const int x = static_cast<int>(std::lround(p.pixels[k].x()));
      const int y = static_cast<int>(std::lround(p.pixels[k].y()));
      if (x < 0 || y < 0 || x >= mask.cols || y >= mask.rows || mask.at<std::uint8_t>(y, x))
        continue;
      ++differing;
      supported += p.supported[k] ? 1 : 0;
      by_chance += static_cast<std::size_t>(p.by_chance[k]);
    }
    if (differing < static_cast<std::size_t>(params_.min_evidence_samples))
      return std::numeric_limits<double>::quiet_NaN();
    return (static_cast<double>(supported) - 0.5 * static_cast<double>(by_chance)) / differing;
  }

  /// The model's near-symmetries, once per model (held, so that another model cannot take its
  /// address and its symmetries).
  Status prepare(const std::shared_ptr<const PolygonModel>& model) {
    Result<std::vector<Eigen::Isometry3d>> symmetries =
        nearSymmetriesOf(*model, params_.min_symmetry_overlap);
    if (!symmetries) return symmetries.status();
    symmetries_ = std::move(symmetries).value();
    prepared_ = model;
    return Status::ok();
  }

  std::shared_ptr<const PolygonModel> file_model_;
  std::shared_ptr<const PolygonModel> prepared_;
  std::vector<Eigen::Isometry3d> symmetries_;  // of the prepared model
  tracking::AcquiringEdgeTrackerOptions options_;
  tracking::AcquiringEdgeTracker tracker_;
};

CDFF_REGISTER_DFI(EdgeRefinementEdgeTracker);

}  // namespace cdff::dfn
