#pragma once
// How a CDFF value travels on DDS: which wire type carries each CDFF type, and the conversions
// between CDFF values and the samples of those wire types (the C structs that Cyclone's idlc
// generates from idl/ros2.idl and idl/cdff_msgs.idl).
//
//   CDFF type            wire type (DDS type name)                          loss
//   Image                sensor_msgs::msg::dds_::Image_                     none; its CameraModel
//                        (+ CameraInfo_ on <dir>/camera_info)               travels beside it
//   CameraModel          sensor_msgs::msg::dds_::CameraInfo_                none
//   ImuSample            sensor_msgs::msg::dds_::Imu_                       none
//   PointCloud           sensor_msgs::msg::dds_::PointCloud2_               the padding float (1)
//   Transform            tf2_msgs::msg::dds_::TFMessage_                    none
//   PoseWithCovariance   geometry_msgs::msg::dds_::PoseWithCovarianceStamped_  the child frame
//                        travels in the writer's user data (a ROS 2 writer has none)
//   every other type     cdff_msgs::msg::dds_::Record_                      none (codec bytes)
//
// With Encoding::kAsn1Uper (`--encoding asn1-uper`), every type that has an ESROCOS ASN.1 type
// (asn1/uper.hpp: Image, CameraModel, PointCloud, Transform, PoseWithCovariance, RigidBodyState,
// Bearing) travels as a Record whose encoding is "asn1-uper", whose type_name is the ASN.1
// type's ("Image8UC1", "TransformWithCovariance"...) and whose data are the uPER bytes; the
// other types travel as above. A received Record is decoded by its encoding field, whatever the
// reader's encoding.
//
// Times: CDFF's microseconds become builtin_interfaces/Time exactly; nanoseconds that are not
// whole microseconds (a ROS 2 publisher's) are truncated to the microsecond on the way in.
// A sample that does not convert (a size that does not match, an unknown encoding, a NaN in a
// pose) is an error that names the field, the value and what was expected.

#include <deque>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "cdff/types/type_registry.hpp"
#include "cdff/types/types.hpp"
#include "cdff_msgs.h"
#include "ros2.h"

namespace cdff::dds {

/// How the values that have an ASN.1 type travel (the others always travel as in the table).
enum class Encoding {
  kRos2,      // ROS 2 messages where there is one, else a Record of the recording codec's bytes
  kAsn1Uper,  // a Record of the value's uPER bytes, encoding "asn1-uper"
};
/// "ros2" or "asn1-uper".
std::string_view toString(Encoding encoding);
/// The encoding named `name`; an error that lists the names otherwise.
Result<Encoding> parseEncoding(std::string_view name);
/// The Record encoding field of uPER bytes.
inline constexpr std::string_view kAsn1UperEncoding = "asn1-uper";

enum class WireType {
  kImage,
  kCameraInfo,
  kImu,
  kPointCloud2,
  kTfMessage,
  kPoseWithCovarianceStamped,
  kRecord,
};

struct WireInfo {
  WireType wire;
  const dds_topic_descriptor_t* descriptor;
  std::string_view type_name;  // the DDS type name, ROS 2's for ROS 2 messages
};

const WireInfo& wireInfo(WireType wire);
/// The wire type that carries values of `type` in `encoding`.
WireType wireTypeOf(TypeId type, Encoding encoding = Encoding::kRos2);
/// The wire type registered under a DDS type name; none for a type the CDFF does not read.
std::optional<WireType> wireTypeNamed(std::string_view dds_type_name);
/// The CDFF type a ROS 2 wire type converts to (not valid for kRecord: each sample names it).
TypeId cdffTypeOf(WireType wire);

/// The DDS topic of a CDFF channel: ROS 2's "rt" prefix before the channel ("/a/b" -> "rt/a/b").
std::string topicOfChannel(std::string_view channel);
/// The channel of a ROS 2 topic ("rt/a/b" -> "/a/b"); none for a topic without the prefix.
std::optional<std::string> channelOfTopic(std::string_view topic);
/// The channel that carries an image channel's CameraInfo, ROS 2's convention:
/// "/chaser/camera/far/image" -> "/chaser/camera/far/camera_info".
std::string cameraInfoChannel(std::string_view image_channel);

builtin_interfaces_msg_dds__Time_ toRosTime(Timestamp stamp);
Timestamp fromRosTime(const builtin_interfaces_msg_dds__Time_& time);

using WireSample =
    std::variant<sensor_msgs_msg_dds__Image_, sensor_msgs_msg_dds__CameraInfo_,
                 sensor_msgs_msg_dds__Imu_, sensor_msgs_msg_dds__PointCloud2_,
                 tf2_msgs_msg_dds__TFMessage_, geometry_msgs_msg_dds__PoseWithCovarianceStamped_,
                 cdff_msgs_msg_dds__Record_>;

/// A sample ready to write, and the memory it points into: strings and packed arrays it owns,
/// and the value whose large arrays (pixels) it references without a copy. Not copyable (the
/// sample points into it).
class OutgoingSample {
 public:
  OutgoingSample() = default;
  OutgoingSample(const OutgoingSample&) = delete;
  OutgoingSample& operator=(const OutgoingSample&) = delete;

