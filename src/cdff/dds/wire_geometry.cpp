// The wire-type table, topic names, times, transforms, poses and CDFF records, and the dispatch
// from a value or a received sample to the typed conversions.
#include <fmt/ranges.h>

#include <cstring>
#include <span>

#include "cdff/asn1/uper.hpp"
#include "cdff/dds/wire.hpp"
#include "cdff/types/codec/codec.hpp"

namespace cdff::dds {

namespace {

constexpr WireInfo kWireTypes[] = {
    {WireType::kImage, &sensor_msgs_msg_dds__Image__desc, "sensor_msgs::msg::dds_::Image_"},
    {WireType::kCameraInfo, &sensor_msgs_msg_dds__CameraInfo__desc,
     "sensor_msgs::msg::dds_::CameraInfo_"},
    {WireType::kImu, &sensor_msgs_msg_dds__Imu__desc, "sensor_msgs::msg::dds_::Imu_"},
    {WireType::kPointCloud2, &sensor_msgs_msg_dds__PointCloud2__desc,
     "sensor_msgs::msg::dds_::PointCloud2_"},
    {WireType::kTfMessage, &tf2_msgs_msg_dds__TFMessage__desc, "tf2_msgs::msg::dds_::TFMessage_"},
    {WireType::kPoseWithCovarianceStamped, &geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc,
     "geometry_msgs::msg::dds_::PoseWithCovarianceStamped_"},
    {WireType::kRecord, &cdff_msgs_msg_dds__Record__desc, "cdff_msgs::msg::dds_::Record_"},
};

std::string text(const char* s) {
  return s == nullptr ? std::string() : std::string(s);
}

geometry_msgs_msg_dds__Quaternion_ toRos(const Eigen::Quaterniond& q) {
  return {q.x(), q.y(), q.z(), q.w()};
}
Eigen::Quaterniond fromRos(const geometry_msgs_msg_dds__Quaternion_& q) {
  return Eigen::Quaterniond(q.w, q.x, q.y, q.z);
}

}  // namespace

const WireInfo& wireInfo(WireType wire) {
  return kWireTypes[static_cast<int>(wire)];
}

std::string_view toString(Encoding encoding) {
  return encoding == Encoding::kAsn1Uper ? kAsn1UperEncoding : "ros2";
}

Result<Encoding> parseEncoding(std::string_view name) {
  if (name == "ros2") return Encoding::kRos2;
  if (name == kAsn1UperEncoding) return Encoding::kAsn1Uper;
  return invalidParameter(
      "encoding '{}': expected ros2 (ROS 2 messages, else the recording codec's bytes) or "
      "asn1-uper (the ESROCOS ASN.1 types in uPER)",
      name);
}

WireType wireTypeOf(TypeId type, Encoding encoding) {
  if (encoding == Encoding::kAsn1Uper && asn1::hasAsn1Type(type)) return WireType::kRecord;
  if (type == TypeId::of<Image>()) return WireType::kImage;
  if (type == TypeId::of<CameraModel>()) return WireType::kCameraInfo;
  if (type == TypeId::of<ImuSample>()) return WireType::kImu;
  if (type == TypeId::of<PointCloud>()) return WireType::kPointCloud2;
  if (type == TypeId::of<Transform>()) return WireType::kTfMessage;
  if (type == TypeId::of<PoseWithCovariance>()) return WireType::kPoseWithCovarianceStamped;
  return WireType::kRecord;
}

std::optional<WireType> wireTypeNamed(std::string_view dds_type_name) {
  for (const WireInfo& w : kWireTypes)
    if (w.type_name == dds_type_name) return w.wire;
  return std::nullopt;
}

TypeId cdffTypeOf(WireType wire) {
  switch (wire) {
    case WireType::kImage:
      return TypeId::of<Image>();
    case WireType::kCameraInfo:
      return TypeId::of<CameraModel>();
    case WireType::kImu:
      return TypeId::of<ImuSample>();
    case WireType::kPointCloud2:
      return TypeId::of<PointCloud>();
    case WireType::kTfMessage:
      return TypeId::of<Transform>();
    case WireType::kPoseWithCovarianceStamped:
      return TypeId::of<PoseWithCovariance>();
    case WireType::kRecord:
      break;
  }
  return TypeId();
}

std::string topicOfChannel(std::string_view channel) {
  if (!channel.empty() && channel.front() == '/') channel.remove_prefix(1);
  return "rt/" + std::string(channel);
}

std::optional<std::string> channelOfTopic(std::string_view topic) {
  if (topic.substr(0, 3) != "rt/") return std::nullopt;
  return "/" + std::string(topic.substr(3));
}

std::string cameraInfoChannel(std::string_view image_channel) {
  const std::size_t slash = image_channel.rfind('/');
  const std::string_view dir =
      slash == std::string_view::npos ? std::string_view() : image_channel.substr(0, slash);
  return std::string(dir) + "/camera_info";
}

builtin_interfaces_msg_dds__Time_ toRosTime(Timestamp stamp) {
  // Floor division: a negative stamp keeps nanosec in [0, 1e9), as ROS 2 requires.
  Timestamp seconds = stamp / kMicrosecondsPerSecond;
  Timestamp micros = stamp % kMicrosecondsPerSecond;
  if (micros < 0) {
    micros += kMicrosecondsPerSecond;
    seconds -= 1;
  }
  return {static_cast<std::int32_t>(seconds), static_cast<std::uint32_t>(micros * 1000)};
}

Timestamp fromRosTime(const builtin_interfaces_msg_dds__Time_& time) {
  return Timestamp{time.sec} * kMicrosecondsPerSecond + time.nanosec / 1000;
}

// ---------------------------------------------------------------------------------------------

char* OutgoingSample::keep(std::string text) {
  strings_.push_back(std::move(text));
  return strings_.back().data();
}

const void* OutgoingSample::data() const {
  return std::visit([](const auto& msg) -> const void* { return &msg; }, sample_);
}

Status encodeTransform(const Transform& transform, OutgoingSample& out) {
  CDFF_RETURN_IF_ERROR(transform.validate());
  auto& msg = out.start<tf2_msgs_msg_dds__TFMessage_>(WireType::kTfMessage, Value());
  geometry_msgs_msg_dds__TransformStamped_ t{};
  t.header.stamp = toRosTime(transform.stamp);
  t.header.frame_id = out.keep(transform.parent_frame);
  t.child_frame_id = out.keep(transform.child_frame);
  t.transform.translation = {transform.translation.x(), transform.translation.y(),
                             transform.translation.z()};
  t.transform.rotation = toRos(transform.rotation);
  out.transforms().push_back(t);
  msg.transforms._buffer = out.transforms().data();
  msg.transforms._length = msg.transforms._maximum = 1;
  msg.transforms._release = false;
  return Status::ok();
}

Result<std::vector<Transform>> decodeTfMessage(const tf2_msgs_msg_dds__TFMessage_& msg) {
  std::vector<Transform> transforms;
  for (std::uint32_t i = 0; i < msg.transforms._length; ++i) {
    const geometry_msgs_msg_dds__TransformStamped_& t = msg.transforms._buffer[i];
    Transform transform;
    transform.stamp = fromRosTime(t.header.stamp);
    transform.parent_frame = text(t.header.frame_id);
    transform.child_frame = text(t.child_frame_id);
    const auto& v = t.transform.translation;
    transform.translation = {v.x, v.y, v.z};
    transform.rotation = fromRos(t.transform.rotation);
    Status valid = transform.validate();
    if (!valid) return valid.withContext(fmt::format("transforms[{}]", i));
    transforms.push_back(std::move(transform));
  }
  return transforms;
}

Status encodePose(const PoseWithCovariance& pose, OutgoingSample& out) {
  CDFF_RETURN_IF_ERROR(pose.validate());
  auto& msg = out.start<geometry_msgs_msg_dds__PoseWithCovarianceStamped_>(
      WireType::kPoseWithCovarianceStamped, Value());
  msg.header.stamp = toRosTime(pose.pose.stamp);
  msg.header.frame_id = out.keep(pose.pose.parent_frame);
  const Eigen::Vector3d& t = pose.pose.translation;
  msg.pose.pose.position = {t.x(), t.y(), t.z()};
  msg.pose.pose.orientation = toRos(pose.pose.rotation);
  // ROS 2 and CDFF order the covariance alike: translation, then rotation (docs/dds.md).
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) msg.pose.covariance[6 * r + c] = pose.covariance(r, c);
  return Status::ok();
}

