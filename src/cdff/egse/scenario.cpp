#include "cdff/egse/scenario.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <fmt/ranges.h>
#include <yaml-cpp/yaml.h>

namespace cdff::egse {

const char* toString(SensorType type) {
  switch (type) {
    case SensorType::kCamera:
      return "camera";
    case SensorType::kLidar:
      return "lidar";
    case SensorType::kTof:
      return "tof";
    case SensorType::kImu:
      return "imu";
    case SensorType::kRadar:
      return "radar";
    case SensorType::kAhrs:
      return "ahrs";
  }
  return "?";
}

const char* toString(FaultType type) {
  switch (type) {
    case FaultType::kCameraFailure:
      return "camera_failure";
    case FaultType::kGlare:
      return "glare";
    case FaultType::kLidarDropout:
      return "lidar_dropout";
    case FaultType::kLidarSpurious:
      return "lidar_spurious";
    case FaultType::kImuBiasJump:
      return "imu_bias_jump";
    case FaultType::kDroppedFrames:
      return "dropped_frames";
    case FaultType::kLateFrames:
      return "late_frames";
    case FaultType::kOcclusion:
      return "occlusion";
  }
  return "?";
}

namespace {

constexpr double kDeg = M_PI / 180.0;

// The optical frame (z forward, x right, y down) of a sensor whose body frame looks along x.
Eigen::Matrix3d mountRotationOptical() {
  Eigen::Matrix3d R;
  R.col(0) = -Eigen::Vector3d::UnitY();  // optical x (right) = body -y
  R.col(1) = -Eigen::Vector3d::UnitZ();  // optical y (down) = body -z
  R.col(2) = Eigen::Vector3d::UnitX();   // optical z (forward) = body x
  return R;
}

Eigen::Quaterniond fromRpy(const Eigen::Vector3d& rpy) {
  // REP-103 fixed-axis roll, pitch, yaw: R = Rz(yaw) Ry(pitch) Rx(roll).
  return Eigen::Quaterniond(Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
                            Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
                            Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()));
}

std::size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

// What every reader knows: the source's name and which keys came from overrides.
struct Context {
  std::string source;
  std::map<std::string, std::string> overridden;  // key -> "key=value" as given
};

// A YAML node with its dotted path, for messages that say where and what.
class Field {
 public:
  Field(YAML::Node node, std::string path, const Context* context)
      : node_(std::move(node)), path_(std::move(path)), context_(context) {}

  const std::string& path() const { return path_; }
  const YAML::Node& node() const { return node_; }
  bool defined() const { return node_.IsDefined() && !node_.IsNull(); }

  std::string where() const {
    for (const auto& [key, text] : context_->overridden)
      if (path_ == key || path_.rfind(key + ".", 0) == 0) return fmt::format("--set {}", text);
    const YAML::Mark mark = node_.Mark();
    if (mark.line < 0) return context_->source;
    return fmt::format("{}:{}:{}", context_->source, mark.line + 1, mark.column + 1);
  }
  std::string value() const {
    if (!node_.IsDefined() || node_.IsNull()) return "null";
    if (node_.IsScalar()) return node_.Scalar();
    YAML::Emitter out;
    out << YAML::Flow << node_;
    return out.c_str();
  }
  Status fail(const std::string& expected) const {
    return invalidParameter("{}: {} = {}: expected {}", where(), path_, value(), expected);
  }

  Field operator[](const std::string& key) const {
    YAML::Node child = node_.IsMap() ? node_[key] : YAML::Node(YAML::NodeType::Undefined);
    return Field(child, path_.empty() ? key : path_ + "." + key, context_);
  }
  bool has(const std::string& key) const {
    return node_.IsMap() && node_[key].IsDefined() && !node_[key].IsNull();
  }

  Status isMap() const {
    if (!node_.IsMap()) return fail("a mapping (key: value pairs)");
    return Status::ok();
  }
  /// Every key must be one of `allowed`.
  Status allowOnly(const std::vector<std::string>& allowed) const {
    CDFF_RETURN_IF_ERROR(isMap());
    for (auto it = node_.begin(); it != node_.end(); ++it) {
      const std::string key = it->first.as<std::string>();
      if (std::find(allowed.begin(), allowed.end(), key) != allowed.end()) continue;
      std::string best;
      std::size_t best_distance = 3;
      for (const std::string& candidate : allowed) {
        const std::size_t d = editDistance(key, candidate);
        if (d < best_distance) {
          best_distance = d;
          best = candidate;
        }
      }
      const Field bad(it->first, path_.empty() ? key : path_ + "." + key, context_);
      return invalidParameter(
          "{}: unknown key '{}'{}; expected one of {{{}}}", bad.where(), bad.path(),
          best.empty() ? "" : fmt::format(" (did you mean '{}'?)", best), fmt::join(allowed, ", "));
    }
    return Status::ok();
  }

  Status number(double& out, double low, double high, const std::string& unit,
                bool low_open = false) const {
    double v = 0;
    try {
      v = node_.as<double>();
    } catch (const YAML::Exception&) {
      return fail(fmt::format("a number{}", unit.empty() ? "" : " in " + unit));
    }
    const bool below = low_open ? !(v > low) : !(v >= low);
    if (!std::isfinite(v) || below || !(v <= high))
      return fail(fmt::format("a number in {}{}, {}]{}", low_open ? "(" : "[", low, high,
                              unit.empty() ? "" : " " + unit));
    out = v;
    return Status::ok();
  }
  Status integer(int& out, int low, int high) const {
    long long v = 0;
    try {
      v = node_.as<long long>();
    } catch (const YAML::Exception&) {
      return fail(fmt::format("an integer in [{}, {}]", low, high));
    }
    if (v < low || v > high) return fail(fmt::format("an integer in [{}, {}]", low, high));
    out = static_cast<int>(v);
    return Status::ok();
  }
  Status unsignedInteger(std::uint64_t& out) const {
    try {
      out = node_.as<std::uint64_t>();
    } catch (const YAML::Exception&) {
      return fail("a non-negative integer");
    }
    return Status::ok();
  }
  Status boolean(bool& out) const {
    try {
      out = node_.as<bool>();
    } catch (const YAML::Exception&) {
      return fail("true or false");
    }
    return Status::ok();
  }
  Status string(std::string& out) const {
    if (!node_.IsScalar()) return fail("a string");
    out = node_.Scalar();
    return Status::ok();
  }
  Status choice(std::string& out, const std::vector<std::string>& choices) const {
    std::string v;
    if (!node_.IsScalar() ||
        std::find(choices.begin(), choices.end(), (v = node_.Scalar())) == choices.end())
      return fail(fmt::format("one of {{{}}}", fmt::join(choices, ", ")));
    out = v;
    return Status::ok();
  }
  Status numbers(std::vector<double>& out, std::size_t min_size, std::size_t max_size) const {
    const std::string expected =
        min_size == max_size ? fmt::format("a list of {} numbers", min_size)
                             : fmt::format("a list of {} to {} numbers", min_size, max_size);
    if (!node_.IsSequence() || node_.size() < min_size || node_.size() > max_size)
      return fail(expected);
    out.clear();
    for (std::size_t i = 0; i < node_.size(); ++i) {
      double v;
      try {
        v = node_[i].as<double>();
      } catch (const YAML::Exception&) {
        return fail(expected);
      }
      if (!std::isfinite(v)) return fail(expected + " (finite)");
      out.push_back(v);
    }
    return Status::ok();
  }
  Status vec3(Eigen::Vector3d& out, double scale = 1.0) const {
    std::vector<double> v;
    CDFF_RETURN_IF_ERROR(numbers(v, 3, 3));
    out = Eigen::Vector3d(v[0], v[1], v[2]) * scale;
    return Status::ok();
  }
  Status direction(Eigen::Vector3d& out) const {
    CDFF_RETURN_IF_ERROR(vec3(out));
    if (out.norm() < 1e-12) return fail("a non-zero direction vector");
    out.normalize();
    return Status::ok();
  }