  WireType wire() const { return wire_; }
  /// The sample, as dds_write() takes it.
  const void* data() const;

  // Used by the encoders.
  template <typename Msg>
  Msg& start(WireType wire, Value keep_alive) {
    wire_ = wire;
    value_ = std::move(keep_alive);
    strings_.clear();
    bytes_.clear();
    doubles_.clear();
    fields_.clear();
    transforms_.clear();
    return sample_.emplace<Msg>();
  }
  char* keep(std::string text);
  std::vector<std::uint8_t>& bytes() { return bytes_; }
  std::vector<double>& doubles() { return doubles_; }
  std::vector<sensor_msgs_msg_dds__PointField_>& fields() { return fields_; }
  std::vector<geometry_msgs_msg_dds__TransformStamped_>& transforms() { return transforms_; }

 private:
  WireType wire_ = WireType::kRecord;
  Value value_;
  WireSample sample_;
  std::deque<std::string> strings_;  // a deque: growing it keeps the pointers already handed out
  std::vector<std::uint8_t> bytes_;
  std::vector<double> doubles_;
  std::vector<sensor_msgs_msg_dds__PointField_> fields_;
  std::vector<geometry_msgs_msg_dds__TransformStamped_> transforms_;
};

/// Fills `out` with the wire sample of `value` (of wireTypeOf(value.type(), encoding)); `stamp`
/// is the message's stamp (the header's, for the types without a stamp of their own).
Status encodeSample(const Value& value, Timestamp stamp, OutgoingSample& out,
                    Encoding encoding = Encoding::kRos2);
/// The CameraInfo sample of an image's camera model, stamped and framed like the image.
Status encodeCameraInfo(const CameraModel& camera, Timestamp stamp, const std::string& frame_id,
                        OutgoingSample& out);

/// What a received sample is read with.
struct IncomingContext {
  std::string channel;      // for the messages
  std::string child_frame;  // PoseWithCovarianceStamped: the writer's (user data), or ""
  TypeId expected;          // Record: the type the channel must carry (not valid: any)
};

struct Decoded {
  Timestamp stamp = 0;
  Value value;
};

/// The CDFF values of one received sample (a TFMessage may hold several transforms), each with
/// its stamp; an error naming the field, the value and what was expected when it does not
/// convert or does not validate.
Result<std::vector<Decoded>> decodeSample(WireType wire, const void* sample,
                                          const IncomingContext& context);

// The typed conversions, one per wire type (wire_sensors.cpp, wire_geometry.cpp).
Status encodeImage(const Image& image, OutgoingSample& out, Value keep_alive);
Status encodeCameraModel(const CameraModel& camera, Timestamp stamp, const std::string& frame_id,
                         OutgoingSample& out);
Status encodeImu(const ImuSample& imu, OutgoingSample& out);
Status encodePointCloud(const PointCloud& cloud, OutgoingSample& out);
Status encodeTransform(const Transform& transform, OutgoingSample& out);
Status encodePose(const PoseWithCovariance& pose, OutgoingSample& out);
Status encodeRecord(const Value& value, Timestamp stamp, OutgoingSample& out);
/// A Record of the value's uPER bytes (an error for a value without an ASN.1 type).
Status encodeAsn1Record(const Value& value, Timestamp stamp, OutgoingSample& out);

Result<Image> decodeImage(const sensor_msgs_msg_dds__Image_& msg);
Result<CameraModel> decodeCameraInfo(const sensor_msgs_msg_dds__CameraInfo_& msg);
Result<ImuSample> decodeImu(const sensor_msgs_msg_dds__Imu_& msg);
Result<PointCloud> decodePointCloud(const sensor_msgs_msg_dds__PointCloud2_& msg);
Result<std::vector<Transform>> decodeTfMessage(const tf2_msgs_msg_dds__TFMessage_& msg);
Result<PoseWithCovariance> decodePose(const geometry_msgs_msg_dds__PoseWithCovarianceStamped_& msg,
                                      const std::string& child_frame);
/// A Record's value, decoded by its encoding field: the type's recording codec ("protobuf",
/// "json") or uPER ("asn1-uper", type_name the ASN.1 type's).
Result<Value> decodeRecord(const cdff_msgs_msg_dds__Record_& msg, TypeId expected);

}  // namespace cdff::dds