Result<PoseWithCovariance> decodePose(const geometry_msgs_msg_dds__PoseWithCovarianceStamped_& msg,
                                      const std::string& child_frame) {
  PoseWithCovariance pose;
  pose.pose.stamp = fromRosTime(msg.header.stamp);
  pose.pose.parent_frame = text(msg.header.frame_id);
  pose.pose.child_frame = child_frame;
  const auto& p = msg.pose.pose.position;
  pose.pose.translation = {p.x, p.y, p.z};
  pose.pose.rotation = fromRos(msg.pose.pose.orientation);
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) pose.covariance(r, c) = msg.pose.covariance[6 * r + c];
  CDFF_RETURN_IF_ERROR(pose.validate());
  return pose;
}

Status encodeRecord(const Value& value, Timestamp stamp, OutgoingSample& out) {
  const TypeInfo& info = value.type().info();
  auto& msg = out.start<cdff_msgs_msg_dds__Record_>(WireType::kRecord, Value());
  msg.header.stamp = toRosTime(stamp);
  msg.header.frame_id = out.keep("");
  msg.type_name = out.keep(std::string(info.name));
  msg.encoding = out.keep(std::string(info.messageEncoding()));
  codec::Encoded encoded;
  CDFF_RETURN_IF_ERROR(info.encode(value.raw(), stamp, encoded));
  out.bytes() = encoded.flatten();
  msg.data._buffer = out.bytes().data();
  msg.data._length = msg.data._maximum = static_cast<std::uint32_t>(out.bytes().size());
  msg.data._release = false;
  return Status::ok();
}