 private:
  YAML::Node node_;
  std::string path_;
  const Context* context_;
};

// Optional readers: leave `out` alone when the key is absent.
Status optNumber(const Field& f, const std::string& key, double& out, double low, double high,
                 const std::string& unit = "", bool low_open = false, double scale = 1.0) {
  if (!f.has(key)) return Status::ok();
  double v = 0;
  CDFF_RETURN_IF_ERROR(f[key].number(v, low, high, unit, low_open));
  out = v * scale;
  return Status::ok();
}
Status optInt(const Field& f, const std::string& key, int& out, int low, int high) {
  return f.has(key) ? f[key].integer(out, low, high) : Status::ok();
}
Status optBool(const Field& f, const std::string& key, bool& out) {
  return f.has(key) ? f[key].boolean(out) : Status::ok();
}
Status optVec3(const Field& f, const std::string& key, Eigen::Vector3d& out, double scale = 1.0) {
  return f.has(key) ? f[key].vec3(out, scale) : Status::ok();
}
Status optRpy(const Field& f, const std::string& key, Eigen::Quaterniond& out) {
  if (!f.has(key)) return Status::ok();
  Eigen::Vector3d rpy;
  CDFF_RETURN_IF_ERROR(f[key].vec3(rpy, kDeg));
  out = fromRpy(rpy);
  return Status::ok();
}

// ------------------------------------------------------------------------------- sensors

CameraModel prosilicaGc1600h() {
  CameraModel m;
  m.width = 1624;
  m.height = 1234;
  m.fx = m.fy = 6e-3 / 4.4e-6;  // 6 mm lens, 4.4 um pixels (Sony ICX274)
  m.cx = 811.5;
  m.cy = 616.5;
  m.distortion_model = DistortionModel::kRadialTangential;
  m.distortion = {-0.12, 0.05, 0.0005, -0.0003, 0.0};
  return m;
}

Eigen::Isometry3d mountAt(const Eigen::Vector3d& p,
                          const Eigen::Quaterniond& q = Eigen::Quaterniond::Identity()) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.toRotationMatrix();
  T.translation() = p;
  return T;
}

const std::vector<std::string> kCommonSensorKeys = {"type",  "enabled", "rate",
                                                    "phase", "latency", "mount"};

