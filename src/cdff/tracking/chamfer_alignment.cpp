#include "cdff/tracking/chamfer_alignment.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <utility>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "cdff/tracking/contours.hpp"
#include "cdff/types/opencv.hpp"

namespace cdff::tracking {

namespace {

constexpr float kTruncation = 6;     // px: an edge farther away costs as much as none
constexpr int kScaleSteps = 4;       // scales on each side of 1 in the grid
constexpr int kGrid = 5;             // px between the grid's shifts (the truncation allows no more)
constexpr int kRefinementReach = 7;  // px the refinements add to the grid's shift: 2 (2 + 1 + 0.5)

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
  float truncation = kTruncation;
  int edge_pixels = 0;

  float cost(int x, int y, float nx, float ny) const {
    if (static_cast<unsigned>(x) >= static_cast<unsigned>(window.width) ||
        static_cast<unsigned>(y) >= static_cast<unsigned>(window.height))
      return truncation;
    const Cell& c = cells[static_cast<std::size_t>(y) * window.width + x];
    return c.base - std::abs(c.ax * nx + c.ay * ny);
  }
};

// The unit Sobel gradient direction of each edge pixel of `edges` (a window of `full` at
// `origin`), in raster order after a null direction: distanceTransform's labels number the edge
// pixels from 1 in that order. The gradient is read in the whole image so that the window's
// border does not bias it.
std::vector<cv::Vec2f> edgeDirections(const cv::Mat& full, const cv::Mat& edges, cv::Point origin,
                                      int edge_pixels) {
  const auto pixel = [&](int x, int y) {
    return static_cast<float>(
        full.at<std::uint8_t>(std::clamp(y, 0, full.rows - 1), std::clamp(x, 0, full.cols - 1)));
  };
  std::vector<cv::Vec2f> label_direction(1, cv::Vec2f(0, 0));
  label_direction.reserve(static_cast<std::size_t>(edge_pixels) + 1);
  for (int y = 0; y < edges.rows; ++y) {
    const std::uint8_t* e = edges.ptr<std::uint8_t>(y);
    for (int x = 0; x < edges.cols; ++x) {
      if (!e[x]) continue;
      const int u = x + origin.x, v = y + origin.y;
      const float gx = pixel(u + 1, v - 1) + 2 * pixel(u + 1, v) + pixel(u + 1, v + 1) -
                       pixel(u - 1, v - 1) - 2 * pixel(u - 1, v) - pixel(u - 1, v + 1);
      const float gy = pixel(u - 1, v + 1) + 2 * pixel(u, v + 1) + pixel(u + 1, v + 1) -
                       pixel(u - 1, v - 1) - 2 * pixel(u, v - 1) - pixel(u + 1, v - 1);
      const float n = std::max(1e-6f, std::hypot(gx, gy));
      label_direction.push_back(cv::Vec2f(gx / n, gy / n));
    }
  }
  return label_direction;
}

// Canny edges, their distance transform and the gradient direction of each pixel's nearest edge
// pixel (distanceTransform's labels), in `window` of `image` only: the part of the image that the
// search can reach.
ChamferMap chamferMap(const Image& image, cv::Rect window, float truncation, double canny_low) {
  ChamferMap map;
  map.window = window;
  map.truncation = truncation;
  const cv::Mat full = toMat(image);
  const cv::Mat part = full(window);
  cv::Mat edges, not_edges, distance, labels;
  cv::Canny(part, edges, canny_low, 3 * canny_low);
  map.edge_pixels = cv::countNonZero(edges);
  map.cells.assign(static_cast<std::size_t>(window.area()), {2 * truncation, 0.f, 0.f});
  if (map.edge_pixels == 0) return map;
  cv::bitwise_not(edges, not_edges);
  cv::distanceTransform(not_edges, distance, labels, cv::DIST_L2, cv::DIST_MASK_5,
                        cv::DIST_LABEL_PIXEL);
  const std::vector<cv::Vec2f> label_direction =
      edgeDirections(full, edges, window.tl(), map.edge_pixels);
  for (int y = 0; y < window.height; ++y) {
    const float* d = distance.ptr<float>(y);
    const int* l = labels.ptr<int>(y);
    ChamferMap::Cell* cell = &map.cells[static_cast<std::size_t>(y) * window.width];
    for (int x = 0; x < window.width; ++x) {
      const cv::Vec2f dir = l[x] >= 0 && l[x] < static_cast<int>(label_direction.size())
                                ? label_direction[static_cast<std::size_t>(l[x])]
                                : cv::Vec2f(0, 0);
      cell[x] = {std::min(truncation, d[x]) + truncation, truncation * dir[0], truncation * dir[1]};
    }
  }
  return map;
}

// The model's contour at the prediction on the alignment's level, sampled every 2 px: the
// samples, their mean and bounding box.
struct ContourTemplate {
  std::vector<ContourSample> samples;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  Eigen::AlignedBox2d box;
};

// No value with fewer than 20 samples: too little contour to align.
Result<std::optional<ContourTemplate>> contourTemplate(const TrackingModel& model,
                                                       const CameraModel& camera,
                                                       const Eigen::Isometry3d& c_T_m,
                                                       const Transform& camera_T_reference,
                                                       const VisibilityOptions& visibility) {
  Result<ModelContours> contours = computeContours(
      model, camera, Transform::fromIsometry(c_T_m, "c", "m"), camera_T_reference, visibility);
  if (!contours) return contours.status();
  SamplingOptions sampling;
  sampling.step = 2;
  sampling.max_samples = 600;
  ContourSamples samples =
      sampleContours(std::make_shared<const ModelContours>(*contours), sampling);
  if (samples.samples.size() < 20) return std::optional<ContourTemplate>();
  ContourTemplate t;
  t.samples = std::move(samples.samples);
  for (const ContourSample& s : t.samples) {
    t.mean += s.pixel;
    t.box.extend(s.pixel);
  }
  t.mean /= static_cast<double>(t.samples.size());
  return std::optional<ContourTemplate>(std::move(t));
}

// How far the search goes: shifts of up to `reach` px each way (acquisition_sigmas of the lateral
// uncertainty), scales of 1 +- kScaleSteps * `scale_step` (of the range uncertainty, at most 0.3).
struct SearchExtent {
  int reach = 1;
  double scale_step = 0;
};

SearchExtent searchExtent(const Matrix6d& c, double sigmas, const CameraModel& camera, double z) {
  const double lateral = sigmas * std::sqrt(std::max(0.0, c(0, 0) + c(1, 1))) * camera.fx / z;
  const double range = sigmas * std::sqrt(std::max(0.0, c(2, 2))) / z;
  SearchExtent e;
  e.reach = std::clamp(static_cast<int>(std::ceil(lateral)), 1, 200);
  e.scale_step = std::min(range, 0.3) / kScaleSteps;
  return e;
}

// The window the search can reach: the contours scaled about their mean by the largest scale
// (the grid's and the refinements' 0.7 step more), shifted by the reach and the refinements'
// reach, plus the truncation so that distances up to it are those of the whole image.
cv::Rect searchWindow(const ContourTemplate& t, const SearchExtent& e, const CameraModel& camera) {
  const double max_scale = 1 + (kScaleSteps + 0.7) * e.scale_step;
  const Eigen::Vector2d low = t.mean + max_scale * (t.box.min() - t.mean);
  const Eigen::Vector2d high = t.mean + max_scale * (t.box.max() - t.mean);
  const int margin = e.reach + kRefinementReach + static_cast<int>(kTruncation) + 2;
  return cv::Rect(cv::Point(static_cast<int>(std::floor(low.x())) - margin,
                            static_cast<int>(std::floor(low.y())) - margin),
                  cv::Point(static_cast<int>(std::ceil(high.x())) + margin + 1,
                            static_cast<int>(std::ceil(high.y())) + margin + 1)) &
         cv::Rect(0, 0, camera.width, camera.height);
}

struct ChamferPlacement {
  double score = 0;
  double scale = 1, x = 0, y = 0;  // about the contour's mean; px
};

// The score of any scale and shift, each sample at its nearest pixel.
double score(const ChamferMap& map, const ContourTemplate& t, double s, double dx, double dy) {
  float total = 0;
  for (const ContourSample& q : t.samples) {
    const double u = t.mean.x() + s * (q.pixel.x() - t.mean.x()) + dx;
    const double v = t.mean.y() + s * (q.pixel.y() - t.mean.y()) + dy;
    total += map.cost(static_cast<int>(std::lround(u)) - map.window.x,
                      static_cast<int>(std::lround(v)) - map.window.y,
                      static_cast<float>(q.normal.x()), static_cast<float>(q.normal.y()));
  }
  return static_cast<double>(total);
}

// A grid as coarse as the truncation allows (the score still falls towards the minimum within
// it). Its shifts are whole pixels, so each sample's pixel is rounded once per scale; a shift stops
// being scored once its partial sum reaches the best (the costs are not negative).
ChamferPlacement gridSearch(const ChamferMap& map, const ContourTemplate& t,
                            const SearchExtent& e) {
  ChamferPlacement best;
  best.score = score(map, t, 1, 0, 0);
  struct Placed {
    int x, y;
    float nx, ny;
  };
  std::vector<Placed> placed(t.samples.size());
  for (int k = -kScaleSteps; k <= kScaleSteps; ++k) {
    const double s = 1 + e.scale_step * k;
    for (std::size_t i = 0; i < t.samples.size(); ++i) {
      const ContourSample& q = t.samples[i];
      placed[i] = {
          static_cast<int>(std::lround(t.mean.x() + s * (q.pixel.x() - t.mean.x()))) - map.window.x,
          static_cast<int>(std::lround(t.mean.y() + s * (q.pixel.y() - t.mean.y()))) - map.window.y,
          static_cast<float>(q.normal.x()), static_cast<float>(q.normal.y())};
    }
    for (int dy = -e.reach; dy <= e.reach; dy += kGrid)
      for (int dx = -e.reach; dx <= e.reach; dx += kGrid) {
        float total = 0;
        const float bound = static_cast<float>(best.score);
        for (const Placed& p : placed) {
          total += map.cost(p.x + dx, p.y + dy, p.nx, p.ny);
          if (total >= bound) break;
        }
        if (total < bound) best.score = total, best.scale = s, best.x = dx, best.y = dy;
      }
  }
  return best;
}

// Finer grids around the best: shifts of 2, 1 and 0.5 px, scales of the grid's step times the
// shift over kGrid.
void refine(const ChamferMap& map, const ContourTemplate& t, const SearchExtent& e,
            ChamferPlacement& best) {
  for (double step = 2; step >= 0.5; step /= 2) {
    const double s0 = best.scale, x0 = best.x, y0 = best.y;
    for (int k = -1; k <= 1; ++k)
      for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx) {
          const double s = s0 + k * e.scale_step * step / kGrid;
          const double v = score(map, t, s, x0 + dx * step, y0 + dy * step);
          if (v < best.score)
            best.score = v, best.scale = s, best.x = x0 + dx * step, best.y = y0 + dy * step;
        }
  }
}

