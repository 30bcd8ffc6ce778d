#include <opencv2/calib3d.hpp>

#include "triangulation_common.hpp"

namespace cdff::dfn {

class TriangulationDlt final : public TriangulationDltBase {
 public:
  void warnAbout(std::string message) { warn(std::move(message)); }

 protected:
  Status onProcess() override {
    return triangulation::run(
        *this, [](const triangulation::Views& v) -> Result<std::vector<Eigen::Vector3d>> {
          // Projections in normalised coordinates: P1 = [I | 0], P2 = second_T_first = [R^T | -R^T
          // c].
          const Eigen::Matrix3d r = v.first_R_second.transpose();
          const Eigen::Vector3d t = -r * v.first_c_second;
          cv::Matx34d p1 = cv::Matx34d::eye(), p2;
          for (int row = 0; row < 3; ++row) {
            for (int col = 0; col < 3; ++col) p2(row, col) = r(row, col);
            p2(row, 3) = t(row);
          }
          cv::Mat x1(2, static_cast<int>(v.first.size()), CV_64F), x2 = x1.clone(), h;
          for (int i = 0; i < x1.cols; ++i) {
            x1.at<double>(0, i) = v.first[i].x();
            x1.at<double>(1, i) = v.first[i].y();
            x2.at<double>(0, i) = v.second[i].x();
            x2.at<double>(1, i) = v.second[i].y();
          }
          try {
            cv::triangulatePoints(p1, p2, x1, x2, h);
            h.convertTo(h, CV_64F);
          } catch (const cv::Exception& e) {
            return numericalFailure("Triangulation: cv::triangulatePoints failed on {} pairs: {}",
                                    x1.cols, e.what());
          }
          std::vector<Eigen::Vector3d> points(v.first.size());
          for (int i = 0; i < h.cols; ++i) {
            const double w = h.at<double>(3, i);  // 0 for a point at infinity: refused as NaN
            points[i] =
                Eigen::Vector3d(h.at<double>(0, i), h.at<double>(1, i), h.at<double>(2, i)) / w;
          }
          return points;
        });
  }
};

CDFF_REGISTER_DFI(TriangulationDlt);

}  // namespace cdff::dfn
