#include "cdff/egse/sink.hpp"

namespace cdff::egse {

std::size_t MemorySink::count(const std::string& channel) const {
  std::size_t n = 0;
  for (const SimMessage& m : messages_) n += m.channel == channel;
  return n;
}

void DigestSink::add(const void* data, std::size_t size) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < size; ++i) {
    hash_ ^= bytes[i];
    hash_ *= 0x100000001b3ULL;
  }
}

void DigestSink::add(const std::string& s) {
  const std::uint64_t n = s.size();
  add(&n, sizeof(n));
  add(s.data(), s.size());
}

void DigestSink::add(const Transform& t) {
  add(&t.stamp, sizeof(t.stamp));
  add(t.parent_frame);
  add(t.child_frame);
  add(t.translation.data(), 3 * sizeof(double));
  add(t.rotation.coeffs().data(), 4 * sizeof(double));
}

void DigestSink::add(const Image& i) {
  add(&i.stamp, sizeof(i.stamp));
  add(i.frame_id);
  add(&i.width, sizeof(i.width));
  add(&i.height, sizeof(i.height));
  add(i.pixels.data(), i.pixels.size());
}

Status DigestSink::begin(const SimulationMetadata& m) {
  add(m.scenario);
  add(m.scenario_yaml);
  add(&m.seed, sizeof(m.seed));
  add(m.renderer);
  return Status::ok();
}

Status DigestSink::write(const SimMessage& message) {
  ++count_;
  add(message.channel);
  add(&message.log_time, sizeof(message.log_time));
  std::visit(
      [&](const auto& v) {
        using T = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<T, Image>) {
          add(v);
        } else if constexpr (std::is_same_v<T, DepthMap>) {
          add(v.image);
        } else if constexpr (std::is_same_v<T, PointCloud>) {
          add(&v.stamp, sizeof(v.stamp));
          add(v.frame_id);
          add(v.points.data(), v.points.size() * sizeof(Point4f));
          add(v.intensity.data(), v.intensity.size() * sizeof(float));
          add(v.ring.data(), v.ring.size() * sizeof(std::uint16_t));
          add(v.time_offset_us.data(), v.time_offset_us.size() * sizeof(std::int32_t));
        } else if constexpr (std::is_same_v<T, ImuSample>) {
          add(&v.stamp, sizeof(v.stamp));
          add(v.angular_velocity.data(), 3 * sizeof(double));
          add(v.linear_acceleration.data(), 3 * sizeof(double));
        } else if constexpr (std::is_same_v<T, RangeMeasurement>) {
          add(&v.stamp, sizeof(v.stamp));
          add(&v.valid, sizeof(v.valid));
          add(&v.range, sizeof(v.range));
          add(&v.range_rate, sizeof(v.range_rate));
          add(v.direction.data(), 3 * sizeof(double));
        } else if constexpr (std::is_same_v<T, CameraInfo>) {
          add(&v.stamp, sizeof(v.stamp));
          add(v.frame_id);
          const double k[4] = {v.model.fx, v.model.fy, v.model.cx, v.model.cy};
          add(k, sizeof(k));
          add(v.model.distortion.data(), v.model.distortion.size() * sizeof(double));
        } else if constexpr (std::is_same_v<T, LidarInfo>) {
          add(&v.stamp, sizeof(v.stamp));
          add(v.frame_id);
          add(v.elevations.data(), v.elevations.size() * sizeof(double));
          const double values[4] = {v.rotation_rate, v.min_range, v.max_range, v.range_noise};
          add(values, sizeof(values));
        } else if constexpr (std::is_same_v<T, Transform>) {
          add(v);
        } else if constexpr (std::is_same_v<T, PoseWithCovariance>) {
          add(v.pose);
          add(v.covariance.data(), 36 * sizeof(double));
        } else if constexpr (std::is_same_v<T, TriangleMesh>) {
          add(v.frame_id);
          add(v.vertices.data(), v.vertices.size() * sizeof(Eigen::Vector3f));
          add(v.triangles.data(), v.triangles.size() * sizeof(std::array<std::uint32_t, 3>));
        } else if constexpr (std::is_same_v<T, RigidBodyState>) {
          add(v.pose);
          add(v.twist.linear.data(), 3 * sizeof(double));
          add(v.twist.angular.data(), 3 * sizeof(double));
        } else if constexpr (std::is_same_v<T, JointState>) {
          add(&v.stamp, sizeof(v.stamp));
          for (const std::string& name : v.names) add(name);
          add(v.position.data(), v.position.size() * sizeof(double));
        } else if constexpr (std::is_same_v<T, Wrench>) {
          add(&v.stamp, sizeof(v.stamp));
          add(v.frame_id);
          add(v.force.data(), 3 * sizeof(double));
          add(v.torque.data(), 3 * sizeof(double));
        } else if constexpr (std::is_same_v<T, FaultEvent>) {
          add(&v.stamp, sizeof(v.stamp));
          add(v.sensor);
          add(v.fault);
          add(v.detail);
        }
      },
      message.payload);
  return Status::ok();
}

}  // namespace cdff::egse