std::vector<std::string> with(std::vector<std::string> a, const std::vector<std::string>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

Status readCameraModel(const Field& f, CameraModel& m, bool allow_distortion) {
  const bool size_given = f.has("width") || f.has("height");
  CDFF_RETURN_IF_ERROR(optInt(f, "width", m.width, 8, 16384));
  CDFF_RETURN_IF_ERROR(optInt(f, "height", m.height, 8, 16384));
  double focal_length = 0, pixel_pitch = 0;
  CDFF_RETURN_IF_ERROR(optNumber(f, "focal_length", focal_length, 0, 1, "m", true));
  CDFF_RETURN_IF_ERROR(optNumber(f, "pixel_pitch", pixel_pitch, 0, 1e-3, "m", true));
  if (focal_length > 0 && pixel_pitch > 0) m.fx = m.fy = focal_length / pixel_pitch;
  if (size_given) {
    m.cx = 0.5 * (m.width - 1);
    m.cy = 0.5 * (m.height - 1);
  }
  CDFF_RETURN_IF_ERROR(optNumber(f, "fx", m.fx, 0, 1e6, "px", true));
  CDFF_RETURN_IF_ERROR(optNumber(f, "fy", m.fy, 0, 1e6, "px", true));
  CDFF_RETURN_IF_ERROR(optNumber(f, "cx", m.cx, -1e5, 1e5, "px"));
  CDFF_RETURN_IF_ERROR(optNumber(f, "cy", m.cy, -1e5, 1e5, "px"));
  if (!allow_distortion) return Status::ok();
  if (f.has("distortion_model")) {
    std::string model;
    CDFF_RETURN_IF_ERROR(
        f["distortion_model"].choice(model, {"none", "radial_tangential", "equidistant"}));
    m.distortion_model = model == "none"          ? DistortionModel::kNone
                         : model == "equidistant" ? DistortionModel::kEquidistant
                                                  : DistortionModel::kRadialTangential;
    if (m.distortion_model == DistortionModel::kNone) m.distortion.clear();
  }
  if (f.has("distortion")) {
    const std::size_t n_min = m.distortion_model == DistortionModel::kEquidistant ? 4 : 4;
    const std::size_t n_max = m.distortion_model == DistortionModel::kEquidistant ? 4 : 8;
    CDFF_RETURN_IF_ERROR(f["distortion"].numbers(m.distortion, n_min, n_max));
    if (m.distortion_model == DistortionModel::kNone)
      m.distortion_model = DistortionModel::kRadialTangential;
  }
  return Status::ok();
}

Status readSensor(const Field& f, SensorConfig& s, int shadow_map_size) {
  CDFF_RETURN_IF_ERROR(optBool(f, "enabled", s.enabled));
  CDFF_RETURN_IF_ERROR(optNumber(f, "rate", s.rate, 0, 10000, "Hz", true));
  CDFF_RETURN_IF_ERROR(optNumber(f, "phase", s.phase, 0, 1e6, "s"));
  CDFF_RETURN_IF_ERROR(optNumber(f, "latency", s.latency, 0, 10, "s"));
  if (f.has("mount")) {
    const Field m = f["mount"];
    CDFF_RETURN_IF_ERROR(m.allowOnly({"position", "rpy_deg"}));
    Eigen::Vector3d p = s.servicer_T_mount.translation();
    Eigen::Quaterniond q(s.servicer_T_mount.linear());
    CDFF_RETURN_IF_ERROR(optVec3(m, "position", p));
    CDFF_RETURN_IF_ERROR(optRpy(m, "rpy_deg", q));
    s.servicer_T_mount = mountAt(p, q);
  }
  switch (s.type) {
    case SensorType::kCamera: {
      CDFF_RETURN_IF_ERROR(f.allowOnly(with(kCommonSensorKeys, {"width",
                                                                "height",
                                                                "fx",
                                                                "fy",
                                                                "cx",
                                                                "cy",
                                                                "focal_length",
                                                                "pixel_pitch",
                                                                "distortion_model",
                                                                "distortion",
                                                                "format",
                                                                "exposure_time",
                                                                "gain_db",
                                                                "full_well",
                                                                "read_noise",
                                                                "sensitivity",
                                                                "noise",
                                                                "psf_sigma",
                                                                "f_number",
                                                                "focus_distance",
                                                                "supersampling",
                                                                "motion_blur_samples",
                                                                "stars",
                                                                "star_gain",
                                                                "glare_strength",
                                                                "glare_width_deg",
                                                                "glare_decay_deg",
                                                                "shadow_map_size"})));
      CameraSpec& c = s.camera;
      c.shadow_map_size = shadow_map_size;
      CDFF_RETURN_IF_ERROR(readCameraModel(f, c.model, true));
      CDFF_RETURN_IF_ERROR(optNumber(f, "focal_length", c.focal_length, 0, 1, "m", true));
      CDFF_RETURN_IF_ERROR(optNumber(f, "pixel_pitch", c.pixel_pitch, 0, 1e-3, "m", true));
      if (f.has("format")) {
        std::string format;
        CDFF_RETURN_IF_ERROR(f["format"].choice(format, {"mono8", "bgr8"}));
        c.format = format == "bgr8" ? PixelFormat::kBgr8 : PixelFormat::kGray8;
      }
      CDFF_RETURN_IF_ERROR(optNumber(f, "exposure_time", c.exposure_time, 0, 10, "s", true));
      CDFF_RETURN_IF_ERROR(optNumber(f, "gain_db", c.gain_db, -20, 40, "dB"));
      CDFF_RETURN_IF_ERROR(optNumber(f, "full_well", c.full_well, 0, 1e7, "electrons", true));
      CDFF_RETURN_IF_ERROR(optNumber(f, "read_noise", c.read_noise, 0, 1e4, "electrons"));
      CDFF_RETURN_IF_ERROR(
          optNumber(f, "sensitivity", c.sensitivity, 0, 1e15, "electrons/s", true));
      CDFF_RETURN_IF_ERROR(optBool(f, "noise", c.noise));
      CDFF_RETURN_IF_ERROR(optNumber(f, "psf_sigma", c.psf_sigma, 0, 20, "px"));
      CDFF_RETURN_IF_ERROR(optNumber(f, "f_number", c.f_number, 0, 100));
      CDFF_RETURN_IF_ERROR(optNumber(f, "focus_distance", c.focus_distance, 0, 1e6, "m"));
      CDFF_RETURN_IF_ERROR(optInt(f, "supersampling", c.supersampling, 1, 8));
      CDFF_RETURN_IF_ERROR(optInt(f, "motion_blur_samples", c.motion_blur_samples, 1, 32));
      CDFF_RETURN_IF_ERROR(optBool(f, "stars", c.stars));
      CDFF_RETURN_IF_ERROR(optNumber(f, "star_gain", c.star_gain, 0, 1e9));
      CDFF_RETURN_IF_ERROR(optNumber(f, "glare_strength", c.glare_strength, 0, 1e6));
      CDFF_RETURN_IF_ERROR(
          optNumber(f, "glare_width_deg", c.glare_width, 0, 90, "deg", true, kDeg));
      CDFF_RETURN_IF_ERROR(
          optNumber(f, "glare_decay_deg", c.glare_decay, 0, 90, "deg", true, kDeg));
      CDFF_RETURN_IF_ERROR(optInt(f, "shadow_map_size", c.shadow_map_size, 64, 8192));
      return c.validate(s.name).withContext(f.where() + ": " + f.path());
    }
    case SensorType::kLidar: {
      CDFF_RETURN_IF_ERROR(f.allowOnly(
          with(kCommonSensorKeys,
               {"elevations_deg", "firing_cycle", "laser_interval", "min_range", "max_range",
                "range_noise", "dropout_probability", "spurious_rate", "motion_during_scan"})));
      LidarSpec& l = s.lidar;
      if (f.has("elevations_deg")) {
        CDFF_RETURN_IF_ERROR(f["elevations_deg"].numbers(l.elevations, 1, 256));
        for (double& e : l.elevations) {
          if (std::abs(e) >= 90)
            return f["elevations_deg"].fail("elevations within (-90, 90) degrees");
          e *= kDeg;
        }
      }
      l.rotation_rate = s.rate;
      CDFF_RETURN_IF_ERROR(optNumber(f, "firing_cycle", l.firing_cycle, 0, 1, "s", true));
      CDFF_RETURN_IF_ERROR(optNumber(f, "laser_interval", l.laser_interval, 0, 1, "s"));
      CDFF_RETURN_IF_ERROR(optNumber(f, "min_range", l.min_range, 0, 1e5, "m"));
      CDFF_RETURN_IF_ERROR(optNumber(f, "max_range", l.max_range, 0, 1e5, "m", true));
      CDFF_RETURN_IF_ERROR(optNumber(f, "range_noise", l.range_noise, 0, 100, "m"));
      CDFF_RETURN_IF_ERROR(optNumber(f, "dropout_probability", l.dropout_probability, 0, 1));
      CDFF_RETURN_IF_ERROR(
          optNumber(f, "spurious_rate", l.spurious_rate, 0, 1e6, "returns per scan"));
      CDFF_RETURN_IF_ERROR(optBool(f, "motion_during_scan", l.motion_during_scan));
      return l.validate(s.name).withContext(f.where() + ": " + f.path());
    }
    case SensorType::kTof: {
      CDFF_RETURN_IF_ERROR(f.allowOnly(
          with(kCommonSensorKeys, {"width", "height", "fx", "fy", "cx", "cy", "focal_length",
                                   "pixel_pitch", "min_range", "max_range", "noise_constant",
                                   "noise_quadratic", "min_amplitude", "dropout_probability"})));
      TofSpec& t = s.tof;
      CDFF_RETURN_IF_ERROR(readCameraModel(f, t.model, false));
      CDFF_RETURN_IF_ERROR(optNumber(f, "min_range", t.min_range, 0, 1e4, "m"));
      CDFF_RETURN_IF_ERROR(optNumber(f, "max_range", t.max_range, 0, 1e4, "m", true));
      CDFF_RETURN_IF_ERROR(optNumber(f, "noise_constant", t.noise_constant, 0, 10, "m"));
      CDFF_RETURN_IF_ERROR(optNumber(f, "noise_quadratic", t.noise_quadratic, 0, 10, "m/m^2"));
      CDFF_RETURN_IF_ERROR(optNumber(f, "min_amplitude", t.min_amplitude, 0, 1e6));
      CDFF_RETURN_IF_ERROR(optNumber(f, "dropout_probability", t.dropout_probability, 0, 1));
      return t.validate(s.name).withContext(f.where() + ": " + f.path());
    }
    case SensorType::kImu: {
      CDFF_RETURN_IF_ERROR(f.allowOnly(with(
          kCommonSensorKeys, {"gyro_noise_density", "accel_noise_density", "gyro_bias_sigma",
                              "accel_bias_sigma", "gyro_bias_random_walk", "accel_bias_random_walk",
                              "gyro_bias", "accel_bias", "gyro_range", "accel_range", "noise"})));
      ImuSpec& i = s.imu;
      i.rate = s.rate;
      CDFF_RETURN_IF_ERROR(
          optNumber(f, "gyro_noise_density", i.gyro_noise_density, 0, 1, "rad/s/sqrt(Hz)"));
      CDFF_RETURN_IF_ERROR(
          optNumber(f, "accel_noise_density", i.accel_noise_density, 0, 10, "m/s^2/sqrt(Hz)"));
      CDFF_RETURN_IF_ERROR(optNumber(f, "gyro_bias_sigma", i.gyro_bias_sigma, 0, 10, "rad/s"));
      CDFF_RETURN_IF_ERROR(optNumber(f, "accel_bias_sigma", i.accel_bias_sigma, 0, 100, "m/s^2"));
      CDFF_RETURN_IF_ERROR(
          optNumber(f, "gyro_bias_random_walk", i.gyro_bias_random_walk, 0, 1, "rad/s/sqrt(s)"));
      CDFF_RETURN_IF_ERROR(
          optNumber(f, "accel_bias_random_walk", i.accel_bias_random_walk, 0, 10, "m/s^2/sqrt(s)"));
      if (f.has("gyro_bias")) {
        Eigen::Vector3d b;
        CDFF_RETURN_IF_ERROR(f["gyro_bias"].vec3(b));
        i.gyro_bias = b;
      }
      if (f.has("accel_bias")) {
        Eigen::Vector3d b;
        CDFF_RETURN_IF_ERROR(f["accel_bias"].vec3(b));
        i.accel_bias = b;
      }
      CDFF_RETURN_IF_ERROR(optNumber(f, "gyro_range", i.gyro_range, 0, 1000, "rad/s", true));
      CDFF_RETURN_IF_ERROR(optNumber(f, "accel_range", i.accel_range, 0, 10000, "m/s^2", true));
      CDFF_RETURN_IF_ERROR(optBool(f, "noise", i.noise));
      return i.validate(s.name).withContext(f.where() + ": " + f.path());
    }
    case SensorType::kRadar: {
      CDFF_RETURN_IF_ERROR(f.allowOnly(
          with(kCommonSensorKeys, {"min_range", "max_range", "beam_half_angle_deg", "range_noise",
                                   "range_rate_noise", "angle_noise_deg"})));
      RadarSpec& r = s.radar;
      CDFF_RETURN_IF_ERROR(optNumber(f, "min_range", r.min_range, 0, 1e8, "m"));
      CDFF_RETURN_IF_ERROR(optNumber(f, "max_range", r.max_range, 0, 1e8, "m", true));
      CDFF_RETURN_IF_ERROR(
          optNumber(f, "beam_half_angle_deg", r.beam_half_angle, 0, 180, "deg", true, kDeg));
      CDFF_RETURN_IF_ERROR(optNumber(f, "range_noise", r.range_noise, 0, 1e4, "m"));
      CDFF_RETURN_IF_ERROR(optNumber(f, "range_rate_noise", r.range_rate_noise, 0, 1e3, "m/s"));
      CDFF_RETURN_IF_ERROR(
          optNumber(f, "angle_noise_deg", r.angle_noise, 0, 90, "deg", false, kDeg));
      return r.validate(s.name).withContext(f.where() + ": " + f.path());
    }
    case SensorType::kAhrs: {
      CDFF_RETURN_IF_ERROR(f.allowOnly(with(kCommonSensorKeys, {"attitude_sigma", "noise"})));
      AhrsSpec& a = s.ahrs;
      CDFF_RETURN_IF_ERROR(optNumber(f, "attitude_sigma", a.attitude_sigma, 0, M_PI, "rad"));
      CDFF_RETURN_IF_ERROR(optBool(f, "noise", a.noise));
      return a.validate(s.name).withContext(f.where() + ": " + f.path());
    }
  }
  return Status::ok();
}

// ---------------------------------------------------------------------------- overrides

Status applyOverride(YAML::Node& root, const std::string& text, Context& context) {
  const std::size_t eq = text.find('=');
  if (eq == std::string::npos || eq == 0)
    return invalidParameter(
        "--set {}: expected KEY=VALUE with a dotted key, e.g. sensors.lidar.range_noise=0.05",
        text);
  const std::string key = text.substr(0, eq), value_text = text.substr(eq + 1);
  std::vector<std::string> parts;
  std::stringstream ss(key);
  for (std::string part; std::getline(ss, part, '.');) {
    if (part.empty())
      return invalidParameter("--set {}: the key '{}' has an empty part", text, key);
    parts.push_back(part);
  }
  YAML::Node value;
  try {
    value = YAML::Load(value_text);
  } catch (const YAML::Exception& e) {
    return invalidParameter("--set {}: the value '{}' is not valid YAML: {}", text, value_text,
                            e.msg);
  }
  YAML::Node current = root;
  std::string walked;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const std::string& part = parts[i];
    const bool last = i + 1 == parts.size();
    walked += (walked.empty() ? "" : ".") + part;
    if (current.IsSequence()) {
      char* end = nullptr;
      const long index = std::strtol(part.c_str(), &end, 10);
      if (*end != '\0' || index < 0 || static_cast<std::size_t>(index) >= current.size())
        return invalidParameter("--set {}: '{}' indexes a list of {} items; expected 0 to {}", text,
                                walked, current.size(), static_cast<long>(current.size()) - 1);
      if (last) {
        current[static_cast<std::size_t>(index)] = value;
      } else {
        YAML::Node next = current[static_cast<std::size_t>(index)];
        current.reset(next);
      }
      continue;
    }
    if (!current.IsMap() && !current.IsNull() && current.IsDefined())
      return invalidParameter(
          "--set {}: '{}' is a value, not a mapping with keys", text,
          walked.substr(0, walked.size() - part.size() - (walked.size() > part.size() ? 1 : 0)));
    if (last) {
      current[part] = value;
    } else {
      if (!current[part].IsDefined() || current[part].IsNull())
        current[part] = YAML::Node(YAML::NodeType::Map);
      YAML::Node next = current[part];
      current.reset(next);
    }
  }
  context.overridden[key] = text;
  return Status::ok();
}

}  // namespace

