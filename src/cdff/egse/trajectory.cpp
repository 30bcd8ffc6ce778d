#include "cdff/egse/trajectory.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <optional>

#include "cdff/egse/rng.hpp"
#include "cdff/types/geometry.hpp"

namespace cdff::egse {

namespace {

class Hold final : public Translation {
 public:
  explicit Hold(const Eigen::Vector3d& p) { state_.position = p; }
  TranslationState at(double) const override { return state_; }

 private:
  TranslationState state_;
};

class Line final : public Translation {
 public:
  Line(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double t0, double t1, bool smooth)
      : a_(a), b_(b), t0_(t0), t1_(std::max(t1, t0 + 1e-9)), smooth_(smooth) {}
  TranslationState at(double t) const override {
    const double T = t1_ - t0_;
    const double tau = std::clamp((t - t0_) / T, 0.0, 1.0);
    const bool moving = t > t0_ && t < t1_;
    double s = tau, ds = moving ? 1.0 / T : 0.0, dds = 0.0;
    if (smooth_) {
      // Minimum-jerk: s = 10 tau^3 - 15 tau^4 + 6 tau^5.
      s = tau * tau * tau * (10 - 15 * tau + 6 * tau * tau);
      ds = moving ? 30 * tau * tau * (1 - tau) * (1 - tau) / T : 0.0;
      dds = moving ? 60 * tau * (1 - tau) * (1 - 2 * tau) / (T * T) : 0.0;
    }
    TranslationState st;
    st.position = a_ + s * (b_ - a_);
    st.velocity = ds * (b_ - a_);
    st.acceleration = dds * (b_ - a_);
    return st;
  }

 private:
  Eigen::Vector3d a_, b_;
  double t0_, t1_;
  bool smooth_;
};

class Spline final : public Translation {
 public:
  Spline(std::vector<double> t, std::vector<Eigen::Vector3d> p)
      : t_(std::move(t)), p_(std::move(p)) {
    // Natural cubic spline: second derivatives M with M_0 = M_n = 0 (tridiagonal solve).
    const std::size_t n = t_.size();
    m_.assign(n, Eigen::Vector3d::Zero());
    if (n < 3) return;
    std::vector<double> diag(n, 0.0), upper(n, 0.0);
    std::vector<Eigen::Vector3d> rhs(n, Eigen::Vector3d::Zero());
    for (std::size_t i = 1; i + 1 < n; ++i) {
      const double h0 = t_[i] - t_[i - 1], h1 = t_[i + 1] - t_[i];
      diag[i] = 2 * (h0 + h1);
      upper[i] = h1;
      rhs[i] = 6 * ((p_[i + 1] - p_[i]) / h1 - (p_[i] - p_[i - 1]) / h0);
    }
    // Thomas algorithm on rows 1..n-2 (lower diagonal h0 = t[i] - t[i-1]).
    for (std::size_t i = 2; i + 1 < n; ++i) {
      const double lower = t_[i] - t_[i - 1];
      const double w = lower / diag[i - 1];
      diag[i] -= w * upper[i - 1];
      rhs[i] -= w * rhs[i - 1];
    }
    // Back substitution (m_[n - 1] = 0 closes the last row).
    for (std::size_t i = n - 2; i >= 1; --i) {
      m_[i] = (rhs[i] - upper[i] * m_[i + 1]) / diag[i];
      if (i == 1) break;
    }
  }
  TranslationState at(double t) const override {
    TranslationState st;
    if (t <= t_.front()) {
      st.position = p_.front();
      return st;
    }
    if (t >= t_.back()) {
      st.position = p_.back();
      return st;
    }
    const std::size_t i = std::upper_bound(t_.begin(), t_.end(), t) - t_.begin() - 1;
    const double h = t_[i + 1] - t_[i];
    const double a = (t_[i + 1] - t) / h, b = (t - t_[i]) / h;
    const Eigen::Vector3d &y0 = p_[i], &y1 = p_[i + 1], &m0 = m_[i], &m1 = m_[i + 1];
    st.position = a * y0 + b * y1 + ((a * a * a - a) * m0 + (b * b * b - b) * m1) * h * h / 6;
    st.velocity = (y1 - y0) / h + (-(3 * a * a - 1) * m0 + (3 * b * b - 1) * m1) * h / 6;
    st.acceleration = a * m0 + b * m1;
    return st;
  }