Status encodeAsn1Record(const Value& value, Timestamp stamp, OutgoingSample& out) {
  Result<asn1::Asn1Type> type = asn1::asn1TypeOf(value);
  if (!type) return type.status();
  auto& msg = out.start<cdff_msgs_msg_dds__Record_>(WireType::kRecord, Value());
  msg.header.stamp = toRosTime(stamp);
  msg.header.frame_id = out.keep("");
  msg.type_name = out.keep(std::string(asn1::asn1Name(*type)));
  msg.encoding = out.keep(std::string(kAsn1UperEncoding));
  CDFF_RETURN_IF_ERROR(asn1::encode(value, out.bytes()));
  msg.data._buffer = out.bytes().data();
  msg.data._length = msg.data._maximum = static_cast<std::uint32_t>(out.bytes().size());
  msg.data._release = false;
  return Status::ok();
}

namespace {

// A Record of uPER bytes: its type_name is the ASN.1 type's.
Result<Value> decodeAsn1Record(const cdff_msgs_msg_dds__Record_& msg, TypeId expected) {
  const std::string name = text(msg.type_name);
  const std::optional<asn1::Asn1Type> type = asn1::asn1TypeNamed(name);
  if (!type || !asn1::cdffTypeOf(*type)) {
    std::vector<std::string> names;
    for (asn1::Asn1Type t : asn1::allAsn1Types())
      if (asn1::cdffTypeOf(t)) names.emplace_back(asn1::asn1Name(t));
    return invalidInput("record of ASN.1 type '{}' ({}): expected one of {}", name,
                        kAsn1UperEncoding, fmt::join(names, ", "));
  }
  const TypeId cdff_type = asn1::cdffTypeOf(*type);
  if (expected && cdff_type != expected)
    return invalidInput("record of ASN.1 type '{}' (a {}) on a channel of {}; expected a {}", name,
                        cdff_type.name(), expected.name(), expected.name());
  Result<Value> value =
      asn1::decode(*type, std::span<const std::uint8_t>(msg.data._buffer, msg.data._length));
  if (!value)
    return value.status().withContext(
        fmt::format("record of ASN.1 type '{}' ({})", name, kAsn1UperEncoding));
  return value;
}

}  // namespace

Result<Value> decodeRecord(const cdff_msgs_msg_dds__Record_& msg, TypeId expected) {
  const std::string encoding = text(msg.encoding);
  if (encoding == kAsn1UperEncoding) return decodeAsn1Record(msg, expected);
  const std::string name = text(msg.type_name);
  const TypeId type = findType(name);
  if (!type) return invalidInput("record of type '{}': expected one of {}", name, typeNames());
  if (expected && type != expected)
    return invalidInput("record of type '{}' on a channel of {}; expected a {}", name,
                        expected.name(), expected.name());
  if (encoding != type.info().messageEncoding())
    return invalidInput("record of type '{}' is encoded as '{}'; expected '{}' or '{}'", name,
                        encoding, type.info().messageEncoding(), kAsn1UperEncoding);
  auto bytes = std::make_shared<std::vector<std::uint8_t>>(msg.data._buffer,
                                                           msg.data._buffer + msg.data._length);
  Result<Value> value = type.info().decode(Bytes(*bytes), bytes);
  if (!value) return value.status().withContext(fmt::format("record of type '{}'", name));
  return value;
}