// The prediction moved by a placement: the model's centre moves with the contours' image, its
// depth scales inversely; the attitude stays.
Transform placedPose(const ChamferPlacement& best, const ContourTemplate& t,
                     const CameraModel& camera, const Eigen::Isometry3d& c_T_r,
                     const Eigen::Isometry3d& c_T_m, const Eigen::Vector3d& centre,
                     const Transform& predicted) {
  const double z = centre.z();
  const Eigen::Vector2d centre_px(camera.fx * centre.x() / z + camera.cx,
                                  camera.fy * centre.y() / z + camera.cy);
  const Eigen::Vector2d moved_px =
      t.mean + best.scale * (centre_px - t.mean) + Eigen::Vector2d(best.x, best.y);
  const double moved_z = z / best.scale;
  const Eigen::Vector3d moved((moved_px.x() - camera.cx) / camera.fx * moved_z,
                              (moved_px.y() - camera.cy) / camera.fy * moved_z, moved_z);
  Eigen::Isometry3d aligned = c_T_m;
  aligned.pretranslate(moved - centre);
  return Transform::fromIsometry(c_T_r.inverse() * aligned, predicted.parent_frame,
                                 predicted.child_frame, predicted.stamp);
}

// The pyramid level of the alignment: the coarsest (at most 3) where the model stays kMinModelPx
// or more across.
int alignmentLevel(double model_px) {
  int level = 0;
  while (level < 3 && model_px / (2 << level) >= kMinModelPx) ++level;
  return level;
}

}  // namespace