// ------------------------------------------------------------------------------ sensors

std::string SensorConfig::frame() const {
  return type == SensorType::kCamera || type == SensorType::kTof ? name + "_optical" : name;
}

Eigen::Isometry3d SensorConfig::servicerTframe() const {
  if (type != SensorType::kCamera && type != SensorType::kTof) return servicer_T_mount;
  Eigen::Isometry3d optical = Eigen::Isometry3d::Identity();
  optical.linear() = mountRotationOptical();
  return servicer_T_mount * optical;
}

std::string SensorConfig::channelPrefix() const {
  if (type == SensorType::kCamera) {
    const std::string stem = name.rfind("camera_", 0) == 0 ? name.substr(7) : name;
    return "/chaser/camera/" + stem;
  }
  return "/chaser/" + name;
}

const SensorConfig* Scenario::sensor(const std::string& n) const {
  for (const SensorConfig& s : sensors)
    if (s.name == n) return &s;
  return nullptr;
}

std::vector<SensorConfig> defaultSensors() {
  std::vector<SensorConfig> sensors;
  for (int side : {1, -1}) {
    SensorConfig c;
    c.name = side > 0 ? "camera_left" : "camera_right";
    c.type = SensorType::kCamera;
    c.rate = 10.0;
    c.servicer_T_mount = mountAt({0.45, 0.1 * side, 0.15});
    c.camera.model = prosilicaGc1600h();
    sensors.push_back(c);
  }
  SensorConfig lidar;
  lidar.name = "lidar";
  lidar.type = SensorType::kLidar;
  lidar.rate = 10.0;
  lidar.servicer_T_mount = mountAt({0.45, 0.0, -0.2});
  lidar.lidar = LidarSpec::vlp16();
  sensors.push_back(lidar);
  SensorConfig tof;
  tof.name = "tof";
  tof.type = SensorType::kTof;
  tof.rate = 10.0;
  tof.servicer_T_mount = mountAt({0.45, 0.0, 0.3});
  tof.tof = TofSpec::defaults();
  sensors.push_back(tof);
  SensorConfig imu;
  imu.name = "imu";
  imu.type = SensorType::kImu;
  imu.rate = 120.0;
  imu.servicer_T_mount = mountAt({0.05, 0.02, -0.1});
  sensors.push_back(imu);
  SensorConfig radar;
  radar.name = "radar";
  radar.type = SensorType::kRadar;
  radar.enabled = false;
  radar.rate = 1.0;
  radar.servicer_T_mount = mountAt({0.45, 0.0, 0.0});
  sensors.push_back(radar);
  // Off by default: a scenario's recording (and its digest) changes only when the scenario
  // enables it; the LIDAR tracking DFPC uses it when present.
  SensorConfig ahrs;
  ahrs.name = "ahrs";
  ahrs.type = SensorType::kAhrs;
  ahrs.enabled = false;
  ahrs.rate = 10.0;
  sensors.push_back(ahrs);
  return sensors;
}

// ------------------------------------------------------------------------------ parsing