 private:
  std::vector<double> t_;
  std::vector<Eigen::Vector3d> p_;
  std::vector<Eigen::Vector3d> m_;
};

class FlyAround final : public Translation {
 public:
  FlyAround(const Eigen::Vector3d& c, const Eigen::Vector3d& axis, const Eigen::Vector3d& reference,
            double r, double dr, double w, double phase)
      : c_(c), r_(r), dr_(dr), w_(w), phase_(phase) {
    k_ = axis.normalized();
    e1_ = (reference - reference.dot(k_) * k_).normalized();
    e2_ = k_.cross(e1_);
  }
  TranslationState at(double t) const override {
    const double th = phase_ + w_ * t, r = r_ + dr_ * t;
    const Eigen::Vector3d u = std::cos(th) * e1_ + std::sin(th) * e2_;
    const Eigen::Vector3d du = w_ * (-std::sin(th) * e1_ + std::cos(th) * e2_);
    TranslationState st;
    st.position = c_ + r * u;
    st.velocity = dr_ * u + r * du;
    st.acceleration = 2 * dr_ * du - r * w_ * w_ * u;
    return st;
  }

 private:
  Eigen::Vector3d c_, k_, e1_, e2_;
  double r_, dr_, w_, phase_;
};

class CwDrift final : public Translation {
 public:
  CwDrift(const Orbit& orbit, const Eigen::Vector3d& r0, const Eigen::Vector3d& v0)
      : orbit_(orbit), r0_(r0), v0_(v0) {}
  TranslationState at(double t) const override {
    TranslationState st;
    orbit_.propagate(r0_, v0_, t, st.position, st.velocity);
    st.acceleration = orbit_.naturalAcceleration(st.position, st.velocity);
    return st;
  }

 private:
  Orbit orbit_;
  Eigen::Vector3d r0_, v0_;
};

// Angular velocity and acceleration of a rotation R(t) (lvlh_R_body) relative to eci, in body
// axes, by central differences (h = 1e-4 s: truncation ~1e-9 rad/s for smooth motion).
AttitudeState differentiate(const Orbit& orbit, double t,
                            const std::function<Eigen::Quaterniond(double)>& lvlh_R_body) {
  constexpr double h = 1e-4;
  auto eci = [&](double s) {
    return (Eigen::Quaterniond(orbit.eciRotationLvlh(s)) * lvlh_R_body(s)).normalized();
  };
  auto omega = [&](double s) {
    // omega_body = log(R(s)^T R(s + h)) / h, central: log(R(s-h)^T R(s+h)) / 2h.
    const Eigen::Quaterniond a = eci(s - h), b = eci(s + h);
    return Eigen::Vector3d(logSO3(a.conjugate() * b) / (2 * h));
  };
  AttitudeState st;
  st.lvlh_R_body = lvlh_R_body(t).normalized();
  st.angular_velocity = omega(t);
  // d(omega_body)/dt, consistent with the body-frame derivative used by Euler's equations.
  st.angular_acceleration = (omega(t + h) - omega(t - h)) / (2 * h);
  return st;
}

class LvlhFixed final : public Attitude {
 public:
  LvlhFixed(const Orbit& orbit, const Eigen::Quaterniond& q) : orbit_(orbit), q_(q.normalized()) {}
  AttitudeState at(double) const override {
    AttitudeState st;
    st.lvlh_R_body = q_;
    // lvlh rotates at n about its z axis relative to eci.
    st.angular_velocity = q_.conjugate() * Eigen::Vector3d(0, 0, orbit_.meanMotion());
    return st;
  }

