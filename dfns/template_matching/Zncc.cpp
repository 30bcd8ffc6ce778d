// TemplateMatching/Zncc: the inverse compositional Gauss-Newton algorithm on the ZNCC criterion.
#include <Eigen/Dense>

#include "TemplateMatching.gen.hpp"
#include "template_track.hpp"

namespace cdff::dfn {
namespace tm = template_matching;

namespace {

/// Inverse compositional refinement: with both sides normalised to zero mean and unit norm,
/// sum (T - I(W))^2 = 2 - 2 ZNCC, so Gauss-Newton on it maximises the ZNCC; the steepest-descent
/// images and the Hessian are the template's, computed once.
std::optional<Eigen::Matrix3d> refineInverseCompositional(const tm::Crop& crop, int level,
                                                          const tm::Template& t,
                                                          const Eigen::Matrix3d& start,
                                                          const tm::Settings& s) {
  const tm::NormalisedTemplate n = tm::normalise(t);
  const Eigen::MatrixXd sd = n.steepest.cast<double>();
  const Eigen::LDLT<Eigen::MatrixXd> hessian(sd.transpose() * sd);
  if (hessian.info() != Eigen::Success) return std::nullopt;
  const cv::Mat& image = crop.levels[static_cast<std::size_t>(level)];
  const Eigen::Matrix3d to_level = crop.imageToLevel(level);
  Eigen::Matrix3d h = start;
  for (int it = 0; it < s.max_iterations; ++it) {
    Eigen::VectorXf warped = tm::sampleAt(image, to_level * h, n.xy);
    if (!warped.allFinite()) return std::nullopt;
    warped.array() -= warped.mean();
    const float norm = warped.norm();
    if (norm <= 0) return std::nullopt;
    warped /= norm;
    const Eigen::VectorXd dp = hessian.solve(sd.transpose() * (warped - n.values).cast<double>());
    if (!dp.allFinite()) return std::nullopt;
    h = h * tm::warpOf(dp, n.centre).inverse();
    const double size = 0.5 * std::max(t.pixels.cols, t.pixels.rows);
    const double step =
        dp.size() == 4 ? dp.head<2>().norm() + size * dp.tail<2>().norm() : dp.head<2>().norm();
    if (step < 1e-3) break;
  }
  return h;
}

}  // namespace

class TemplateMatchingZncc final : public TemplateMatchingZnccBase {
 protected:
  Status onConfigure() override {
    track_.reset();  // new parameters wait for a new designation
    return Status::ok();
  }

  Status onProcess() override {
    return tm::processStep(in, out, tm::settingsOf(params_), track_, refineInverseCompositional);
  }

 private:
  std::optional<tm::Template> track_;
};
CDFF_REGISTER_DFI(TemplateMatchingZncc);

}  // namespace cdff::dfn