Result<Scenario> parseScenario(const std::string& text, const std::string& source,
                               const std::vector<std::string>& overrides,
                               const std::filesystem::path& base) {
  Context context;
  context.source = source;
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    return invalidParameter("{}:{}:{}: invalid YAML: {}", source, e.mark.line + 1,
                            e.mark.column + 1, e.msg);
  }
  if (root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
  for (const std::string& o : overrides) CDFF_RETURN_IF_ERROR(applyOverride(root, o, context));
  const Field top(root, "", &context);
  CDFF_RETURN_IF_ERROR(
      top.allowOnly({"name", "description", "duration", "seed", "orbit", "target", "servicer",
                     "lighting", "background", "sensors", "faults", "truth", "renderer"}));
  Scenario sc;
  sc.name = std::filesystem::path(source).stem().string();
  if (top.has("name")) CDFF_RETURN_IF_ERROR(top["name"].string(sc.name));
  if (top.has("description")) CDFF_RETURN_IF_ERROR(top["description"].string(sc.description));
  CDFF_RETURN_IF_ERROR(optNumber(top, "duration", sc.duration, 0, 1e6, "s", true));
  if (top.has("seed")) CDFF_RETURN_IF_ERROR(top["seed"].unsignedInteger(sc.seed));

  if (top.has("orbit")) {
    const Field o = top["orbit"];
    CDFF_RETURN_IF_ERROR(o.allowOnly({"enabled", "altitude"}));
    CDFF_RETURN_IF_ERROR(optBool(o, "enabled", sc.orbit.enabled));
    CDFF_RETURN_IF_ERROR(optNumber(o, "altitude", sc.orbit.altitude, 100e3, 1e8, "m"));
  }

  // Renderer first: cameras take its shadow map size as their default.
  int shadow_map_size = 1024;
  if (top.has("renderer")) {
    const Field r = top["renderer"];
    CDFF_RETURN_IF_ERROR(r.allowOnly({"backend", "shadow_map_size"}));
    if (r.has("backend")) {
      std::string backend;
      CDFF_RETURN_IF_ERROR(r["backend"].choice(backend, {"cpu", "opengl", "auto"}));
      sc.renderer = backend == "opengl" ? RendererBackend::kOpenGl
                    : backend == "auto" ? RendererBackend::kAuto
                                        : RendererBackend::kCpu;
    }
    CDFF_RETURN_IF_ERROR(optInt(r, "shadow_map_size", shadow_map_size, 64, 8192));
  }

  if (top.has("target")) {
    const Field t = top["target"];
    CDFF_RETURN_IF_ERROR(t.allowOnly({"model", "procedural", "mesh", "attitude"}));
    if (t.has("model")) {
      std::string model;
      CDFF_RETURN_IF_ERROR(t["model"].string(model));
      if (model != "procedural") {
        sc.procedural_target = false;
        std::filesystem::path p(model);
        sc.target_mesh = p.is_absolute() || base.empty() ? p : base / p;
        if (!std::filesystem::exists(sc.target_mesh))
          return notFound("{}: target.model = {}: the mesh file '{}' does not exist",
                          t["model"].where(), model, sc.target_mesh.string());
      }
    }
    if (t.has("procedural")) {
      const Field p = t["procedural"];
      CDFF_RETURN_IF_ERROR(
          p.allowOnly({"bus_size",          "solar_wings",       "panels_per_wing",
                       "panel_size",        "panel_thickness",   "panel_gap",
                       "yoke_length",       "wing_angle_deg",    "adapter_ring",
                       "ring_diameter",     "ring_height",       "ring_wall",
                       "ring_flange_width", "launcher_brackets", "antenna",
                       "dish_diameter",     "dish_depth",        "mast_height",
                       "thrusters",         "thruster_length",   "thruster_exit_diameter",
                       "segments"}));
      TargetSpec& s = sc.target_spec;
      CDFF_RETURN_IF_ERROR(optVec3(p, "bus_size", s.bus_size));
      CDFF_RETURN_IF_ERROR(optBool(p, "solar_wings", s.solar_wings));
      CDFF_RETURN_IF_ERROR(optInt(p, "panels_per_wing", s.panels_per_wing, 1, 8));
      if (p.has("panel_size")) {
        std::vector<double> v;
        CDFF_RETURN_IF_ERROR(p["panel_size"].numbers(v, 2, 2));
        s.panel_size = {v[0], v[1]};
      }
      CDFF_RETURN_IF_ERROR(optNumber(p, "panel_thickness", s.panel_thickness, 0, 1, "m", true));
      CDFF_RETURN_IF_ERROR(optNumber(p, "panel_gap", s.panel_gap, 0, 1, "m"));
      CDFF_RETURN_IF_ERROR(optNumber(p, "yoke_length", s.yoke_length, 0, 10, "m", true));
      CDFF_RETURN_IF_ERROR(
          optNumber(p, "wing_angle_deg", s.wing_angle, -180, 180, "deg", false, kDeg));
      CDFF_RETURN_IF_ERROR(optBool(p, "adapter_ring", s.adapter_ring));
      CDFF_RETURN_IF_ERROR(optNumber(p, "ring_diameter", s.ring_diameter, 0, 10, "m", true));
      CDFF_RETURN_IF_ERROR(optNumber(p, "ring_height", s.ring_height, 0, 5, "m", true));
      CDFF_RETURN_IF_ERROR(optNumber(p, "ring_wall", s.ring_wall, 0, 1, "m", true));
      CDFF_RETURN_IF_ERROR(optNumber(p, "ring_flange_width", s.ring_flange_width, 0, 1, "m"));
      CDFF_RETURN_IF_ERROR(optBool(p, "launcher_brackets", s.launcher_brackets));
      CDFF_RETURN_IF_ERROR(optBool(p, "antenna", s.antenna));
      CDFF_RETURN_IF_ERROR(optNumber(p, "dish_diameter", s.dish_diameter, 0, 10, "m", true));
      CDFF_RETURN_IF_ERROR(optNumber(p, "dish_depth", s.dish_depth, 0, 5, "m", true));
      CDFF_RETURN_IF_ERROR(optNumber(p, "mast_height", s.mast_height, 0, 10, "m", true));
      CDFF_RETURN_IF_ERROR(optBool(p, "thrusters", s.thrusters));
      CDFF_RETURN_IF_ERROR(optNumber(p, "thruster_length", s.thruster_length, 0, 2, "m", true));
      CDFF_RETURN_IF_ERROR(
          optNumber(p, "thruster_exit_diameter", s.thruster_exit_diameter, 0, 2, "m", true));
      CDFF_RETURN_IF_ERROR(optInt(p, "segments", s.segments, 8, 256));
      CDFF_RETURN_IF_ERROR(s.validate().withContext(p.where() + ": target.procedural"));
    }
    if (t.has("mesh")) {
      const Field m = t["mesh"];
      CDFF_RETURN_IF_ERROR(m.allowOnly({"scale", "recentre", "rpy_deg", "smoothing_angle_deg"}));
      CDFF_RETURN_IF_ERROR(optNumber(m, "scale", sc.mesh_options.scale, 0, 1e6, "", true));
      CDFF_RETURN_IF_ERROR(optBool(m, "recentre", sc.mesh_options.recentre));
      CDFF_RETURN_IF_ERROR(optRpy(m, "rpy_deg", sc.mesh_rotation));
      CDFF_RETURN_IF_ERROR(optNumber(m, "smoothing_angle_deg", sc.mesh_options.smoothing_angle, 0,
                                     180, "deg", false, kDeg));
    }
    if (t.has("attitude")) {
      const Field a = t["attitude"];
      CDFF_RETURN_IF_ERROR(a.allowOnly({"mode", "rpy_deg", "rate_deg_s", "inertia"}));
      if (a.has("mode")) {
        std::string mode;
        CDFF_RETURN_IF_ERROR(a["mode"].choice(mode, {"lvlh", "inertial", "tumbling"}));
        sc.target_attitude = mode == "inertial"   ? TargetAttitudeKind::kInertial
                             : mode == "tumbling" ? TargetAttitudeKind::kTumbling
                                                  : TargetAttitudeKind::kLvlh;
      }
      CDFF_RETURN_IF_ERROR(optRpy(a, "rpy_deg", sc.target_initial));
      CDFF_RETURN_IF_ERROR(optVec3(a, "rate_deg_s", sc.target_rate, kDeg));
      if (sc.target_rate.norm() > 0 && sc.target_attitude != TargetAttitudeKind::kTumbling)
        return a["rate_deg_s"].fail("no rate unless target.attitude.mode is tumbling");
      if (a.has("inertia")) {
        Eigen::Vector3d inertia;
        CDFF_RETURN_IF_ERROR(a["inertia"].vec3(inertia));
        if (inertia.minCoeff() <= 0)
          return a["inertia"].fail("three positive principal moments of inertia in kg m^2");
        sc.target_inertia = inertia;
      }
    }
  }

  if (top.has("servicer")) {
    const Field s = top["servicer"];
    CDFF_RETURN_IF_ERROR(s.allowOnly({"trajectory", "attitude", "mockup"}));
    if (s.has("trajectory")) {
      const Field tr = s["trajectory"];
      std::string type = "hold";
      if (tr.has("type"))
        CDFF_RETURN_IF_ERROR(
            tr["type"].choice(type, {"hold", "line", "waypoints", "fly_around", "cw"}));
      if (type == "hold") {
        CDFF_RETURN_IF_ERROR(tr.allowOnly({"type", "position"}));
        sc.translation = TranslationKind::kHold;
        CDFF_RETURN_IF_ERROR(optVec3(tr, "position", sc.start));
      } else if (type == "line") {
        CDFF_RETURN_IF_ERROR(
            tr.allowOnly({"type", "start", "end", "start_time", "end_time", "profile"}));
        sc.translation = TranslationKind::kLine;
        if (!tr.has("start") || !tr.has("end"))
          return tr.fail("a line with 'start' and 'end' positions (lvlh, m)");
        CDFF_RETURN_IF_ERROR(tr["start"].vec3(sc.start));
        CDFF_RETURN_IF_ERROR(tr["end"].vec3(sc.end));
        CDFF_RETURN_IF_ERROR(optNumber(tr, "start_time", sc.start_time, 0, 1e6, "s"));
        CDFF_RETURN_IF_ERROR(optNumber(tr, "end_time", sc.end_time, 0, 1e6, "s", true));
        if (sc.end_time >= 0 && sc.end_time <= sc.start_time)
          return tr["end_time"].fail(fmt::format("a time after start_time ({} s)", sc.start_time));
        if (tr.has("profile")) {
          std::string profile;
          CDFF_RETURN_IF_ERROR(tr["profile"].choice(profile, {"smooth", "linear"}));
          sc.smooth = profile == "smooth";
        }
      } else if (type == "waypoints") {
        CDFF_RETURN_IF_ERROR(tr.allowOnly({"type", "times", "positions"}));
        sc.translation = TranslationKind::kWaypoints;
        if (!tr.has("times") || !tr.has("positions"))
          return tr.fail("waypoints with 'times' (s) and 'positions' (lvlh, m)");
        CDFF_RETURN_IF_ERROR(tr["times"].numbers(sc.waypoint_times, 2, 100000));
        const Field positions = tr["positions"];
        if (!positions.node().IsSequence() || positions.node().size() != sc.waypoint_times.size())
          return positions.fail(
              fmt::format("a list of {} positions, one per time", sc.waypoint_times.size()));
        for (std::size_t i = 0; i < positions.node().size(); ++i) {
          Eigen::Vector3d p;
          CDFF_RETURN_IF_ERROR(
              Field(positions.node()[i], positions.path() + "." + std::to_string(i), &context)
                  .vec3(p));
          sc.waypoints.push_back(p);
        }
        for (std::size_t i = 1; i < sc.waypoint_times.size(); ++i)
          if (!(sc.waypoint_times[i] > sc.waypoint_times[i - 1]))
            return tr["times"].fail("strictly increasing times");
        sc.start = sc.waypoints.front();
      } else if (type == "fly_around") {
        CDFF_RETURN_IF_ERROR(tr.allowOnly({"type", "centre", "axis", "reference", "radius",
                                           "radial_rate", "rate_deg_s", "phase_deg"}));
        sc.translation = TranslationKind::kFlyAround;
        CDFF_RETURN_IF_ERROR(optVec3(tr, "centre", sc.centre));
        if (tr.has("axis")) CDFF_RETURN_IF_ERROR(tr["axis"].direction(sc.axis));
        if (tr.has("reference")) CDFF_RETURN_IF_ERROR(tr["reference"].direction(sc.reference));
        if (std::abs(sc.axis.dot(sc.reference)) > 0.999)
          return tr["reference"].fail("a direction not parallel to 'axis'");
        CDFF_RETURN_IF_ERROR(optNumber(tr, "radius", sc.radius, 0, 1e6, "m", true));
        CDFF_RETURN_IF_ERROR(optNumber(tr, "radial_rate", sc.radial_rate, -100, 100, "m/s"));
        CDFF_RETURN_IF_ERROR(
            optNumber(tr, "rate_deg_s", sc.angular_rate, -90, 90, "deg/s", false, kDeg));
        CDFF_RETURN_IF_ERROR(optNumber(tr, "phase_deg", sc.phase, -360, 360, "deg", false, kDeg));
      } else {
        CDFF_RETURN_IF_ERROR(tr.allowOnly({"type", "position", "velocity"}));
        sc.translation = TranslationKind::kCw;
        CDFF_RETURN_IF_ERROR(optVec3(tr, "position", sc.start));
        CDFF_RETURN_IF_ERROR(optVec3(tr, "velocity", sc.velocity));
      }
    }
    if (s.has("attitude")) {
      const Field a = s["attitude"];
      CDFF_RETURN_IF_ERROR(
          a.allowOnly({"mode", "up", "yaw_offset_deg", "pitch_offset_deg", "rpy_deg"}));
      if (a.has("mode")) {
        std::string mode;
        CDFF_RETURN_IF_ERROR(a["mode"].choice(mode, {"target_pointing", "lvlh", "inertial"}));
        sc.servicer_attitude = mode == "lvlh"       ? ServicerAttitudeKind::kLvlh
                               : mode == "inertial" ? ServicerAttitudeKind::kInertial
                                                    : ServicerAttitudeKind::kTargetPointing;
      }
      if (a.has("up")) CDFF_RETURN_IF_ERROR(a["up"].direction(sc.up));
      CDFF_RETURN_IF_ERROR(
          optNumber(a, "yaw_offset_deg", sc.yaw_offset, -180, 180, "deg", false, kDeg));
      CDFF_RETURN_IF_ERROR(
          optNumber(a, "pitch_offset_deg", sc.pitch_offset, -90, 90, "deg", false, kDeg));
      CDFF_RETURN_IF_ERROR(optRpy(a, "rpy_deg", sc.servicer_orientation));
    }
    if (s.has("mockup")) {
      const Field m = s["mockup"];
      CDFF_RETURN_IF_ERROR(m.allowOnly({"enabled", "bus_size", "probe_length", "probe_diameter"}));
      sc.servicer_mockup = true;
      CDFF_RETURN_IF_ERROR(optBool(m, "enabled", sc.servicer_mockup));
      CDFF_RETURN_IF_ERROR(optVec3(m, "bus_size", sc.servicer_spec.bus_size));
      CDFF_RETURN_IF_ERROR(optNumber(m, "probe_length", sc.servicer_spec.probe_length, 0, 10, "m"));
      CDFF_RETURN_IF_ERROR(
          optNumber(m, "probe_diameter", sc.servicer_spec.probe_diameter, 0, 1, "m", true));
      CDFF_RETURN_IF_ERROR(
          sc.servicer_spec.validate().withContext(m.where() + ": servicer.mockup"));
    }
  }

  // Lighting: a preset relative to the first line of sight, or a direction.
  std::string sun_preset = "side_lit";
  double azimuth = 90 * kDeg, elevation = 10 * kDeg;
  bool sun_direction_given = false;
  if (top.has("lighting")) {
    const Field l = top["lighting"];
    CDFF_RETURN_IF_ERROR(l.allowOnly({"sun", "irradiance", "eclipses"}));
    CDFF_RETURN_IF_ERROR(optNumber(l, "irradiance", sc.sun.irradiance, 0, 100, "solar constants"));
    CDFF_RETURN_IF_ERROR(optBool(l, "eclipses", sc.eclipses));
    if (l.has("sun")) {
      const Field s = l["sun"];
      CDFF_RETURN_IF_ERROR(
          s.allowOnly({"preset", "azimuth_deg", "elevation_deg", "direction", "frame"}));
      if (s.has("direction") && (s.has("preset") || s.has("azimuth_deg") || s.has("elevation_deg")))
        return s["direction"].fail(
            "either 'direction' or 'preset'/'azimuth_deg'/'elevation_deg', not both");
      if (s.has("preset")) {
        CDFF_RETURN_IF_ERROR(
            s["preset"].choice(sun_preset, {"front_lit", "side_lit", "back_lit", "near_fov"}));
        const std::map<std::string, std::pair<double, double>> presets = {{"front_lit", {25, 15}},
                                                                          {"side_lit", {90, 10}},
                                                                          {"back_lit", {130, 20}},
                                                                          {"near_fov", {145, 0}}};
        azimuth = presets.at(sun_preset).first * kDeg;
        elevation = presets.at(sun_preset).second * kDeg;
      }
      CDFF_RETURN_IF_ERROR(optNumber(s, "azimuth_deg", azimuth, -360, 360, "deg", false, kDeg));
      CDFF_RETURN_IF_ERROR(optNumber(s, "elevation_deg", elevation, -90, 90, "deg", false, kDeg));
      if (s.has("direction")) {
        CDFF_RETURN_IF_ERROR(s["direction"].direction(sc.sun.direction));
        sun_direction_given = true;
      }
      if (s.has("frame")) {
        std::string frame;
        CDFF_RETURN_IF_ERROR(s["frame"].choice(frame, {"lvlh", "eci"}));
        sc.sun.inertial = frame == "eci";
      }
    }
  }
  if (top.has("background")) {
    const Field b = top["background"];
    CDFF_RETURN_IF_ERROR(b.allowOnly({"stars", "star_gain", "earth"}));
    CDFF_RETURN_IF_ERROR(optBool(b, "stars", sc.stars));
    CDFF_RETURN_IF_ERROR(optNumber(b, "star_gain", sc.star_gain, 0, 1e9));
    CDFF_RETURN_IF_ERROR(optBool(b, "earth", sc.earth));
  }
  if (sc.translation == TranslationKind::kFlyAround)
    sc.start =
        sc.centre +
        sc.radius *
            (std::cos(sc.phase) *
                 (sc.reference - sc.reference.dot(sc.axis) * sc.axis).normalized() +
             std::sin(sc.phase) *
                 sc.axis.cross((sc.reference - sc.reference.dot(sc.axis) * sc.axis).normalized()));
  if (!sun_direction_given) {
    // Azimuth from "behind the servicer" (0, front-lit) towards its right; elevation towards up.
    const Eigen::Vector3d f =
        (-sc.start).norm() > 1e-9 ? (-sc.start).normalized() : Eigen::Vector3d::UnitY();
    Eigen::Vector3d u = sc.up - sc.up.dot(f) * f;
    if (u.norm() < 1e-6) u = Eigen::Vector3d::UnitZ() - f.z() * f;
    u.normalize();
    const Eigen::Vector3d r = f.cross(u);
    sc.sun.direction = (std::cos(elevation) * (std::cos(azimuth) * -f + std::sin(azimuth) * r) +
                        std::sin(elevation) * u)
                           .normalized();
  }

  // Sensors: the default suite, then the scenario's changes and additions.
  sc.sensors = defaultSensors();
  for (SensorConfig& s : sc.sensors)
    if (s.type == SensorType::kCamera) s.camera.shadow_map_size = shadow_map_size;
  if (top.has("sensors")) {
    const Field all = top["sensors"];
    CDFF_RETURN_IF_ERROR(all.isMap());
    for (auto it = all.node().begin(); it != all.node().end(); ++it) {
      const std::string name = it->first.as<std::string>();
      const Field f = all[name];
      if (!f.node().IsMap()) return f.fail("a mapping of the sensor's settings");
      SensorConfig* existing = nullptr;
      for (SensorConfig& s : sc.sensors)
        if (s.name == name) existing = &s;
      if (!existing) {
        if (!f.has("type"))
          return invalidParameter(
              "{}: sensors.{}: a new sensor needs a 'type' (one of {{camera, lidar, tof, imu, "
              "radar, ahrs}})",
              f.where(), name);
        bool valid_name = !name.empty();
        for (char c : name)
          valid_name = valid_name && (std::isalnum(static_cast<unsigned char>(c)) || c == '_');
        if (!valid_name)
          return Field(it->first, "sensors." + name, &context)
              .fail("a sensor name of letters, digits and '_'");
        std::string type;
        CDFF_RETURN_IF_ERROR(
            f["type"].choice(type, {"camera", "lidar", "tof", "imu", "radar", "ahrs"}));
        SensorConfig s;
        s.name = name;
        s.type = type == "camera"  ? SensorType::kCamera
                 : type == "lidar" ? SensorType::kLidar
                 : type == "tof"   ? SensorType::kTof
                 : type == "imu"   ? SensorType::kImu
                 : type == "ahrs"  ? SensorType::kAhrs
                                   : SensorType::kRadar;
        // New sensors start from the defaults of their type.
        for (const SensorConfig& d : defaultSensors())
          if (d.type == s.type) {
            const std::string keep = s.name;
            s = d;
            s.name = keep;
            s.enabled = true;
            break;
          }
        if (s.type == SensorType::kCamera) s.camera.shadow_map_size = shadow_map_size;
        sc.sensors.push_back(s);
        existing = &sc.sensors.back();
      } else if (f.has("type")) {
        std::string type;
        CDFF_RETURN_IF_ERROR(f["type"].string(type));
        if (type != toString(existing->type))
          return f["type"].fail(fmt::format("'{}' (the built-in sensor '{}' is a {})",
                                            toString(existing->type), name,
                                            toString(existing->type)));
      }
      CDFF_RETURN_IF_ERROR(readSensor(f, *existing, shadow_map_size));
    }
  }

  if (top.has("faults")) {
    const Field all = top["faults"];
    if (!all.node().IsSequence()) return all.fail("a list of faults");
    for (std::size_t i = 0; i < all.node().size(); ++i) {
      const Field f(all.node()[i], "faults." + std::to_string(i), &context);
      CDFF_RETURN_IF_ERROR(
          f.allowOnly({"type", "sensor", "start", "end", "time", "probability", "rate", "gain",
                       "veil", "delay", "fraction", "mode", "gyro", "gyro_deg_s", "accel"}));
      FaultConfig fault;
      std::string type;
      if (!f.has("type")) return f.fail("a fault with a 'type'");
      CDFF_RETURN_IF_ERROR(
          f["type"].choice(type, {"camera_failure", "glare", "lidar_dropout", "lidar_spurious",
                                  "imu_bias_jump", "dropped_frames", "late_frames", "occlusion"}));
      const std::map<std::string, FaultType> types = {{"camera_failure", FaultType::kCameraFailure},
                                                      {"glare", FaultType::kGlare},
                                                      {"lidar_dropout", FaultType::kLidarDropout},
                                                      {"lidar_spurious", FaultType::kLidarSpurious},
                                                      {"imu_bias_jump", FaultType::kImuBiasJump},
                                                      {"dropped_frames", FaultType::kDroppedFrames},
                                                      {"late_frames", FaultType::kLateFrames},
                                                      {"occlusion", FaultType::kOcclusion}};
      fault.type = types.at(type);
      if (!f.has("sensor")) return f.fail("a fault with a 'sensor' (a sensor name, or '*')");
      CDFF_RETURN_IF_ERROR(f["sensor"].string(fault.sensor));
      // Which sensor types the fault can hit.
      std::vector<SensorType> allowed;
      switch (fault.type) {
        case FaultType::kCameraFailure:
        case FaultType::kGlare:
        case FaultType::kOcclusion:
          allowed = {SensorType::kCamera};
          break;
        case FaultType::kLidarDropout:
          allowed = {SensorType::kLidar, SensorType::kTof};
          break;
        case FaultType::kLidarSpurious:
          allowed = {SensorType::kLidar};
          break;
        case FaultType::kImuBiasJump:
          allowed = {SensorType::kImu};
          break;
        default:
          allowed = {SensorType::kCamera, SensorType::kLidar, SensorType::kTof,
                     SensorType::kImu,    SensorType::kRadar, SensorType::kAhrs};
      }
      if (fault.sensor != "*") {
        const SensorConfig* target = sc.sensor(fault.sensor);
        std::vector<std::string> names;
        for (const SensorConfig& s : sc.sensors)
          if (std::find(allowed.begin(), allowed.end(), s.type) != allowed.end())
            names.push_back(s.name);
        if (!target || std::find(allowed.begin(), allowed.end(), target->type) == allowed.end())
          return f["sensor"].fail(
              fmt::format("a sensor a {} fault applies to: one of {{{}}} or '*'", type,
                          fmt::join(names, ", ")));
      }
      CDFF_RETURN_IF_ERROR(optNumber(f, "start", fault.start, 0, 1e9, "s"));
      CDFF_RETURN_IF_ERROR(optNumber(f, "time", fault.start, 0, 1e9, "s"));
      CDFF_RETURN_IF_ERROR(optNumber(f, "end", fault.end, 0, 1e9, "s"));
      if (f.has("end") && fault.end <= fault.start)
        return f["end"].fail(fmt::format("a time after start ({} s)", fault.start));
      CDFF_RETURN_IF_ERROR(optNumber(f, "probability", fault.probability, 0, 1));
      CDFF_RETURN_IF_ERROR(optNumber(f, "rate", fault.rate, 0, 1e6, "returns per scan"));
      CDFF_RETURN_IF_ERROR(optNumber(f, "gain", fault.gain, 0, 1e6));
      CDFF_RETURN_IF_ERROR(optNumber(f, "veil", fault.veil, 0, 1e6));
      CDFF_RETURN_IF_ERROR(optNumber(f, "delay", fault.delay, 0, 60, "s", true));
      CDFF_RETURN_IF_ERROR(optNumber(f, "fraction", fault.fraction, 0, 1));
      if (f.has("mode")) {
        std::string mode;
        CDFF_RETURN_IF_ERROR(f["mode"].choice(mode, {"occluder", "shadow"}));
        fault.mode = mode == "shadow" ? OcclusionMode::kShadow : OcclusionMode::kOccluder;
      }
      CDFF_RETURN_IF_ERROR(optVec3(f, "gyro", fault.gyro));
      CDFF_RETURN_IF_ERROR(optVec3(f, "gyro_deg_s", fault.gyro, kDeg));
      CDFF_RETURN_IF_ERROR(optVec3(f, "accel", fault.accel));
      if (fault.type == FaultType::kLidarSpurious && !f.has("rate"))
        return f.fail("a lidar_spurious fault with a 'rate' (returns per scan)");
      sc.faults.push_back(fault);
    }
  }

  if (top.has("truth")) {
    const Field t = top["truth"];
    CDFF_RETURN_IF_ERROR(t.allowOnly({"rate", "camera_depth"}));
    CDFF_RETURN_IF_ERROR(optNumber(t, "rate", sc.truth_rate, 0, 10000, "Hz", true));
    CDFF_RETURN_IF_ERROR(optBool(t, "camera_depth", sc.truth_camera_depth));
  }
  if (sc.translation == TranslationKind::kLine && sc.end_time < 0) sc.end_time = sc.duration;
  YAML::Emitter out;
  out << root;
  sc.yaml = out.c_str();
  return sc;
}

