#pragma once
// Value: an immutable value of any CDFF data type, known at run time: a shared pointer and the
// TypeId that says what it points to. Ports, messages, data products, recordings and the
// synchronisation queues all hold Values; passing one copies a pointer, never the data.
//
//   Value v = Value::of(image);                        // or Value::of<Image>(shared_ptr)
//   if (std::shared_ptr<const Image> im = v.as<Image>()) ...   // null for another type
//
// A TypeId identifies one entry of the type registry (type_registry.hpp), where every data
// type is declared once; TypeId::of<T>() only compiles for a registered T.

#include <memory>
#include <string_view>

namespace cdff {

struct TypeInfo;

/// Specialised once per registered type, by the registry's table (type_registry.hpp).
template <typename T>
struct TypeTraits;

template <typename T>
concept RegisteredType = requires {
  TypeTraits<T>::name;
};

/// The registry entry of T (defined with the table).
template <typename T>
const TypeInfo& typeInfoOf();

class TypeId {
 public:
  /// No type: an unset port or message.
  TypeId() = default;
  explicit TypeId(const TypeInfo* info) : info_(info) {}

  template <RegisteredType T>
  static TypeId of() {
    return TypeId(&typeInfoOf<T>());
  }

  bool valid() const { return info_ != nullptr; }
  explicit operator bool() const { return valid(); }
  /// "Image", "PoseWithCovariance"...; "none" when not valid.
  std::string_view name() const;
  /// The registry entry; only when valid().
  const TypeInfo& info() const { return *info_; }
  bool operator==(const TypeId& other) const = default;

 private:
  const TypeInfo* info_ = nullptr;
};

class Value {
 public:
  Value() = default;
  Value(std::shared_ptr<const void> data, TypeId type)
      : data_(std::move(data)), type_(data_ ? type : TypeId()) {}

  template <RegisteredType T>
  static Value of(std::shared_ptr<const T> value) {
    return Value(std::move(value), TypeId::of<T>());
  }
  template <RegisteredType T>
  static Value of(T value) {
    return of<T>(std::make_shared<const T>(std::move(value)));
  }

  bool empty() const { return data_ == nullptr; }
  explicit operator bool() const { return !empty(); }
  TypeId type() const { return type_; }
  const std::shared_ptr<const void>& data() const { return data_; }
  const void* raw() const { return data_.get(); }

  /// The value as a T, or null when it is empty or of another type.
  template <RegisteredType T>
  std::shared_ptr<const T> as() const {
    return type_ == TypeId::of<T>() ? std::static_pointer_cast<const T>(data_) : nullptr;
  }
  template <RegisteredType T>
  const T* get() const {
    return type_ == TypeId::of<T>() ? static_cast<const T*>(data_.get()) : nullptr;
  }

  void reset() {
    data_.reset();
    type_ = TypeId();
  }

 private:
  std::shared_ptr<const void> data_;
  TypeId type_;
};

}  // namespace cdff
