#pragma once
// Typed ports: how data enters and leaves a DFN.
//
// A port holds a std::shared_ptr<const T>: values are immutable once produced and passing one
// from an output to an input copies a pointer, never the data. Ports know their type at run
// time too (PortType), so that a DFPC can check a connection before anything runs.

#include <memory>
#include <string>
#include <string_view>
#include <typeindex>
#include <vector>

#include "cdff/types/types.hpp"

namespace cdff::dfn {

/// The name a port type has in DFN descriptions (YAML) and messages.
template <typename T>
struct PortTypeName;

#define CDFF_PORT_TYPE(Type, Name)                  \
  template <>                                       \
  struct PortTypeName<Type> {                       \
    static constexpr std::string_view value = Name; \
  }

// Every port type, once: the names above and the run-time table (findPortType) come from it.
#define CDFF_FOR_EACH_PORT_TYPE(X)                      \
  X(::cdff::Image, "Image")                             \
  X(::cdff::StereoImagePair, "StereoImagePair")         \
  X(::cdff::DepthMap, "DepthMap")                       \
  X(::cdff::CameraModel, "CameraModel")                 \
  X(::cdff::PointCloud, "PointCloud")                   \
  X(::cdff::Transform, "Transform")                     \
  X(::cdff::PoseWithCovariance, "PoseWithCovariance")   \
  X(::cdff::RigidBodyState, "RigidBodyState")           \
  X(::cdff::ImuSample, "ImuSample")                     \
  X(::cdff::Wrench, "Wrench")                           \
  X(::cdff::JointState, "JointState")                   \
  X(::cdff::Features2D, "Features2D")                   \
  X(::cdff::Features3D, "Features3D")                   \
  X(::cdff::Matches, "Matches")                         \
  X(::cdff::Correspondences2D, "Correspondences2D")     \
  X(::cdff::Correspondences3D, "Correspondences3D")     \
  X(::cdff::Correspondences2D3D, "Correspondences2D3D") \
  X(::cdff::TriangleMesh, "TriangleMesh")               \
  X(::cdff::PolygonModel, "PolygonModel")               \
  X(::cdff::ModelContours, "ModelContours")             \
  X(::cdff::ContourSamples, "ContourSamples")           \
  X(::cdff::Timestamp, "Timestamp")                     \
  X(double, "Double")                                   \
  X(bool, "Bool")                                       \
  X(int, "Int")                                         \
  X(std::string, "String")

#define CDFF_DECLARE_PORT_TYPE_NAME(Type, Name) CDFF_PORT_TYPE(Type, Name);
CDFF_FOR_EACH_PORT_TYPE(CDFF_DECLARE_PORT_TYPE_NAME)
#undef CDFF_DECLARE_PORT_TYPE_NAME

struct PortType {
  std::type_index cpp_type = std::type_index(typeid(void));
  std::string_view name = "none";  // the default: no type (an empty message, an unbound port)

  template <typename T>
  static PortType of() {
    return {std::type_index(typeid(T)), PortTypeName<T>::value};
  }
  bool operator==(const PortType& other) const { return cpp_type == other.cpp_type; }
};

/// The port type a description or a recording names ("PoseWithCovariance"); nullptr if none.
const PortType* findPortType(std::string_view name);
/// Every port type, in declaration order (for messages listing the accepted names).
const std::vector<PortType>& allPortTypes();

class PortBase {
 public:
  PortBase(std::string name, PortType type) : name_(std::move(name)), type_(type) {}
  PortBase(const PortBase&) = delete;
  PortBase& operator=(const PortBase&) = delete;
  virtual ~PortBase() = default;

  const std::string& name() const { return name_; }
  const PortType& type() const { return type_; }
  bool hasValue() const { return value_ != nullptr; }
  void clear() { value_.reset(); }

  /// Type-erased access for the DFPC framework; setAny() refuses a value of another type.
  const std::shared_ptr<const void>& anyValue() const { return value_; }
  Status setAny(std::shared_ptr<const void> value, const PortType& type);

 protected:
  std::string name_;
  PortType type_;
  std::shared_ptr<const void> value_;
};

class InputPortBase : public PortBase {
 public:
  InputPortBase(std::string name, PortType type, bool optional)
      : PortBase(std::move(name), type), optional_(optional) {}
  bool optional() const { return optional_; }
  /// True when a value arrived since the last process() call of the owning DFN.
  bool isFresh() const { return fresh_; }
  void markConsumed() { fresh_ = false; }
  /// As PortBase::setAny, and marks the input fresh.
  Status setAny(std::shared_ptr<const void> value, const PortType& type);

 protected:
  bool optional_;
  bool fresh_ = false;
};

class OutputPortBase : public PortBase {
 public:
  using PortBase::PortBase;
};

template <typename T>
class InputPort final : public InputPortBase {
 public:
  InputPort(std::string name, bool optional = false)
      : InputPortBase(std::move(name), PortType::of<T>(), optional) {}

  void set(std::shared_ptr<const T> value) {
    value_ = std::move(value);
    fresh_ = value_ != nullptr;
  }
  void set(T value) { set(std::make_shared<const T>(std::move(value))); }

  /// The value; only valid when hasValue() (process() checks required inputs before a DFI runs).
  const T& operator*() const { return *static_cast<const T*>(value_.get()); }
  const T* operator->() const { return static_cast<const T*>(value_.get()); }
  const T* get() const { return static_cast<const T*>(value_.get()); }
  std::shared_ptr<const T> shared() const { return std::static_pointer_cast<const T>(value_); }
};

template <typename T>
class OutputPort final : public OutputPortBase {
 public:
  explicit OutputPort(std::string name) : OutputPortBase(std::move(name), PortType::of<T>()) {}

  void set(std::shared_ptr<const T> value) { value_ = std::move(value); }
  void set(T value) { value_ = std::make_shared<const T>(std::move(value)); }

  const T& operator*() const { return *static_cast<const T*>(value_.get()); }
  const T* operator->() const { return static_cast<const T*>(value_.get()); }
  const T* get() const { return static_cast<const T*>(value_.get()); }
  std::shared_ptr<const T> shared() const { return std::static_pointer_cast<const T>(value_); }
};

}  // namespace cdff::dfn
