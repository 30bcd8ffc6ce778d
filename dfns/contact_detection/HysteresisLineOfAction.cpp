// ContactDetection/HysteresisLineOfAction: the bias tracked while free, a contact state with
// hysteresis on the corrected force, and the contact's normal from the torque about the tip's
// centre pooled over the contact (ContactDetection.yaml has the method).
#include <cmath>
#include <deque>
#include <optional>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "ContactDetection.gen.hpp"
#include "cdff/types/geometry.hpp"
#include "contact_geometry.hpp"

namespace cdff::dfn {

class ContactDetectionHysteresisLineOfAction final
    : public ContactDetectionHysteresisLineOfActionBase {
 protected:
  Status onConfigure() override {
    if (params_.release_sigmas >= params_.onset_sigmas)
      return invalidParameter(
          "parameter 'release_sigmas' = {} is not below 'onset_sigmas' = {}; expected release < "
          "onset (the hysteresis that keeps the noise from toggling the contact)",
          params_.release_sigmas, params_.onset_sigmas);
    centre_ = Eigen::Vector3d(params_.tip_centre[0], params_.tip_centre[1], params_.tip_centre[2]);
    // The noise of tau - c x F per axis: the torque's and the force's through the lever c (its
    // largest, across c).
    const double sigma2 = std::pow(params_.torque_noise, 2) +
                          centre_.squaredNorm() * std::pow(params_.force_noise, 2);
    weight_ = 1.0 / sigma2;
    bias_ = Vector6d::Zero();
    bias_seconds_ = 0;
    bias_samples_ = 0;
    pending_.clear();
    last_stamp_.reset();
    in_contact_ = false;
    return Status::ok();
  }

  Status onProcess() override {
    const Wrench& w = *in.wrench;
    CDFF_RETURN_IF_ERROR(contact::checkSample(w, params_.force_range, params_.torque_range));
    if (last_stamp_ && w.stamp <= *last_stamp_)
      return invalidInput(
          "input 'wrench' at {} us does not follow the previous sample at {} us; "
          "expected increasing stamps",
          w.stamp, *last_stamp_);
    const double dt = last_stamp_ ? toSeconds(w.stamp - *last_stamp_) : 0.0;
    last_stamp_ = w.stamp;
    Vector6d raw;
    raw << w.force, w.torque;
    if (bias_seconds_ < params_.bias_time_constant) {
      // Starting: the tool is taken as free, its readings are the bias.
      ++bias_samples_;
      bias_ += (raw - bias_) / static_cast<double>(bias_samples_);
      bias_seconds_ += dt;
      out.in_contact.set(false);
      return Status::ok();
    }
    const Vector6d corrected = raw - bias_;
    const double force = corrected.head<3>().norm();
    if (!in_contact_ && force > params_.onset_sigmas * params_.force_noise) {
      in_contact_ = true;
      startContact();
    } else if (in_contact_ && force < params_.release_sigmas * params_.force_noise) {
      in_contact_ = false;
    }
    if (!in_contact_) trackBias(w.stamp, dt, raw);
    out.in_contact.set(in_contact_);
    if (in_contact_) estimate(corrected, w);
    return Status::ok();
  }

 private:
  void startContact() {
    pending_.clear();  // the rise of this contact is not the bias
    normal_matrix_.setZero();
    normal_vector_.setZero();
    force_sum_.setZero();
    warned_ = false;
  }

  /// A free sample joins the bias bias_delay after its stamp (if no contact started since).
  void trackBias(Timestamp stamp, double dt, const Vector6d& raw) {
    pending_.push_back({stamp, dt, raw});
    while (!pending_.empty() && toSeconds(stamp - pending_.front().stamp) >= params_.bias_delay) {
      const double alpha = 1.0 - std::exp(-pending_.front().dt / params_.bias_time_constant);
      bias_ += alpha * (pending_.front().wrench - bias_);
      pending_.pop_front();
    }
  }

  /// Adds the sample to the contact's normal equations and gives the contact when it is known.
  void estimate(const Vector6d& corrected, const Wrench& w) {
    const Eigen::Vector3d f = corrected.head<3>();
    // The torque about the tip's centre is r F x n: linear in n across F.
    const Eigen::Vector3d about_centre = corrected.tail<3>() - centre_.cross(f);
    const Eigen::Matrix3d a = params_.tip_radius * skew(f);
    normal_matrix_ += weight_ * a.transpose() * a;
    normal_vector_ += weight_ * a.transpose() * about_centre;
    force_sum_ += f;
    const Eigen::Vector3d along = force_sum_.normalized();
    // n's part across the mean force, in a basis (e1, e2) of that plane.
    const Eigen::Vector3d e1 = along.unitOrthogonal(), e2 = along.cross(e1);
    Eigen::Matrix<double, 3, 2> plane;
    plane << e1, e2;
    const Eigen::Matrix2d m = plane.transpose() * normal_matrix_ * plane;
    const Eigen::LDLT<Eigen::Matrix2d> solver(m);
    if (solver.info() != Eigen::Success || !(m.determinant() > 0)) return;
    const Eigen::Vector2d across = solver.solve(plane.transpose() * normal_vector_);
    const double sigma = std::sqrt(
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(m.inverse()).eigenvalues().maxCoeff());
    if (sigma > params_.max_normal_sigma) return;
    const double sine = across.norm();
    if (sine >= 1 || std::asin(sine) > std::atan(params_.friction) + 3 * sigma) {
      if (!warned_)
        warn(fmt::format(
            "contact at {} us: the force's line of action {} (the normal {:.1f} deg from the "
            "force, friction cone {:.1f} deg): not a contact of the tip; no contact point given",
            w.stamp, sine >= 1 ? "misses the tip's sphere" : "leaves the friction cone",
            sine >= 1 ? 90.0 : std::asin(sine) * 180 / M_PI,
            std::atan(params_.friction) * 180 / M_PI));
      warned_ = true;
      return;
    }
    const Eigen::Vector3d n = plane * across + std::sqrt(1 - sine * sine) * along;
    out.contact.set(contact::contactCloud(centre_ - params_.tip_radius * n, n, f.dot(n), w));
  }

  struct Pending {
    Timestamp stamp;
    double dt;
    Vector6d wrench;
  };

  Eigen::Vector3d centre_ = Eigen::Vector3d::Zero();
  double weight_ = 1;
  Vector6d bias_ = Vector6d::Zero();
  double bias_seconds_ = 0;
  std::size_t bias_samples_ = 0;
  std::deque<Pending> pending_;
  std::optional<Timestamp> last_stamp_;
  bool in_contact_ = false;
  bool warned_ = false;
  Eigen::Matrix3d normal_matrix_ = Eigen::Matrix3d::Zero();
  Eigen::Vector3d normal_vector_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d force_sum_ = Eigen::Vector3d::Zero();
};

CDFF_REGISTER_DFI(ContactDetectionHysteresisLineOfAction);

}  // namespace cdff::dfn
