#include "cdff/dfn/port.hpp"

namespace cdff::dfn {

const std::vector<PortType>& allPortTypes() {
#define CDFF_PORT_TYPE_ENTRY(Type, Name) PortType::of<Type>(),
  static const std::vector<PortType> types{CDFF_FOR_EACH_PORT_TYPE(CDFF_PORT_TYPE_ENTRY)};
#undef CDFF_PORT_TYPE_ENTRY
  return types;
}

const PortType* findPortType(std::string_view name) {
  for (const PortType& type : allPortTypes())
    if (type.name == name) return &type;
  return nullptr;
}

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
