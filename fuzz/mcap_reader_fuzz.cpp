// libFuzzer target: the MCAP reader, the codecs and the JSON inspector on arbitrary bytes.
// Everything must end in a Status, never in a crash, a hang or a sanitizer report.
#include <cstdint>
#include <map>
#include <vector>

#include "cdff/io/inspect.hpp"
#include "cdff/io/mcap.hpp"
#include "cdff/io/recorder.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace cdff::io;
  using cdff::TypeId;
  McapReaderOptions options;
  options.max_chunk_bytes = 64u << 20;  // stay well inside libFuzzer's memory limit
  McapReader reader;
  if (!reader.openBuffer(std::vector<std::uint8_t>(data, data + size), "fuzz", options).isOk())
    return 0;
  (void)reader.statistics();
  std::map<std::uint16_t, cdff::Result<MessageInspector>> inspectors;
  MessageIterator it = reader.messages();
  std::size_t n = 0;
  while (it.next() && n++ < 2000) {
    const MessageView& m = it.message();
    const TypeId type = typeOfChannel(*m.channel, m.schema);
    if (type) (void)type.info().decode(m.data, m.owner);
    auto found = inspectors.find(m.channel->id);
    if (found == inspectors.end())
      found =
          inspectors.emplace(m.channel->id, MessageInspector::create(*m.channel, m.schema)).first;
    if (found->second) {
      auto j = found->second->toJson(m.data);
      if (j) (void)j->dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
    }
  }
  (void)it.status();
  (void)reader.verify(false);  // the data-section CRC; the iteration read every chunk
  for (const AttachmentInfo& a : reader.attachments()) (void)reader.readAttachment(a);
  for (const MetadataInfo& md : reader.metadata()) (void)reader.readMetadata(md);
  // A time-range read through the index too.
  const Statistics& s = reader.statistics();
  ReadOptions window;
  window.start_time = s.message_start_time + (s.message_end_time - s.message_start_time) / 3;
  window.end_time = s.message_end_time;
  MessageIterator part = reader.messages(window);
  while (part.next()) {
  }
  return 0;
}
