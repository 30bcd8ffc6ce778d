#pragma once
// What both TemplateMatching DFIs share: the template and its taking, the image crop and its
// pyramid, the coarse ZNCC search and the covariance of a refined warp. The DFIs differ only in
// the refinement of the warp.

#include <functional>
#include <limits>
#include <optional>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "cdff/types/image.hpp"
#include "cdff/types/image_region.hpp"
#include "cdff/types/status.hpp"

namespace cdff::dfn::template_matching {

/// The parameters both DFIs take (TemplateMatching.yaml).
struct Settings {
  double min_score = 0.6;
  double search_sigmas = 4;
  double min_search_radius = 8;
  double max_search_radius = 200;
  double min_extent_for_scale = 4;
  double update_scale_ratio = 1.25;
  double min_update_score = 0.8;
  int template_memory = 10;
  int max_template_size = 96;
  int max_iterations = 30;
  double pixel_correlation = 1;
};

/// Part of an image, converted to float grey, with its halvings: level m's pixel (x, y) is level
/// 0's ((x + 0.5) 2^m - 0.5, (y + 0.5) 2^m - 0.5), level 0's pixel (x, y) the image's
/// (x + origin.x, y + origin.y).
struct Crop {
  std::vector<cv::Mat> levels;  // CV_32F
  cv::Point origin;
  /// The homography from image pixels to level m's pixels.
  Eigen::Matrix3d imageToLevel(int m) const;
};

/// The crop of `image` covering [x0, x1) x [y0, y1) (clipped to the image; origin a multiple of
/// 2^levels) with `levels` halvings beyond level 0.
Result<Crop> cropOf(const Image& image, double x0, double y0, double x1, double y1, int levels);

/// The image rectangle a region's template covers, with `margin` pixels around it.
cv::Rect2d footprint(const ImageRegion& region, double margin);

/// The pyramid level at which one template pixel of `region` is about one pixel.
int levelFor(const ImageRegion& region);

/// A template: its pixels (CV_32F) and where they are in the image the last match was in.
struct Template {
  cv::Mat pixels;
  ImageRegion region;           // the last match (or the designation): template -> image
  double scale_at_taking = 1;   // the region's scale when the template was taken
  double extent_at_taking = 0;  // the target's extent in it then (image px)
  bool estimates_scale = false;
  int averaged = 1;  // the matches averaged into the pixels (at most template_memory)
};

/// Takes a template from `crop` along `region` (its homography maps template pixels to image
/// pixels), at the resolution at which the longest side fits max_template_size. Refuses a region
/// that leaves the image or has no contrast, with the reason.
Result<Template> takeTemplate(const Image& image, const ImageRegion& region, const Settings& s);

/// The coarse search: the centre of the template's best ZNCC placement within `radius` pixels of
/// `centre`, with `warp` giving its shape. Returns the warp moved to that placement and the score.
struct Coarse {
  Eigen::Matrix3d homography;
  double score;
};
std::optional<Coarse> coarseSearch(const Image& image, const Template& t,
                                   const Eigen::Matrix3d& warp, const Eigen::Vector2d& centre,
                                   double radius);

/// ZNCC of the template with the image sampled at `homography` (template -> image) on level
/// `level` of `crop`, and the covariance (image px^2) of the template centre's image position
/// by Gauss-Newton on the normalised residuals (translation and, when the template estimates
/// scale, scale and rotation), the residuals' variance inflated by the pixel correlation.
struct Fit {
  double score = -1;
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();
  bool inside = false;  // every template pixel maps inside the crop
};
Fit evaluateFit(const Crop& crop, int level, const Template& t, const Eigen::Matrix3d& homography,
                const Settings& s);

/// The template's pixels normalised to zero mean and unit norm, and its centred coordinates.
struct NormalisedTemplate {
  std::vector<Eigen::Vector2f> xy;  // template pixel coordinates
  Eigen::VectorXf values;           // normalised
  Eigen::MatrixXf steepest;         // N x dof: gradient . dW/dp at p = 0 (centred coordinates)
  Eigen::Vector2f centre;
  int dof = 2;
};
NormalisedTemplate normalise(const Template& t);

/// Bilinear samples of `image` at level-m homography H (template -> level pixels); NaN outside.
Eigen::VectorXf sampleAt(const cv::Mat& level, const Eigen::Matrix3d& h,
                         const std::vector<Eigen::Vector2f>& xy);

/// The warp of dof parameters p (translation; with 4, also scale and rotation) about `centre`.
Eigen::Matrix3d warpOf(const Eigen::VectorXd& p, const Eigen::Vector2f& centre);

/// After a match: the template again when the region grew by update_scale_ratio since it was
/// taken and the score allows it; else the same template with the new region.
Result<Template> afterMatch(const Image& image, Template t, const ImageRegion& match,
                            const Settings& s);

/// A DFI's refinement: the warp (template -> image) that maximises the ZNCC, started from
/// `start`, on level `level` of `crop`; nullopt when it failed (left the crop, diverged).
using Refine =
    std::function<std::optional<Eigen::Matrix3d>(const Crop& crop, int level, const Template& t,
                                                 const Eigen::Matrix3d& start, const Settings& s)>;

struct StepResult {
  std::optional<ImageRegion> match;
  double score = std::numeric_limits<double>::quiet_NaN();
};

/// One call of the DFN: a fresh designation restarts `track`; else the template is searched
/// around the prediction (or the last match) and refined by `refine`. An error leaves `track`
/// as it was.
Result<StepResult> step(const Image& image, const ImageRegion* designation,
                        const ImageRegion* prediction, const Settings& s,
                        std::optional<Template>& track, const Refine& refine);

/// Both DFIs' parameters (their generated structs have the same fields) as Settings.
template <typename Parameters>
Settings settingsOf(const Parameters& p) {
  return {p.min_score,         p.search_sigmas,        p.min_search_radius,
          p.max_search_radius, p.min_extent_for_scale, p.update_scale_ratio,
          p.min_update_score,  p.template_memory,      p.max_template_size,
          p.max_iterations,    p.pixel_correlation};
}

/// A DFI's process(): `step` on the fresh inputs, its result on the outputs (the generated
/// Inputs and Outputs of TemplateMatching).
template <typename Inputs, typename Outputs>
Status processStep(const Inputs& in, Outputs& out, const Settings& s,
                   std::optional<Template>& track, const Refine& refine) {
  Result<StepResult> r =
      step(*in.image, in.designation.isFresh() ? in.designation.get() : nullptr,
           in.prediction.isFresh() ? in.prediction.get() : nullptr, s, track, refine);
  if (!r) return r.status();
  if (r->match) out.match.set(*r->match);
  out.found.set(r->match.has_value());
  out.score.set(r->score);
  return Status::ok();
}

}  // namespace cdff::dfn::template_matching
