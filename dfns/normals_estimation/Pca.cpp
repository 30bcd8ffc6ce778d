#include <vector>

#include <Eigen/Eigenvalues>

#include "NormalsEstimation.gen.hpp"
#include "cdff/types/kd_tree.hpp"
#include "normals_common.hpp"

namespace cdff::dfn {

class NormalsEstimationPca final : public NormalsEstimationPcaBase {
 protected:
  Status onProcess() override {
    const PointCloud& cloud = *in.cloud;
    CDFF_RETURN_IF_ERROR(cloud.validate("input 'cloud'"));
    tree_.build(cloud.points.span());
    const Eigen::Vector3f viewpoint(params_.viewpoint[0], params_.viewpoint[1],
                                    params_.viewpoint[2]);
    std::vector<std::uint32_t> keep;
    std::vector<Point4f> normals;
    keep.reserve(cloud.size());
    normals.reserve(cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const Eigen::Vector3f p = cloud.points[i].vec();
      if (params_.radius > 0)
        tree_.withinRadius(p, static_cast<float>(params_.radius), neighbours_);
      else
        tree_.kNearest(p, params_.neighbours, neighbours_);
      if (neighbours_.size() < 3) continue;
      // Covariance about the neighbourhood's mean, accumulated relative to the query point so
      // that far-from-origin clouds keep their precision in single precision.
      Eigen::Vector3f sum = Eigen::Vector3f::Zero();
      Eigen::Matrix3f sum2 = Eigen::Matrix3f::Zero();
      for (const KdTree3f::Neighbour& nb : neighbours_) {
        const Eigen::Vector3f d = cloud.points[nb.index].vec() - p;
        sum += d;
        sum2.noalias() += d * d.transpose();
      }
      const float count = static_cast<float>(neighbours_.size());
      const Eigen::Vector3f mean = sum / count;
      const Eigen::Matrix3f covariance = sum2 / count - mean * mean.transpose();
      solver_.computeDirect(covariance);
      Eigen::Vector3f n = solver_.eigenvectors().col(0);  // smallest eigenvalue first
      if (!normals::orient(n, p, viewpoint)) continue;
      keep.push_back(static_cast<std::uint32_t>(i));
      normals.emplace_back(n.x(), n.y(), n.z());
    }
    normals::publish(out, cloud, keep, std::move(normals),
                     [this](std::string m) { warn(std::move(m)); });
    return Status::ok();
  }

 private:
  KdTree3f tree_;
  std::vector<KdTree3f::Neighbour> neighbours_;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> solver_;
};

CDFF_REGISTER_DFI(NormalsEstimationPca);

}  // namespace cdff::dfn
