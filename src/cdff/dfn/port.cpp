#include "cdff/dfn/port.hpp"

namespace cdff::dfn {

Status PortBase::setAny(Value value) {
  if (!value.empty() && value.type() != type_)
    return invalidInput("port '{}' has type {}; got a value of type {}", name_, type_.name(),
                        value.type().name());
  value_ = std::move(value);
  return Status::ok();
}

Status InputPortBase::setAny(Value value) {
  CDFF_RETURN_IF_ERROR(PortBase::setAny(std::move(value)));
  fresh_ = !value_.empty();
  return Status::ok();
}

}  // namespace cdff::dfn
