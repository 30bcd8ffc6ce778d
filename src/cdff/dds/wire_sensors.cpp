// Images, camera models, IMU samples and point clouds <-> their ROS 2 sensor_msgs samples.
#include <cmath>
#include <cstring>

#include "cdff/dds/wire.hpp"

namespace cdff::dds {

namespace {

// ROS 2's image encodings (sensor_msgs/image_encodings.hpp) for CDFF's pixel formats.
struct EncodingName {
  PixelFormat format;
  const char* name;
};
constexpr EncodingName kEncodings[] = {{PixelFormat::kGray8, "mono8"},
                                       {PixelFormat::kBgr8, "bgr8"},
                                       {PixelFormat::kGray16, "mono16"},
                                       {PixelFormat::kFloat32, "32FC1"}};

std::optional<PixelFormat> formatOfEncoding(std::string_view encoding) {
  for (const EncodingName& e : kEncodings)
    if (encoding == e.name) return e.format;
  if (encoding == "8UC1") return PixelFormat::kGray8;
  if (encoding == "8UC3") return PixelFormat::kBgr8;
  if (encoding == "16UC1") return PixelFormat::kGray16;
  return std::nullopt;
}

const char* encodingOf(PixelFormat format) {
  for (const EncodingName& e : kEncodings)
    if (e.format == format) return e.name;
  return "";
}

std::string text(const char* s) {
  return s == nullptr ? std::string() : std::string(s);
}

// sensor_msgs/PointField datatypes.
constexpr std::uint8_t kUint16 = 4, kInt32 = 5, kFloat32 = 7;

struct CloudField {
  const char* name;
  std::uint8_t datatype;
  std::uint32_t size;
};

}  // namespace

Status encodeImage(const Image& image, OutgoingSample& out, Value keep_alive) {
  CDFF_RETURN_IF_ERROR(image.validate("image"));
  auto& msg = out.start<sensor_msgs_msg_dds__Image_>(WireType::kImage, std::move(keep_alive));
  msg.header.stamp = toRosTime(image.stamp);
  msg.header.frame_id = out.keep(image.frame_id);
  msg.height = static_cast<std::uint32_t>(image.height);
  msg.width = static_cast<std::uint32_t>(image.width);
  msg.encoding = out.keep(encodingOf(image.format));
  msg.is_bigendian = 0;
  msg.step = static_cast<std::uint32_t>(image.stride_bytes);
  const std::size_t size = image.stride_bytes * static_cast<std::size_t>(image.height);
  const std::uint8_t* data = image.pixels.data();
  if (image.pixels.size() < size) {
    // The last row is not padded in memory; ROS 2 requires step * height bytes.
    out.bytes().assign(size, 0);
    std::memcpy(out.bytes().data(), image.pixels.data(), image.pixels.size());
    data = out.bytes().data();
  }
  msg.data._buffer = const_cast<std::uint8_t*>(data);  // read only, while the sample is written
  msg.data._length = msg.data._maximum = static_cast<std::uint32_t>(size);
  msg.data._release = false;
  return Status::ok();
}

Result<Image> decodeImage(const sensor_msgs_msg_dds__Image_& msg) {
  const std::string encoding = text(msg.encoding);
  const std::optional<PixelFormat> format = formatOfEncoding(encoding);
  if (!format)
    return invalidInput(
        "image encoding '{}' is not one CDFF reads; expected one of {{mono8, bgr8, "
        "mono16, 32FC1, 8UC1, 8UC3, 16UC1}}",
        encoding);
  if (msg.is_bigendian != 0 && bytesPerPixel(*format) > 1)
    return invalidInput("image '{}' is big-endian; expected little-endian pixels", encoding);
  const std::uint64_t expected = std::uint64_t{msg.step} * msg.height;
  if (msg.data._length != expected)
    return invalidInput("image data holds {} bytes; expected step * height = {} * {} = {}",
                        msg.data._length, msg.step, msg.height, expected);
  if (msg.width == 0 || msg.height == 0 || msg.width > 1u << 20 || msg.height > 1u << 20)
    return invalidInput("image size is {}x{}; expected 1 to 1048576 pixels each way", msg.width,
                        msg.height);
  std::vector<std::uint8_t> bytes(msg.data._buffer, msg.data._buffer + msg.data._length);
  Result<Image> image = Image::fromBytes(std::move(bytes), static_cast<int>(msg.width),
                                         static_cast<int>(msg.height), *format, msg.step);
  if (!image) return image.status();
  image->stamp = fromRosTime(msg.header.stamp);
  image->frame_id = text(msg.header.frame_id);
  return image;
}

Status encodeCameraModel(const CameraModel& camera, Timestamp stamp, const std::string& frame_id,
                         OutgoingSample& out) {
  CDFF_RETURN_IF_ERROR(camera.validate());
  auto& msg = out.start<sensor_msgs_msg_dds__CameraInfo_>(WireType::kCameraInfo, Value());
  msg.header.stamp = toRosTime(stamp);
  msg.header.frame_id = out.keep(frame_id);
  msg.height = static_cast<std::uint32_t>(camera.height);
  msg.width = static_cast<std::uint32_t>(camera.width);
  const std::size_t n = camera.distortion.size();
  const char* model = "";
  if (camera.distortion_model == DistortionModel::kRadialTangential)
    model = n > 5 ? "rational_polynomial" : "plumb_bob";
  else if (camera.distortion_model == DistortionModel::kEquidistant)
    model = "equidistant";
  msg.distortion_model = out.keep(model);
  out.doubles() = camera.distortion;
  msg.d._buffer = out.doubles().data();
  msg.d._length = msg.d._maximum = static_cast<std::uint32_t>(n);
  msg.d._release = false;
  const double k[9] = {camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1};
  const double r[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const double p[12] = {camera.fx, 0, camera.cx, 0, 0, camera.fy, camera.cy, 0, 0, 0, 1, 0};
  std::memcpy(msg.k, k, sizeof k);
  std::memcpy(msg.r, r, sizeof r);
  std::memcpy(msg.p, p, sizeof p);
  return Status::ok();
}

Result<CameraModel> decodeCameraInfo(const sensor_msgs_msg_dds__CameraInfo_& msg) {
  CameraModel camera;
  camera.width = static_cast<int>(msg.width);
  camera.height = static_cast<int>(msg.height);
  camera.fx = msg.k[0];
  camera.cx = msg.k[2];
  camera.fy = msg.k[4];
  camera.cy = msg.k[5];
  if (msg.k[1] != 0 || msg.k[3] != 0 || msg.k[6] != 0 || msg.k[7] != 0 || msg.k[8] != 1)
    return invalidInput(
        "camera info K = [{} {} {}; {} {} {}; {} {} {}]; expected [fx 0 cx; 0 fy cy; 0 0 1]",
        msg.k[0], msg.k[1], msg.k[2], msg.k[3], msg.k[4], msg.k[5], msg.k[6], msg.k[7], msg.k[8]);
  camera.distortion.assign(msg.d._buffer, msg.d._buffer + msg.d._length);
  const std::string model = text(msg.distortion_model);
  bool all_zero = true;
  for (double d : camera.distortion) all_zero = all_zero && d == 0;
  if (model == "plumb_bob" || model == "rational_polynomial")
    camera.distortion_model = DistortionModel::kRadialTangential;
  else if (model == "equidistant")
    camera.distortion_model = DistortionModel::kEquidistant;
  else if (model.empty() && all_zero)
    camera.distortion.clear();
  else
    return invalidInput(
        "camera info distortion model '{}' is not one CDFF reads; expected plumb_bob, "
        "rational_polynomial, equidistant or '' without coefficients",
        model);
  CDFF_RETURN_IF_ERROR(camera.validate());
  return camera;
}

Status encodeImu(const ImuSample& imu, OutgoingSample& out) {
  CDFF_RETURN_IF_ERROR(imu.validate());
  auto& msg = out.start<sensor_msgs_msg_dds__Imu_>(WireType::kImu, Value());
  msg.header.stamp = toRosTime(imu.stamp);
  msg.header.frame_id = out.keep(imu.frame_id);
  msg.orientation = {0, 0, 0, 1};
  msg.orientation_covariance[0] = -1;  // ROS 2: no orientation estimate
  msg.angular_velocity = {imu.angular_velocity.x(), imu.angular_velocity.y(),
                          imu.angular_velocity.z()};
  msg.linear_acceleration = {imu.linear_acceleration.x(), imu.linear_acceleration.y(),
                             imu.linear_acceleration.z()};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      msg.angular_velocity_covariance[3 * r + c] = imu.angular_velocity_covariance(r, c);
      msg.linear_acceleration_covariance[3 * r + c] = imu.linear_acceleration_covariance(r, c);
    }
  return Status::ok();
}

Result<ImuSample> decodeImu(const sensor_msgs_msg_dds__Imu_& msg) {
  ImuSample imu;
  imu.stamp = fromRosTime(msg.header.stamp);
  imu.frame_id = text(msg.header.frame_id);
  imu.angular_velocity = {msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z};
  imu.linear_acceleration = {msg.linear_acceleration.x, msg.linear_acceleration.y,
                             msg.linear_acceleration.z};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      imu.angular_velocity_covariance(r, c) = msg.angular_velocity_covariance[3 * r + c];
      imu.linear_acceleration_covariance(r, c) = msg.linear_acceleration_covariance[3 * r + c];
    }
  CDFF_RETURN_IF_ERROR(imu.validate());
  return imu;
}