Result<CoarseAlignment> alignCoarsely(const TrackingModel& model,
                                      std::span<const CameraFrame> frames,
                                      const PoseWithCovariance& predicted,
                                      const EdgeTrackerOptions& options,
                                      const AcquisitionOptions& acquisition,
                                      const ChamferAlignmentOptions& chamfer,
                                      FramePyramids& pyramids) {
  CoarseAlignment out;
  if (frames.empty()) return out;
  const std::size_t reference = referenceCamera(frames);
  const CameraFrame& frame = frames[reference];
  if (!frame.image) return out;
  const double near = options.visibility.near_clipping;
  if (visibleSpreadPx(model, frame, predicted, acquisition.sigmas, near) <=
      options.search.search_distance)
    return out;
  const double model_px = modelSizePx(model, frame, predicted, near);
  if (model_px >= std::min(frame.camera.width, frame.camera.height)) return out;
  const int level = alignmentLevel(model_px);
  const CameraModel camera = cameraAtLevel(frame.camera, level);
  const Eigen::Isometry3d c_T_r = frame.camera_T_reference.isometry();
  const Eigen::Isometry3d c_T_m = c_T_r * predicted.pose.isometry();
  Result<std::optional<ContourTemplate>> t =
      contourTemplate(model, camera, c_T_m, frame.camera_T_reference, options.visibility);
  if (!t) return t.status();
  if (!*t) return out;
  const ContourTemplate& contour = **t;
  const Eigen::Vector3d centre = c_T_m * model.centre;
  const SearchExtent extent =
      searchExtent(predicted.covariance, acquisition.sigmas, camera, centre.z());
  const cv::Rect window = searchWindow(contour, extent, camera);
  const ChamferMap map =
      chamferMap(pyramids.image(reference, level), window, kTruncation, chamfer.canny_low);
  if (map.edge_pixels < static_cast<int>(contour.samples.size())) {
    out.note = fmt::format(
        "coarse alignment skipped: {} edge pixels in its {}x{} px search window at pyramid level "
        "{}, fewer than the {} samples of the model's contour",
        map.edge_pixels, window.width, window.height, level, contour.samples.size());
    return out;
  }
  ChamferPlacement best = gridSearch(map, contour, extent);
  refine(map, contour, extent, best);
  out.start = placedPose(best, contour, camera, c_T_r, c_T_m, centre, predicted.pose);
  return out;
}

void warmUpChamferAlignment(const ChamferAlignmentOptions& chamfer) {
  cv::Mat image(64, 64, CV_8UC1, cv::Scalar(0)), edges, distance, labels;
  cv::rectangle(image, cv::Rect(16, 16, 32, 32), cv::Scalar(255), cv::FILLED);
  cv::Canny(image, edges, chamfer.canny_low, 3 * chamfer.canny_low);
  cv::bitwise_not(edges, edges);
  cv::distanceTransform(edges, distance, labels, cv::DIST_L2, cv::DIST_MASK_5,
                        cv::DIST_LABEL_PIXEL);
}

}  // namespace cdff::tracking
