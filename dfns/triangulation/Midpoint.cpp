#include "triangulation_common.hpp"

namespace cdff::dfn {

class TriangulationMidpoint final : public TriangulationMidpointBase {
 public:
  void warnAbout(std::string message) { warn(std::move(message)); }

 protected:
  Status onProcess() override {
    return triangulation::run(*this, [](const triangulation::Views& v) {
      // c1 = 0, c2 = the second camera's centre; rays d = (x, y, 1) so that s is the depth.
      std::vector<Eigen::Vector3d> points(v.first.size());
      const Eigen::Vector3d& c2 = v.first_c_second;
      for (std::size_t i = 0; i < points.size(); ++i) {
        const Eigen::Vector3d d1 = v.first[i].homogeneous();
        const Eigen::Vector3d d2 = v.first_R_second * v.second[i].homogeneous();
        // Minimise |s1 d1 - (c2 + s2 d2)|: the normal equations of [d1, -d2] (s1, s2) = c2.
        const double a = d1.dot(d1), b = d1.dot(d2), c = d2.dot(d2);
        const double det = a * c - b * b;  // 0 for parallel rays
        const double s1 = (c * d1.dot(c2) - b * d2.dot(c2)) / det;
        const double s2 = (b * d1.dot(c2) - a * d2.dot(c2)) / det;
        points[i] = std::abs(det) > 1e-15 * a * c ? Eigen::Vector3d(0.5 * (s1 * d1 + c2 + s2 * d2))
                                                  : Eigen::Vector3d::Constant(NAN);
      }
      return Result<std::vector<Eigen::Vector3d>>(std::move(points));
    });
  }
};

CDFF_REGISTER_DFI(TriangulationMidpoint);

}  // namespace cdff::dfn