// ---------------------------------------------------------------------------------------------

Status encodeCameraInfo(const CameraModel& camera, Timestamp stamp, const std::string& frame_id,
                        OutgoingSample& out) {
  return encodeCameraModel(camera, stamp, frame_id, out);
}

Status encodeSample(const Value& value, Timestamp stamp, OutgoingSample& out, Encoding encoding) {
  if (!value) return invalidInput("an empty value; expected a value to publish");
  if (encoding == Encoding::kAsn1Uper && asn1::hasAsn1Type(value.type()))
    return encodeAsn1Record(value, stamp, out);
  switch (wireTypeOf(value.type())) {
    case WireType::kImage:
      return encodeImage(*value.get<Image>(), out, value);
    case WireType::kCameraInfo:
      return encodeCameraModel(*value.get<CameraModel>(), stamp, "", out);
    case WireType::kImu:
      return encodeImu(*value.get<ImuSample>(), out);
    case WireType::kPointCloud2:
      return encodePointCloud(*value.get<PointCloud>(), out);
    case WireType::kTfMessage:
      return encodeTransform(*value.get<Transform>(), out);
    case WireType::kPoseWithCovarianceStamped:
      return encodePose(*value.get<PoseWithCovariance>(), out);
    case WireType::kRecord:
      break;
  }
  return encodeRecord(value, stamp, out);
}

namespace {

template <typename T>
Result<std::vector<Decoded>> one(Result<T> value, Timestamp stamp) {
  if (!value) return value.status();
  return std::vector<Decoded>{{stamp, Value::of<T>(std::move(value).value())}};
}

}  // namespace

Result<std::vector<Decoded>> decodeSample(WireType wire, const void* sample,
                                          const IncomingContext& context) {
  switch (wire) {
    case WireType::kImage: {
      const auto& msg = *static_cast<const sensor_msgs_msg_dds__Image_*>(sample);
      return one(decodeImage(msg), fromRosTime(msg.header.stamp));
    }
    case WireType::kCameraInfo: {
      const auto& msg = *static_cast<const sensor_msgs_msg_dds__CameraInfo_*>(sample);
      return one(decodeCameraInfo(msg), fromRosTime(msg.header.stamp));
    }
    case WireType::kImu: {
      const auto& msg = *static_cast<const sensor_msgs_msg_dds__Imu_*>(sample);
      return one(decodeImu(msg), fromRosTime(msg.header.stamp));
    }
    case WireType::kPointCloud2: {
      const auto& msg = *static_cast<const sensor_msgs_msg_dds__PointCloud2_*>(sample);
      return one(decodePointCloud(msg), fromRosTime(msg.header.stamp));
    }
    case WireType::kTfMessage: {
      Result<std::vector<Transform>> transforms =
          decodeTfMessage(*static_cast<const tf2_msgs_msg_dds__TFMessage_*>(sample));
      if (!transforms) return transforms.status();
      std::vector<Decoded> decoded;
      for (Transform& t : *transforms) decoded.push_back({t.stamp, Value::of(std::move(t))});
      return decoded;
    }
    case WireType::kPoseWithCovarianceStamped: {
      const auto& msg =
          *static_cast<const geometry_msgs_msg_dds__PoseWithCovarianceStamped_*>(sample);
      return one(decodePose(msg, context.child_frame), fromRosTime(msg.header.stamp));
    }
    case WireType::kRecord: {
      const auto& msg = *static_cast<const cdff_msgs_msg_dds__Record_*>(sample);
      Result<Value> value = decodeRecord(msg, context.expected);
      if (!value) return value.status();
      return std::vector<Decoded>{{fromRosTime(msg.header.stamp), std::move(value).value()}};
    }
  }
  return invalidInput("unknown wire type {}", static_cast<int>(wire));
}

}  // namespace cdff::dds
