// The C++ half of the interoperability test with the official TypeScript MCAP library
// (tests/io/interop/run.sh drives both halves):
//   mcap_interop write DIR   writes cdff_{none,lz4,zstd}.mcap and cdff_manifest.json, the
//                            expected channels, counts and a decoded sample per channel
//   mcap_interop check DIR   reads the files interop.mjs wrote with @mcap/core and compares them
//                            with node_manifest.json
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cdff/io/replay.hpp"
#include "samples.hpp"

using nlohmann::json;
using namespace cdff;

namespace {

int failures = 0;

void fail(const std::string& what) {
  fmt::print(stderr, "FAIL {}\n", what);
  ++failures;
}

// A byte-array fingerprint the Node side computes the same way (FNV-1a, 32 bit).
json bytesExpect(const std::uint8_t* p, std::size_t n) {
  std::uint32_t h = 2166136261u;
  for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 16777619u;
  return {{"$len", n}, {"$fnv", h}};
}
template <typename T>
json bytesExpect(const Buffer<T>& b) {
  return bytesExpect(reinterpret_cast<const std::uint8_t*>(b.data()), b.size() * sizeof(T));
}

json timeExpect(Timestamp us) {
  return {{"seconds", us / 1'000'000}, {"nanos", (us % 1'000'000) * 1000}};
}
json xyzExpect(const Eigen::Vector3d& v) {
  return {{"x", v.x()}, {"y", v.y()}, {"z", v.z()}};
}
json quatExpect(const Eigen::Quaterniond& q) {
  return {{"x", q.x()}, {"y", q.y()}, {"z", q.z()}, {"w", q.w()}};
}
template <typename Range>
json firstOf(const Range& values, std::size_t total, std::size_t n = 6) {
  json first = json::array();
  std::size_t i = 0;
  for (const auto& v : values) {
    if (i++ >= n) break;
    first.push_back(v);
  }
  return {{"$len", total}, {"$first", first}};
}

json cameraExpect(const CameraModel& c, const char* model) {
  return {{"width", c.width},
          {"height", c.height},
          {"distortion_model", model},
          {"D", c.distortion},
          {"K", {c.fx, 0.0, c.cx, 0.0, c.fy, c.cy, 0.0, 0.0, 1.0}}};
}

json imageExpect(const Image& im, const char* encoding) {
  json j = {{"timestamp", timeExpect(im.stamp)},
            {"frame_id", im.frame_id},
            {"width", im.width},
            {"height", im.height},
            {"encoding", encoding},
            {"step", im.stride_bytes},
            {"data", bytesExpect(im.pixels.data(), im.height * im.stride_bytes)}};
  return j;
}

template <int N>
std::vector<double> rowMajor(const Eigen::Matrix<double, N, N>& m) {
  std::vector<double> v;
  for (int r = 0; r < N; ++r)
    for (int c = 0; c < N; ++c) v.push_back(m(r, c));
  return v;
}

std::map<std::string, json> expectations(const testing::IoSamples& s) {
  std::map<std::string, json> e;
  json left = imageExpect(s.image_mono, "mono8");
  left["cdff_camera"] = cameraExpect(s.camera, "plumb_bob");
  e["/chaser/camera/left/image"] = left;
  e["/chaser/camera/right/image"] = imageExpect(s.image_bgr, "bgr8");
  e["/chaser/thermal/image"] = imageExpect(s.image_float, "32FC1");
  json calibration = cameraExpect(s.camera, "plumb_bob");
  calibration["frame_id"] = "camera_left_optical";
  calibration["R"] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
  calibration["P"] = {s.camera.fx, 0.0, s.camera.cx, 0.0, 0.0, s.camera.fy,
                      s.camera.cy, 0.0, 0.0,         0.0, 1.0, 0.0};
  e["/chaser/camera/left/calibration"] = calibration;
  e["/chaser/camera/left/compressed"] = {{"format", "png"},
                                         {"frame_id", s.compressed.frame_id},
                                         {"timestamp", timeExpect(s.compressed.stamp)},
                                         {"data", bytesExpect(s.compressed.data)}};
  json right = imageExpect(s.stereo.right, "mono8");
  right["cdff_camera"] = cameraExpect(*s.stereo.right.camera, "kannala_brandt");
  e["/chaser/stereo/pair"] = {{"left", imageExpect(s.stereo.left, "mono8")},
                              {"right", right},
                              {"right_T_left",
                               {{"parent_frame_id", s.stereo.right_T_left.parent_frame},
                                {"child_frame_id", s.stereo.right_T_left.child_frame},
                                {"translation", xyzExpect(s.stereo.right_T_left.translation)},
                                {"rotation", quatExpect(s.stereo.right_T_left.rotation)}}}};
  json depth = imageExpect(s.depth_m.image, "32FC1");
  depth["cdff_meters_per_unit"] = 1.0;
  e["/chaser/tof/depth"] = depth;
  json depth_mm = imageExpect(s.depth_mm.image, "mono16");
  depth_mm["cdff_meters_per_unit"] = 0.001;
  e["/chaser/tof/depth_mm"] = depth_mm;

  const Point4f& p0 = s.cloud.points[0];
  const Point4f& n0 = s.cloud.normals[0];
  e["/chaser/lidar/points"] = {{"frame_id", "lidar"},
                               {"timestamp", timeExpect(s.cloud.stamp)},
                               {"point_stride", 36},
                               {"fields",
                                {{{"name", "x"}, {"offset", 0}, {"type", "FLOAT32"}},
                                 {{"name", "y"}, {"offset", 4}, {"type", "FLOAT32"}},
                                 {{"name", "z"}, {"offset", 8}, {"type", "FLOAT32"}},
                                 {{"name", "normal_x"}, {"offset", 12}, {"type", "FLOAT32"}},
                                 {{"name", "normal_y"}, {"offset", 16}, {"type", "FLOAT32"}},
                                 {{"name", "normal_z"}, {"offset", 20}, {"type", "FLOAT32"}},
                                 {{"name", "intensity"}, {"offset", 24}, {"type", "FLOAT32"}},
                                 {{"name", "time_offset_us"}, {"offset", 28}, {"type", "INT32"}},
                                 {{"name", "ring"}, {"offset", 32}, {"type", "UINT16"}}}},
                               {"data", {{"$len", 36 * s.cloud.size()}}},
                               {"$point0",
                                {{"x", p0.x},
                                 {"y", p0.y},
                                 {"z", p0.z},
                                 {"normal_z", n0.z},
                                 {"intensity", s.cloud.intensity[0]},
                                 {"ring", s.cloud.ring[0]},
                                 {"time_offset_us", s.cloud.time_offset_us[0]}}}};
  const Point4f& q0 = s.cloud_xyz.points[0];
  e["/chaser/lidar/points_xyz"] = {{"point_stride", 16},
                                   {"fields",
                                    {{{"name", "x"}, {"offset", 0}, {"type", "FLOAT32"}},
                                     {{"name", "y"}, {"offset", 4}, {"type", "FLOAT32"}},
                                     {{"name", "z"}, {"offset", 8}, {"type", "FLOAT32"}}}},
                                   {"data", bytesExpect(s.cloud_xyz.points)},
                                   {"$point0", {{"x", q0.x}, {"y", q0.y}, {"z", q0.z}}}};
  e["/chaser/tf/camera_left"] = {{"timestamp", timeExpect(s.transform.stamp)},
                                 {"parent_frame_id", "chaser"},
                                 {"child_frame_id", "camera_left_optical"},
                                 {"translation", xyzExpect(s.transform.translation)},
                                 {"rotation", quatExpect(s.transform.rotation)}};
  e["/cdff/pose_estimation/pose"] = {
      {"frame_id", "chaser"},
      {"pose",
       {{"position", xyzExpect(s.pose.pose.translation)},
        {"orientation", quatExpect(s.pose.pose.rotation)}}},
      {"cdff_child_frame_id", "target"},
      {"cdff_covariance", firstOf(rowMajor<6>(s.pose.covariance), 36, 36)}};
  e["/truth/target_state"] = {
      {"frame_id", "lvlh"},
      {"cdff_child_frame_id", "target"},
      {"cdff_linear_velocity", xyzExpect(s.state.twist.linear)},
      {"cdff_angular_velocity", xyzExpect(s.state.twist.angular)},
      {"cdff_covariance", firstOf(rowMajor<12>(s.state.covariance), 144, 20)}};
  const Eigen::Isometry3d& t1 = s.trajectory.poses[1];
  e["/cdff/pose_estimation/trajectory"] = {
      {"frame_id", "lvlh"},
      {"poses",
       {{"$len", s.trajectory.poses.size()},
        {"$first",
         {{{"position", xyzExpect(s.trajectory.poses[0].translation())}},
          {{"position", xyzExpect(t1.translation())},
           {"orientation", quatExpect(Eigen::Quaterniond(t1.rotation()))}}}}}}};
  std::vector<json> points;
  for (const auto& v : s.mesh.vertices)
    points.push_back({{"x", static_cast<double>(v.x())},
                      {"y", static_cast<double>(v.y())},
                      {"z", static_cast<double>(v.z())}});
  std::vector<std::uint32_t> indices;
  for (const auto& t : s.mesh.triangles) indices.insert(indices.end(), t.begin(), t.end());
  e["/cdff/reconstruction/mesh"] = {
      {"entities",
       {{{"frame_id", "target"},
         {"id", "mesh"},
         {"frame_locked", true},
         {"timestamp", timeExpect(s.mesh.stamp)},
         {"triangles",
          {{{"points", points},
            {"indices", indices},
            {"cdff_normals", {{"$len", 3 * s.mesh.vertex_normals.size()}}}}}}}}}};
  std::vector<float> xs, octave_f;
  std::vector<int> octaves;
  for (const auto& k : s.features2d.keypoints) {
    xs.push_back(k.position.x());
    octaves.push_back(k.octave);
  }
  e["/cdff/tracking/features"] = {{"frame_id", "camera_left_optical"},
                                  {"x", firstOf(xs, xs.size())},
                                  {"octave", firstOf(octaves, octaves.size(), 10)},
                                  {"descriptors",
                                   {{"element", "UINT8"},
                                    {"distance", "HAMMING"},
                                    {"rows", s.features2d.descriptors.rows},
                                    {"cols", 32},
                                    {"data", bytesExpect(s.features2d.descriptors.data)}}}};
  e["/cdff/tracking/features3d"] = {
      {"frame_id", "target"},
      {"positions", {{"$len", 3 * s.features3d.keypoints.size()}}},
      {"descriptors", {{"element", "FLOAT32"}, {"distance", "L2"}, {"cols", 33}}}};
  std::vector<int> query;
  for (const auto& m : s.matches.matches) query.push_back(m.query);
  e["/cdff/tracking/matches"] = {{"query", firstOf(query, query.size())}};
  e["/cdff/tracking/correspondences2d"] = {
      {"first", firstOf(std::vector<double>{s.corr2d.first[0].x(), s.corr2d.first[0].y(),
                                            s.corr2d.first[1].x()},
                        2 * s.corr2d.size())}};
  e["/cdff/tracking/correspondences3d"] = {{"second", {{"$len", 3 * s.corr3d.size()}}}};
  e["/cdff/tracking/correspondences2d3d"] = {
      {"pixels", firstOf(std::vector<double>{s.corr2d3d.pixels[0].x(), s.corr2d3d.pixels[0].y()},
                         2 * s.corr2d3d.size())}};
  e["/chaser/imu"] = {{"frame_id", "imu"},
                      {"angular_velocity", xyzExpect(s.imu.angular_velocity)},
                      {"angular_velocity_covariance",
                       firstOf(rowMajor<3>(s.imu.angular_velocity_covariance), 9, 9)}};
  e["/chaser/arm/wrench"] = {{"frame_id", "ft_sensor"},
                             {"force", xyzExpect(s.wrench.force)},
                             {"torque", xyzExpect(s.wrench.torque)}};
  e["/chaser/arm/joints"] = {{"name", s.joints.names}, {"position", s.joints.position}};
  e["/cdff/pose_estimation/timing"] = {{"dfn", "pose_estimation/icp"}, {"status", "ok"}};
  e["/cdff/events"] = {{"level", "info"}, {"source", "orchestrator"}};
  return e;
}

int writeFiles(const std::string& dir) {
  const Timestamp t0 = 1'700'000'000'000'000;  // us
  const int frames = 12;
  json manifest = {{"files", json::array()}};
  for (io::Compression compression :
       {io::Compression::kNone, io::Compression::kLz4, io::Compression::kZstd}) {
    const std::string name = fmt::format("cdff_{}.mcap", io::toString(compression));
    io::Recorder rec;
    io::McapWriterOptions options;
    options.compression = compression;
    options.chunk_size = 16 << 10;  // several chunks
    if (Status s = rec.open(dir + "/" + name, options); !s.isOk()) {
      fail(s.toString());
      return 1;
    }
    std::map<std::string, std::uint64_t> counts, first_time;
    std::map<std::string, json> expect;
    std::uint64_t range_count = 0;
    const Timestamp range_lo = t0 + 300'000, range_hi = t0 + 600'000;
    for (int i = 0; i < frames; ++i) {
      const Timestamp t = t0 + i * 100'000;  // 10 Hz
      const testing::IoSamples s = testing::makeIoSamples(i, t);
      if (Status st = testing::writeIoSamples(rec, s, t); !st.isOk()) {
        fail(st.toString());
        return 1;
      }
      if (i == 0) expect = expectations(s);
      for (const auto& [topic, e] : expect) {
        if (topic == "/chaser/tf/late") continue;
        ++counts[topic];
        if (i == 0) first_time[topic] = io::toMcapTime(t);
        if (t >= range_lo && t <= range_hi) ++range_count;
      }
      if (i > 0) {  // a stream that arrives 50 ms late: messages out of log-time order
        Transform late = s.transform;
        late.stamp = t - 50'000;
        if (Status st = rec.write("/chaser/tf/late", late); !st.isOk()) {
          fail(st.toString());
          return 1;
        }
        if (i == 1) {
          first_time["/chaser/tf/late"] = io::toMcapTime(late.stamp);
          expect["/chaser/tf/late"] = {{"child_frame_id", "camera_left_optical"}};
        }
        ++counts["/chaser/tf/late"];
        if (late.stamp >= range_lo && late.stamp <= range_hi) ++range_count;
      }
      for (int k = 1; k < 10; ++k) {  // the IMU runs at 100 Hz
        ImuSample imu = s.imu;
        imu.stamp = t + k * 10'000;
        if (Status st = rec.write("/chaser/imu", imu); !st.isOk()) {
          fail(st.toString());
          return 1;
        }
        ++counts["/chaser/imu"];
        if (imu.stamp >= range_lo && imu.stamp <= range_hi) ++range_count;
      }
    }
    (void)rec.writeMetadata("run", {{"scenario", "interop"}});
    if (Status s = rec.close(); !s.isOk()) {
      fail(s.toString());
      return 1;
    }
    json channels = json::array();
    std::uint64_t total = 0;
    for (const auto& [topic, count] : counts) {
      total += count;
      io::McapReader reader;
      (void)reader.open(dir + "/" + name);
      const io::Channel* ch = reader.channel(topic);
      const io::Schema* schema = ch ? reader.schemaOf(*ch) : nullptr;
      if (!ch || !schema) {
        fail("channel " + topic + " missing in " + name);
        continue;
      }
      channels.push_back({{"topic", topic},
                          {"schema_name", schema->name},
                          {"schema_encoding", schema->encoding},
                          {"message_encoding", ch->message_encoding},
                          {"cdff_type", ch->metadata.at("cdff.type")},
                          {"count", count},
                          {"first_log_time_ns", std::to_string(first_time[topic])},
                          {"expect", expect[topic]}});
    }
    manifest["files"].push_back(
        {{"path", name},
         {"compression", io::mcapName(compression)},
         {"message_count", total},
         {"range",
          {std::to_string(io::toMcapTime(range_lo)), std::to_string(io::toMcapTime(range_hi))}},
         {"range_count", range_count},
         {"channels", channels}});
  }
  std::ofstream(dir + "/cdff_manifest.json") << manifest.dump(1);
  fmt::print("wrote 3 files and cdff_manifest.json to {}\n", dir);
  return failures == 0 ? 0 : 1;
}

bool near(double a, double b) {
  return std::abs(a - b) <= 1e-12 * std::max(1.0, std::abs(b));
}

int checkFiles(const std::string& dir) {
  std::ifstream in(dir + "/node_manifest.json");
  if (!in) {
    fail("no node_manifest.json in " + dir);
    return 1;
  }
  const json manifest = json::parse(in, nullptr, false);
  if (manifest.is_discarded()) {
    fail("node_manifest.json is not JSON");
    return 1;
  }
  for (const json& file : manifest.at("files")) {
    const std::string path = dir + "/" + file.at("path").get<std::string>();
    io::Replay replay;
    if (Status s = replay.open({path}); !s.isOk()) {
      fail(s.toString());
      continue;
    }
    const io::McapReader& reader = replay.reader(0);
    if (reader.recovery().damaged())
      fail(path + ": reported damaged: " + reader.recovery().damages.front().toString());
    if (reader.recovery().indexed != file.at("indexed").get<bool>())
      fail(fmt::format("{}: indexed = {}, expected {}", path, reader.recovery().indexed,
                       file.at("indexed").get<bool>()));
    std::map<std::string, std::uint64_t> counts;
    std::map<std::string, bool> checked;
    std::uint64_t last = 0;
    while (replay.next()) {
      const io::ReplayMessage& m = replay.message();
      if (m.logTimeNs() < last) fail(path + ": messages out of log-time order");
      last = m.logTimeNs();
      ++counts[m.channel()];
      if (checked[m.channel()]) continue;
      checked[m.channel()] = true;
      const json& e = file.at("first").at(m.channel());
      if (m.logTimeNs() != std::stoull(e.at("log_time_ns").get<std::string>()))
        fail(fmt::format("{} {}: first log time {}, expected {}", path, m.channel(), m.logTimeNs(),
                         e.at("log_time_ns").get<std::string>()));
      auto any = m.decode();
      if (!any) {
        fail(any.status().toString());
        continue;
      }
      if (any->type().name() != e.at("cdff_type").get<std::string>()) {
        fail(fmt::format("{} {}: decoded as {}, expected {}", path, m.channel(), any->type().name(),
                         e.at("cdff_type").get<std::string>()));
        continue;
      }
      if (auto pose = any->as<PoseWithCovariance>()) {
        const json& v = e.at("value");
        const auto& p = pose->pose;
        const bool ok =
            p.parent_frame == v.at("frame_id") && p.child_frame == v.at("child_frame_id") &&
            near(p.translation.x(), v.at("x")) && near(p.translation.y(), v.at("y")) &&
            near(p.translation.z(), v.at("z")) && near(p.rotation.w(), v.at("qw")) &&
            near(p.rotation.x(), v.at("qx")) && near(pose->covariance(0, 0), v.at("c00")) &&
            near(pose->covariance(2, 3), v.at("c23")) &&
            near(pose->covariance(3, 2), v.at("c32")) && p.stamp == v.at("stamp_us");
        if (!ok) fail(fmt::format("{} {}: pose differs from {}", path, m.channel(), v.dump()));
      } else if (auto imu = any->as<ImuSample>()) {
        const json& v = e.at("value");
        const bool ok = imu->frame_id == v.at("frame_id") &&
                        near(imu->angular_velocity.z(), v.at("wz")) &&
                        near(imu->linear_acceleration.x(), v.at("ax")) &&
                        near(imu->angular_velocity_covariance(1, 1), v.at("cov11")) &&
                        imu->stamp == v.at("stamp_us");
        if (!ok)
          fail(fmt::format("{} {}: IMU sample differs from {}", path, m.channel(), v.dump()));
      } else if (auto tf = any->as<Transform>()) {
        const json& v = e.at("value");
        const bool ok = tf->parent_frame == v.at("parent") && tf->child_frame == v.at("child") &&
                        near(tf->translation.y(), v.at("y")) && near(tf->rotation.z(), v.at("qz"));
        if (!ok) fail(fmt::format("{} {}: transform differs from {}", path, m.channel(), v.dump()));
      }
    }
    if (!replay.status().isOk()) fail(replay.status().toString());
    for (const auto& [topic, count] : file.at("counts").items())
      if (counts[topic] != count.get<std::uint64_t>())
        fail(fmt::format("{} {}: {} messages, expected {}", path, topic, counts[topic],
                         count.get<std::uint64_t>()));
    if (file.contains("attachment")) {
      const auto& atts = reader.attachments();
      if (atts.size() != 1 || atts[0].name != file.at("attachment").at("name")) {
        fail(path + ": attachment missing");
      } else {
        auto data = reader.readAttachment(atts[0]);
        if (!data || std::string(data->begin(), data->end()) != file.at("attachment").at("text"))
          fail(path + ": attachment content differs");
      }
    }
    fmt::print("ok   read {} ({} channels, {})\n", path, counts.size(),
               reader.recovery().indexed ? "indexed" : "scanned: no index");
  }
  return failures == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3 || (std::string(argv[1]) != "write" && std::string(argv[1]) != "check")) {
    fmt::print(stderr, "usage: mcap_interop write|check DIR\n");
    return 2;
  }
  return std::string(argv[1]) == "write" ? writeFiles(argv[2]) : checkFiles(argv[2]);
}