Result<Scenario> loadScenario(const std::filesystem::path& file,
                              const std::vector<std::string>& overrides) {
  std::ifstream in(file);
  if (!in) return notFound("scenario file '{}' cannot be read", file.string());
  std::stringstream ss;
  ss << in.rdbuf();
  auto scenario = parseScenario(ss.str(), file.string(), overrides, file.parent_path());
  if (scenario) scenario->file = file;
  return scenario;
}

std::filesystem::path scenarioDirectory() {
  if (const char* dir = std::getenv("CDFF_SCENARIO_DIR")) return dir;
#ifdef CDFF_SOURCE_SCENARIO_DIR
  return CDFF_SOURCE_SCENARIO_DIR;
#else
  return "data/scenarios";
#endif
}

std::vector<ScenarioInfo> listScenarios(const std::filesystem::path& directory) {
  std::vector<ScenarioInfo> out;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(directory, ec)) {
    if (entry.path().extension() != ".yaml") continue;
    ScenarioInfo info;
    info.file = entry.path();
    info.name = entry.path().stem().string();
    auto scenario = loadScenario(entry.path());
    if (scenario) {
      info.description = scenario->description;
      info.duration = scenario->duration;
    } else {
      info.description = "INVALID: " + scenario.status().message();
    }
    out.push_back(info);
  }
  std::sort(out.begin(), out.end(),
            [](const ScenarioInfo& a, const ScenarioInfo& b) { return a.name < b.name; });
  return out;
}

Result<std::filesystem::path> resolveScenario(const std::string& name_or_path) {
  const std::filesystem::path p(name_or_path);
  if (p.extension() == ".yaml" || p.extension() == ".yml" ||
      name_or_path.find('/') != std::string::npos) {
    if (!std::filesystem::exists(p))
      return notFound("scenario file '{}' does not exist", name_or_path);
    return p;
  }
  const std::filesystem::path library = scenarioDirectory() / (name_or_path + ".yaml");
  if (std::filesystem::exists(library)) return library;
  std::vector<std::string> names;
  for (const ScenarioInfo& s : listScenarios()) names.push_back(s.name);
  return notFound("unknown scenario '{}'; expected a YAML file or one of {{{}}} (in {})",
                  name_or_path, fmt::join(names, ", "), scenarioDirectory().string());
}

}  // namespace cdff::egse
