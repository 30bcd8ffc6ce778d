#pragma once
// Messages as JSON for people and scripts (`cdff log cat`): protobuf messages are decoded with
// the descriptors in the file's own schema, JSON messages are parsed, anything else is shown by
// size. Long arrays and byte fields are summarised.

#include <nlohmann/json.hpp>

#include "cdff/io/mcap.hpp"
#include "cdff/types/codec/protobuf.hpp"

namespace cdff::io {

namespace pb = ::cdff::codec::pb;

struct InspectOptions {
  /// Arrays longer than this become {"$array": length, "head": [first values]}; byte fields
  /// longer than this become {"$bytes": length, "head": "<hex of the first bytes>"}.
  std::size_t max_array = 16;
  std::size_t head = 6;
};

/// Decodes messages of one channel; build it once per channel (it parses the schema).
class MessageInspector {
 public:
  /// Fails when the channel's schema cannot be parsed (a corrupt FileDescriptorSet...).
  static Result<MessageInspector> create(const Channel& channel, const Schema* schema,
                                         const InspectOptions& options = {});
  Result<nlohmann::json> toJson(Bytes data) const;

 private:
  enum class Kind { kProtobuf, kJson, kOpaque };
  Kind kind_ = Kind::kOpaque;
  pb::DescriptorPool pool_;
  std::string root_;
  InspectOptions options_;
};

}  // namespace cdff::io