// size: one field layout table and the packing loop belong together
Status encodePointCloud(const PointCloud& cloud, OutgoingSample& out) {
  CDFF_RETURN_IF_ERROR(cloud.validate("point cloud", false));
  auto& msg = out.start<sensor_msgs_msg_dds__PointCloud2_>(WireType::kPointCloud2, Value());
  msg.header.stamp = toRosTime(cloud.stamp);
  msg.header.frame_id = out.keep(cloud.frame_id);
  std::vector<CloudField> layout = {{"x", kFloat32, 4}, {"y", kFloat32, 4}, {"z", kFloat32, 4}};
  if (cloud.hasNormals())
    layout.insert(
        layout.end(),
        {{"normal_x", kFloat32, 4}, {"normal_y", kFloat32, 4}, {"normal_z", kFloat32, 4}});
  if (!cloud.intensity.empty()) layout.push_back({"intensity", kFloat32, 4});
  if (!cloud.time_offset_us.empty()) layout.push_back({"time_offset_us", kInt32, 4});
  if (!cloud.ring.empty()) layout.push_back({"ring", kUint16, 2});
  std::uint32_t offset = 0;
  for (const CloudField& f : layout) {
    out.fields().push_back({out.keep(f.name), offset, f.datatype, 1});
    offset += f.size;
  }
  const std::uint32_t step = offset;
  const std::size_t n = cloud.size();
  std::vector<std::uint8_t>& data = out.bytes();
  data.resize(n * step);
  for (std::size_t i = 0; i < n; ++i) {
    std::uint8_t* p = data.data() + i * step;
    const auto put = [&p](const void* v, std::size_t size) {
      std::memcpy(p, v, size);
      p += size;
    };
    put(&cloud.points[i], 12);
    if (cloud.hasNormals()) put(&cloud.normals[i], 12);
    if (!cloud.intensity.empty()) put(&cloud.intensity[i], 4);
    if (!cloud.time_offset_us.empty()) put(&cloud.time_offset_us[i], 4);
    if (!cloud.ring.empty()) put(&cloud.ring[i], 2);
  }
  msg.height = 1;
  msg.width = static_cast<std::uint32_t>(n);
  msg.fields._buffer = out.fields().data();
  msg.fields._length = msg.fields._maximum = static_cast<std::uint32_t>(out.fields().size());
  msg.fields._release = false;
  msg.is_bigendian = false;
  msg.point_step = step;
  msg.row_step = static_cast<std::uint32_t>(n * step);
  msg.data._buffer = data.data();
  msg.data._length = msg.data._maximum = static_cast<std::uint32_t>(data.size());
  msg.data._release = false;
  bool dense = true;
  for (const Point4f& p : cloud.points.span())
    dense = dense && std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
  msg.is_dense = dense;
  return Status::ok();
}