 private:
  Orbit orbit_;
  Eigen::Quaterniond q_;
};

class Inertial final : public Attitude {
 public:
  Inertial(const Orbit& orbit, const Eigen::Quaterniond& q0)
      : orbit_(orbit), q0_(q0.normalized()) {}
  AttitudeState at(double t) const override {
    AttitudeState st;
    // eci_R_body = eci_R_lvlh(0) * q0 = q0; lvlh_R_body(t) = eci_R_lvlh(t)^T * q0.
    st.lvlh_R_body = (Eigen::Quaterniond(orbit_.eciRotationLvlh(t)).conjugate() * q0_).normalized();
    return st;
  }

 private:
  Orbit orbit_;
  Eigen::Quaterniond q0_;
};

class Tumbling final : public Attitude {
 public:
  Tumbling(const Orbit& orbit, const Eigen::Quaterniond& q0, const Eigen::Vector3d& w0,
           const std::optional<Eigen::Vector3d>& inertia, double horizon)
      : orbit_(orbit), inertia_(inertia) {
    // eci_R_body on a fixed grid, RK4 in (q, omega).
    State s{q0.normalized(), w0};
    const std::size_t steps =
        static_cast<std::size_t>(std::ceil(std::max(horizon, 0.0) / kStep)) + 2;
    grid_.reserve(steps + 1);
    grid_.push_back(s);
    for (std::size_t i = 0; i < steps; ++i) {
      s = step(s, kStep);
      grid_.push_back(s);
    }
  }
  AttitudeState at(double t) const override {
    // From the nearest grid state at or before t (the first one for t < 0, integrating
    // backwards), in RK4 steps of at most kStep.
    const std::size_t i =
        t <= 0 ? 0 : std::min(static_cast<std::size_t>(t / kStep), grid_.size() - 1);
    State s = grid_[i];
    double remaining = t - kStep * static_cast<double>(i);
    while (std::abs(remaining) > 0) {
      const double h = std::clamp(remaining, -kStep, kStep);
      s = step(s, h);
      remaining -= h;
    }
    AttitudeState st;
    st.lvlh_R_body = (Eigen::Quaterniond(orbit_.eciRotationLvlh(t)).conjugate() * s.q).normalized();
    st.angular_velocity = s.w;
    st.angular_acceleration = omegaDot(s.w);
    return st;
  }

 private:
  static constexpr double kStep = 0.005;
  struct State {
    Eigen::Quaterniond q;  // eci_R_body
    Eigen::Vector3d w;     // body axes
  };
  Eigen::Vector3d omegaDot(const Eigen::Vector3d& w) const {
    if (!inertia_) return Eigen::Vector3d::Zero();
    const Eigen::Vector3d& I = *inertia_;
    // Torque-free Euler equations: I w' = -w x (I w).
    return (-w.cross(I.cwiseProduct(w))).cwiseQuotient(I);
  }
  static Eigen::Vector4d qdot(const Eigen::Vector4d& q, const Eigen::Vector3d& w) {
    // q' = 1/2 q (x) (0, w), q as (x, y, z, w) coefficients.
    const Eigen::Quaterniond Q(q[3], q[0], q[1], q[2]);
    const Eigen::Quaterniond d = Q * Eigen::Quaterniond(0, w.x(), w.y(), w.z());
    return 0.5 * d.coeffs();
  }
  State step(const State& s, double h) const {
    if (h == 0) return s;
    const Eigen::Vector4d q0 = s.q.coeffs();
    const Eigen::Vector3d w0 = s.w;
    const Eigen::Vector4d k1q = qdot(q0, w0);
    const Eigen::Vector3d k1w = omegaDot(w0);
    const Eigen::Vector4d k2q = qdot(q0 + 0.5 * h * k1q, w0 + 0.5 * h * k1w);
    const Eigen::Vector3d k2w = omegaDot(w0 + 0.5 * h * k1w);
    const Eigen::Vector4d k3q = qdot(q0 + 0.5 * h * k2q, w0 + 0.5 * h * k2w);
    const Eigen::Vector3d k3w = omegaDot(w0 + 0.5 * h * k2w);
    const Eigen::Vector4d k4q = qdot(q0 + h * k3q, w0 + h * k3w);
    const Eigen::Vector3d k4w = omegaDot(w0 + h * k3w);
    const Eigen::Vector4d q = q0 + h / 6 * (k1q + 2 * k2q + 2 * k3q + k4q);
    State out;
    out.q = Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized();
    out.w = w0 + h / 6 * (k1w + 2 * k2w + 2 * k3w + k4w);
    return out;
  }

