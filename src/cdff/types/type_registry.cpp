// The registry's entries: one TypeInfo per row of CDFF_FOR_EACH_TYPE, each reaching its type's
// codec (codec/codec.hpp) through function pointers.
#include "cdff/types/type_registry.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cdff/types/codec/codec.hpp"

namespace cdff {

namespace {

template <typename T>
const T& ref(const void* value) {
  return *static_cast<const T*>(value);
}

template <typename T>
Status encodeErased(const void* value, Timestamp stamp, codec::Encoded& out) {
  return codec::encode(ref<T>(value), stamp, out);
}

template <typename T>
Result<Value> decodeErased(Bytes data, const std::shared_ptr<const void>& owner) {
  auto value = std::make_shared<T>();
  CDFF_RETURN_IF_ERROR(codec::decode(data, owner, *value));
  return Value::of<T>(std::shared_ptr<const T>(std::move(value)));
}

// The stamp a value carries, where it has one.
template <typename T>
std::optional<Timestamp> ownStamp(const void* value) {
  const T& v = ref<T>(value);
  if constexpr (std::is_same_v<T, DepthMap>)
    return v.image.stamp;
  else if constexpr (std::is_same_v<T, StereoImagePair>)
    return v.left.stamp;
  else if constexpr (std::is_same_v<T, PoseWithCovariance> || std::is_same_v<T, RigidBodyState>)
    return v.pose.stamp;
  else if constexpr (requires { v.stamp; }) {
    if constexpr (std::is_same_v<std::remove_cvref_t<decltype(v.stamp)>, Timestamp>) return v.stamp;
    return std::nullopt;
  } else {
    return std::nullopt;
  }
}

template <typename T, ProductForm Form>
Status saveProduct(const void* value, Timestamp stamp, codec::ProductRecord& out) {
  if constexpr (Form == ProductForm::kInline) {
    out.json = codec::toJson(ref<T>(value));
    return Status::ok();
  } else if constexpr (Form == ProductForm::kPly) {
    return codec::toPly(ref<T>(value), out);
  } else {
    codec::Encoded encoded;
    CDFF_RETURN_IF_ERROR(codec::encode(ref<T>(value), stamp, encoded));
    const std::vector<std::uint8_t> bytes = encoded.flatten();
    out.file.assign(bytes.begin(), bytes.end());
    return Status::ok();
  }
}

template <typename T, ProductForm Form>
Result<Value> loadProduct(const codec::ProductRecord& in) {
  if constexpr (Form == ProductForm::kMessage) {
    auto bytes = std::make_shared<const std::string>(in.file);
    const Bytes data(reinterpret_cast<const std::uint8_t*>(bytes->data()), bytes->size());
    return decodeErased<T>(data, bytes);  // large arrays may share the file's bytes
  } else {
    T value{};
    if constexpr (Form == ProductForm::kInline)
      CDFF_RETURN_IF_ERROR(codec::fromJson(in.json, value));
    else
      CDFF_RETURN_IF_ERROR(codec::fromPly(in, value));
    return Value::of<T>(std::move(value));
  }
}

template <typename T, ProductForm Form>
TypeInfo makeInfo(std::string_view name, std::string_view cpp_name, std::string_view schema,
                  MessageEncoding encoding) {
  TypeInfo info;
  info.name = name;
  info.cpp_name = cpp_name;
  info.cpp_type = std::type_index(typeid(T));
  info.schema_name = schema;
  info.encoding = encoding;
  info.product = Form;
  info.encode = &encodeErased<T>;
  info.decode = &decodeErased<T>;
  info.own_stamp = &ownStamp<T>;
  info.save_product = &saveProduct<T, Form>;
  info.load_product = &loadProduct<T, Form>;
  return info;
}

}  // namespace

#define CDFF_DEFINE_TYPE_INFO(Type, Name, Schema, Encoding, Form)                                \
  template <>                                                                                    \
  const TypeInfo& typeInfoOf<Type>() {                                                           \
    static const TypeInfo info =                                                                 \
        makeInfo<Type, ProductForm::k##Form>(Name, #Type, Schema, MessageEncoding::k##Encoding); \
    return info;                                                                                 \
  }
CDFF_FOR_EACH_TYPE(CDFF_DEFINE_TYPE_INFO)
#undef CDFF_DEFINE_TYPE_INFO

std::string_view TypeId::name() const {
  return info_ ? info_->name : std::string_view("none");
}

std::string_view TypeInfo::schemaEncoding() const {
  return encoding == MessageEncoding::kJson ? "jsonschema" : "protobuf";
}

std::string_view TypeInfo::messageEncoding() const {
  return encoding == MessageEncoding::kJson ? "json" : "protobuf";
}

Bytes TypeInfo::schemaData() const {
  return codec::schemaData(schema_name, encoding);
}

const std::vector<TypeId>& allTypes() {
#define CDFF_TYPE_ID(Type, ...) TypeId::of<Type>(),
  static const std::vector<TypeId> types = {CDFF_FOR_EACH_TYPE(CDFF_TYPE_ID)};
#undef CDFF_TYPE_ID
  return types;
}

TypeId findType(std::string_view name) {
  for (TypeId t : allTypes())
    if (t.name() == name) return t;
  return TypeId();
}

TypeId findTypeBySchema(std::string_view schema_name, std::string_view message_encoding) {
  for (TypeId t : allTypes())
    if (t.info().schema_name == schema_name && t.info().messageEncoding() == message_encoding)
      return t;
  return TypeId();
}

std::string typeNames() {
  std::vector<std::string_view> names;
  for (TypeId t : allTypes()) names.push_back(t.name());
  return fmt::format("{{{}}}", fmt::join(names, ", "));
}

}  // namespace cdff