namespace {

// One PointCloud2 field: its offset, checked against the point and the expected datatype.
Result<std::optional<std::uint32_t>> findField(const sensor_msgs_msg_dds__PointCloud2_& msg,
                                               std::string_view name, std::uint8_t datatype,
                                               std::uint32_t size) {
  for (std::uint32_t i = 0; i < msg.fields._length; ++i) {
    const sensor_msgs_msg_dds__PointField_& f = msg.fields._buffer[i];
    if (text(f.name) != name) continue;
    if (f.datatype != datatype)
      return invalidInput("point cloud field '{}' has datatype {}; expected {}", name, f.datatype,
                          datatype);
    if (std::uint64_t{f.offset} + size > msg.point_step)
      return invalidInput("point cloud field '{}' at offset {} overruns the point of {} bytes",
                          name, f.offset, msg.point_step);
    return std::optional<std::uint32_t>(f.offset);
  }
  return std::optional<std::uint32_t>();
}

template <typename T>
Buffer<T> column(const sensor_msgs_msg_dds__PointCloud2_& msg, std::uint32_t offset,
                 std::size_t n) {
  std::vector<T> values(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint8_t* row = msg.data._buffer + (i / msg.width) * msg.row_step;
    std::memcpy(&values[i], row + (i % msg.width) * msg.point_step + offset, sizeof(T));
  }
  return Buffer<T>::fromVector(std::move(values));
}

Buffer<Point4f> vectors(const sensor_msgs_msg_dds__PointCloud2_& msg,
                        const std::uint32_t (&offsets)[3], std::size_t n) {
  std::vector<Point4f> points(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint8_t* p =
        msg.data._buffer + (i / msg.width) * msg.row_step + (i % msg.width) * msg.point_step;
    std::memcpy(&points[i].x, p + offsets[0], 4);
    std::memcpy(&points[i].y, p + offsets[1], 4);
    std::memcpy(&points[i].z, p + offsets[2], 4);
  }
  return Buffer<Point4f>::fromVector(std::move(points));
}

}  // namespace