  Orbit orbit_;
  std::optional<Eigen::Vector3d> inertia_;
  std::vector<State> grid_;
};

class Pointing final : public Attitude {
 public:
  Pointing(const Orbit& orbit, const Translation* self, const Translation* aim,
           const Eigen::Vector3d& up, double yaw, double pitch)
      : orbit_(orbit), self_(self), aim_(aim), up_(up.normalized()), yaw_(yaw), pitch_(pitch) {}
  AttitudeState at(double t) const override {
    return differentiate(orbit_, t, [this](double s) { return orientation(s); });
  }

 private:
  Eigen::Quaterniond orientation(double t) const {
    const Eigen::Vector3d from = self_->at(t).position;
    const Eigen::Vector3d to = aim_ ? aim_->at(t).position : Eigen::Vector3d::Zero();
    Eigen::Vector3d x = to - from;
    if (x.norm() < 1e-9) x = Eigen::Vector3d::UnitY();
    x.normalize();
    Eigen::Vector3d up = up_;
    if (std::abs(x.dot(up)) > 0.999)
      up = std::abs(x.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitY();
    const Eigen::Vector3d y = up.cross(x).normalized();
    const Eigen::Vector3d z = x.cross(y);
    Eigen::Matrix3d R;
    R << x, y, z;
    // Offsets: yaw about body z, then pitch about body y (positive pitch looks down, REP-103).
    const Eigen::Matrix3d offset = (Eigen::AngleAxisd(yaw_, Eigen::Vector3d::UnitZ()) *
                                    Eigen::AngleAxisd(pitch_, Eigen::Vector3d::UnitY()))
                                       .toRotationMatrix();
    return Eigen::Quaterniond(R * offset).normalized();
  }

  Orbit orbit_;
  const Translation* self_;
  const Translation* aim_;
  Eigen::Vector3d up_;
  double yaw_, pitch_;
};

// Minimum-jerk legs between consecutive waypoints, at rest at each.
class Legs final : public Translation {
 public:
  Legs(std::vector<double> t, const std::vector<Eigen::Vector3d>& p) : times_(std::move(t)) {
    for (std::size_t i = 0; i + 1 < p.size(); ++i)
      legs_.emplace_back(p[i], p[i + 1], times_[i], times_[i + 1], true);
  }
  TranslationState at(double t) const override {
    // The leg under way at t (before the first: the first, at rest; after the last: the last).
    const auto after = std::upper_bound(times_.begin() + 1, times_.end() - 1, t);
    return legs_[static_cast<std::size_t>(after - (times_.begin() + 1))].at(t);
  }

