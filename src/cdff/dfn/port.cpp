#include "cdff/dfn/port.hpp"

namespace cdff::dfn {

Status PortBase::setAny(std::shared_ptr<const void> value, const PortType& type) {
  if (!(type == type_))
    return invalidInput("port '{}' has type {}; got a value of type {}", name_, type_.name,
                        type.name);
  value_ = std::move(value);
  return Status::ok();
}

Status InputPortBase::setAny(std::shared_ptr<const void> value, const PortType& type) {
  CDFF_RETURN_IF_ERROR(PortBase::setAny(std::move(value), type));
  fresh_ = value_ != nullptr;
  return Status::ok();
}

}  // namespace cdff::dfn