// size: the checks of a foreign cloud's layout, one after the other
Result<PointCloud> decodePointCloud(const sensor_msgs_msg_dds__PointCloud2_& msg) {
  if (msg.is_bigendian) return invalidInput("point cloud is big-endian; expected little-endian");
  const std::uint64_t n = std::uint64_t{msg.width} * msg.height;
  if (std::uint64_t{msg.row_step} < std::uint64_t{msg.point_step} * msg.width)
    return invalidInput("point cloud row_step is {}; expected >= point_step * width = {} * {}",
                        msg.row_step, msg.point_step, msg.width);
  if (msg.data._length != std::uint64_t{msg.row_step} * msg.height)
    return invalidInput("point cloud data holds {} bytes; expected row_step * height = {} * {}",
                        msg.data._length, msg.row_step, msg.height);
  std::uint32_t xyz[3], normal[3];
  bool has_normals = true;
  const char* names[6] = {"x", "y", "z", "normal_x", "normal_y", "normal_z"};
  for (int i = 0; i < 6; ++i) {
    Result<std::optional<std::uint32_t>> at = findField(msg, names[i], kFloat32, 4);
    if (!at) return at.status();
    if (i < 3 && !*at)
      return invalidInput("point cloud has no FLOAT32 field '{}'; expected x, y and z", names[i]);
    if (i < 3) xyz[i] = **at;
    if (i >= 3 && *at) normal[i - 3] = **at;
    if (i >= 3) has_normals = has_normals && at->has_value();
  }
  PointCloud cloud;
  cloud.stamp = fromRosTime(msg.header.stamp);
  cloud.frame_id = text(msg.header.frame_id);
  cloud.points = vectors(msg, xyz, n);
  if (has_normals) cloud.normals = vectors(msg, normal, n);
  Result<std::optional<std::uint32_t>> intensity = findField(msg, "intensity", kFloat32, 4);
  Result<std::optional<std::uint32_t>> time = findField(msg, "time_offset_us", kInt32, 4);
  Result<std::optional<std::uint32_t>> ring = findField(msg, "ring", kUint16, 2);
  for (const auto* field : {&intensity, &time, &ring})
    if (!*field) return field->status();
  if (*intensity) cloud.intensity = column<float>(msg, **intensity, n);
  if (*time) cloud.time_offset_us = column<std::int32_t>(msg, **time, n);
  if (*ring) cloud.ring = column<std::uint16_t>(msg, **ring, n);
  CDFF_RETURN_IF_ERROR(cloud.validate("point cloud", false));
  return cloud;
}

}  // namespace cdff::dds