 private:
  std::vector<double> times_;
  std::vector<Line> legs_;
};

}  // namespace

std::unique_ptr<Translation> holdTranslation(const Eigen::Vector3d& position) {
  return std::make_unique<Hold>(position);
}

std::unique_ptr<Translation> lineTranslation(const Eigen::Vector3d& start,
                                             const Eigen::Vector3d& end, double t0, double t1,
                                             bool smooth) {
  return std::make_unique<Line>(start, end, t0, t1, smooth);
}

Status checkWaypoints(const std::vector<double>& times,
                      const std::vector<Eigen::Vector3d>& points) {
  if (times.size() != points.size() || times.size() < 2)
    return invalidParameter(
        "waypoints: {} times and {} points; expected the same number, at least 2", times.size(),
        points.size());
  for (std::size_t i = 1; i < times.size(); ++i)
    if (!(times[i] > times[i - 1]))
      return invalidParameter(
          "waypoints: time {} = {} s is not after time {} = {} s; expected "
          "strictly increasing times",
          i, times[i], i - 1, times[i - 1]);
  return Status::ok();
}

Result<std::unique_ptr<Translation>> splineTranslation(const std::vector<double>& times,
                                                       const std::vector<Eigen::Vector3d>& points) {
  CDFF_RETURN_IF_ERROR(checkWaypoints(times, points));
  return std::unique_ptr<Translation>(std::make_unique<Spline>(times, points));
}

Result<std::unique_ptr<Translation>> legsTranslation(const std::vector<double>& times,
                                                     const std::vector<Eigen::Vector3d>& points) {
  CDFF_RETURN_IF_ERROR(checkWaypoints(times, points));
  return std::unique_ptr<Translation>(std::make_unique<Legs>(times, points));
}

std::unique_ptr<Translation> flyAroundTranslation(const Eigen::Vector3d& centre,
                                                  const Eigen::Vector3d& axis,
                                                  const Eigen::Vector3d& reference, double radius,
                                                  double radial_rate, double rate, double phase) {
  return std::make_unique<FlyAround>(centre, axis, reference, radius, radial_rate, rate, phase);
}

std::unique_ptr<Translation> cwTranslation(const Orbit& orbit, const Eigen::Vector3d& r0,
                                           const Eigen::Vector3d& v0) {
  return std::make_unique<CwDrift>(orbit, r0, v0);
}

std::unique_ptr<Attitude> lvlhFixedAttitude(const Orbit& orbit, const Eigen::Quaterniond& q) {
  return std::make_unique<LvlhFixed>(orbit, q);
}

std::unique_ptr<Attitude> inertialAttitude(const Orbit& orbit, const Eigen::Quaterniond& q0) {
  return std::make_unique<Inertial>(orbit, q0);
}

std::unique_ptr<Attitude> tumblingAttitude(const Orbit& orbit, const Eigen::Quaterniond& q0,
                                           const Eigen::Vector3d& omega0,
                                           const std::optional<Eigen::Vector3d>& inertia,
                                           double horizon) {
  return std::make_unique<Tumbling>(orbit, q0, omega0, inertia, horizon);
}

std::unique_ptr<Attitude> pointingAttitude(const Orbit& orbit, const Translation* self,
                                           const Translation* aim_at, const Eigen::Vector3d& up,
                                           double yaw_offset, double pitch_offset) {
  return std::make_unique<Pointing>(orbit, self, aim_at, up, yaw_offset, pitch_offset);
}

namespace {

class Jittered final : public Attitude {
 public:
  Jittered(const Orbit& orbit, std::unique_ptr<Attitude> base, double rms, std::uint64_t seed)
      : orbit_(orbit), base_(std::move(base)), amplitude_(rms * std::sqrt(2.0 / 3.0)) {
    Rng rng(seed ^ 0x6a177e5ULL);
    for (auto& axis : waves_)
      for (Wave& w : axis) {
        w.frequency = std::exp(rng.uniform(std::log(0.03), std::log(0.5)));  // Hz
        w.phase = rng.uniform(0, 2 * M_PI);
      }
  }
  AttitudeState at(double t) const override {
    return differentiate(orbit_, t, [this](double s) {
      return Eigen::Quaterniond(base_->at(s).lvlh_R_body * expSO3(angles(s)));
    });
  }

 private:
  struct Wave {
    double frequency = 0, phase = 0;
  };
  Eigen::Vector3d angles(double t) const {
    Eigen::Vector3d a = Eigen::Vector3d::Zero();
    for (int i = 0; i < 3; ++i)
      for (const Wave& w : waves_[static_cast<std::size_t>(i)])
        a[i] += amplitude_ * std::sin(2 * M_PI * w.frequency * t + w.phase);
    return a;
  }
  Orbit orbit_;
  std::unique_ptr<Attitude> base_;
  double amplitude_;
  std::array<std::array<Wave, 3>, 3> waves_{};
};

}  // namespace

std::unique_ptr<Attitude> jitteredAttitude(const Orbit& orbit, std::unique_ptr<Attitude> base,
                                           double rms, std::uint64_t seed) {
  return std::make_unique<Jittered>(orbit, std::move(base), rms, seed);
}

}  // namespace cdff::egse
