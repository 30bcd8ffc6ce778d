#pragma once
// Typed ports: how data enters and leaves a DFN.
//
// A port holds a Value (type_registry.hpp): a std::shared_ptr<const T> with its TypeId. Values
// are immutable once produced, and passing one from an output to an input copies a pointer,
// never the data. Ports know their type at run time too, so that a DFPC can check a connection
// before anything runs; InputPort<T> and OutputPort<T> only exist for registered types.

#include <memory>
#include <string>
#include <string_view>

#include "cdff/types/type_registry.hpp"
#include "cdff/types/value.hpp"

namespace cdff::dfn {

class PortBase {
 public:
  PortBase(std::string name, TypeId type) : name_(std::move(name)), type_(type) {}
  PortBase(const PortBase&) = delete;
  PortBase& operator=(const PortBase&) = delete;
  virtual ~PortBase() = default;

  const std::string& name() const { return name_; }
  TypeId type() const { return type_; }
  bool hasValue() const { return !value_.empty(); }
  void clear() { value_.reset(); }

  /// Type-erased access for the DFPC framework; setAny() refuses a value of another type.
  const Value& anyValue() const { return value_; }
  Status setAny(Value value);

 protected:
  std::string name_;
  TypeId type_;
  Value value_;
};

class InputPortBase : public PortBase {
 public:
  InputPortBase(std::string name, TypeId type, bool optional)
      : PortBase(std::move(name), type), optional_(optional) {}
  bool optional() const { return optional_; }
  /// True when a value arrived since the last process() call of the owning DFN.
  bool isFresh() const { return fresh_; }
  void markConsumed() { fresh_ = false; }
  /// As PortBase::setAny, and marks the input fresh.
  Status setAny(Value value);

 protected:
  bool optional_;
  bool fresh_ = false;
};

class OutputPortBase : public PortBase {
 public:
  using PortBase::PortBase;
};

template <RegisteredType T>
class InputPort final : public InputPortBase {
 public:
  InputPort(std::string name, bool optional = false)
      : InputPortBase(std::move(name), TypeId::of<T>(), optional) {}

  void set(std::shared_ptr<const T> value) {
    value_ = Value::of<T>(std::move(value));
    fresh_ = !value_.empty();
  }
  void set(T value) { set(std::make_shared<const T>(std::move(value))); }

  /// The value; only valid when hasValue() (process() checks required inputs before a DFI runs).
  const T& operator*() const { return *get(); }
  const T* operator->() const { return get(); }
  const T* get() const { return static_cast<const T*>(value_.raw()); }
  std::shared_ptr<const T> shared() const {
    return std::static_pointer_cast<const T>(value_.data());
  }
};

template <RegisteredType T>
class OutputPort final : public OutputPortBase {
 public:
  explicit OutputPort(std::string name) : OutputPortBase(std::move(name), TypeId::of<T>()) {}

  void set(std::shared_ptr<const T> value) { value_ = Value::of<T>(std::move(value)); }
  void set(T value) { value_ = Value::of<T>(std::move(value)); }

  const T& operator*() const { return *get(); }
  const T* operator->() const { return get(); }
  const T* get() const { return static_cast<const T*>(value_.raw()); }
  std::shared_ptr<const T> shared() const {
    return std::static_pointer_cast<const T>(value_.data());
  }
};

}  // namespace cdff::dfn
