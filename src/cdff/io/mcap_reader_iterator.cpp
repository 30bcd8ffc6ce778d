// The MCAP reader's iteration: a lazy k-way merge of the chunks that overlap the requested time
// range and channels, in log-time order (mcap_reader_impl.hpp).
#include <algorithm>
#include <limits>

#include "cdff/io/mcap_reader_impl.hpp"

namespace cdff::io {

using namespace format;
using detail::Decompressor;
using detail::parseRecords;

namespace {

struct Entry {
  std::uint64_t log_time;
  std::uint64_t publish_time;
  std::uint32_t sequence;
  std::uint16_t channel;
  std::size_t data_offset;  // into the chunk's records
  std::size_t data_size;
};

struct LoadedChunk {
  std::shared_ptr<ByteVector> storage;
  Bytes records;
  std::vector<Entry> entries;
  std::size_t next = 0;
  std::size_t order = 0;  // position in file order, for ties
};

}  // namespace

struct MessageIterator::Impl {
  std::shared_ptr<const McapReader::Impl> reader;
  ReadOptions options;
  std::vector<bool> wanted;          // by channel id; empty: all
  std::vector<std::size_t> pending;  // chunk indices by (start time, offset)
  std::size_t next_pending = 0;
  std::vector<std::unique_ptr<LoadedChunk>> heap;  // min-heap on the next entry
  Decompressor decompressor;
  MessageView current;
  std::vector<Damage> damages;
  std::size_t loaded = 0;

  static bool later(const std::unique_ptr<LoadedChunk>& a, const std::unique_ptr<LoadedChunk>& b) {
    const Entry& ea = a->entries[a->next];
    const Entry& eb = b->entries[b->next];
    if (ea.log_time != eb.log_time) return ea.log_time > eb.log_time;
    return a->order > b->order;
  }

  bool channelWanted(std::uint16_t id) const {
    return wanted.empty() || (id < wanted.size() && wanted[id]);
  }

  void load(std::size_t index) {
    const ChunkInfo& info = reader->chunks[index];
    auto chunk = std::make_unique<LoadedChunk>();
    chunk->order = index;
    std::string error = reader->loadChunk(info, decompressor, chunk->storage, chunk->records);
    ++loaded;
    if (!error.empty()) {
      damages.push_back(
          {info.offset, (info.unchunked ? "records skipped: " : "chunk skipped: ") + error});
      return;
    }
    const std::uint64_t lo = options.start_time.value_or(0);
    const std::uint64_t hi = options.end_time.value_or(std::numeric_limits<std::uint64_t>::max());
    std::string unknown;
    const std::uint8_t* base = chunk->records.data();
    error = parseRecords(
        chunk->records,
        [&](std::size_t at, std::uint16_t channel, std::uint32_t sequence, std::uint64_t t,
            std::uint64_t publish, Bytes data) {
          if (t < lo || t > hi || !channelWanted(channel)) return;
          if (!reader->channels.count(channel)) {
            if (unknown.empty())
              unknown = fmt::format(
                  "message at records offset {} is on channel id {}, which no "
                  "Channel record defines; skipped",
                  at, channel);
            return;
          }
          chunk->entries.push_back({t, publish, sequence, channel,
                                    static_cast<std::size_t>(data.data() - base), data.size()});
        },
        [](std::size_t, Schema) {}, [](std::size_t, Channel) {});
    if (!error.empty()) damages.push_back({info.offset, "chunk partly read: " + error});
    if (!unknown.empty()) damages.push_back({info.offset, unknown});
    if (chunk->entries.empty()) return;
    if (!std::is_sorted(chunk->entries.begin(), chunk->entries.end(),
                        [](const Entry& a, const Entry& b) { return a.log_time < b.log_time; }))
      std::stable_sort(chunk->entries.begin(), chunk->entries.end(),
                       [](const Entry& a, const Entry& b) { return a.log_time < b.log_time; });
    heap.push_back(std::move(chunk));
    std::push_heap(heap.begin(), heap.end(), later);
  }

  bool next() {
    for (;;) {
      while (next_pending < pending.size()) {
        const ChunkInfo& c = reader->chunks[pending[next_pending]];
        if (!heap.empty()) {
          const LoadedChunk& top = *heap.front();
          if (c.message_start_time > top.entries[top.next].log_time) break;
        }
        load(pending[next_pending++]);
      }
      if (heap.empty()) return false;
      std::pop_heap(heap.begin(), heap.end(), later);
      LoadedChunk& chunk = *heap.back();
      const Entry& e = chunk.entries[chunk.next];
      const Channel& channel = reader->channels.at(e.channel);
      current.channel = &channel;
      auto schema = reader->schemas.find(channel.schema_id);
      current.schema = schema == reader->schemas.end() ? nullptr : &schema->second;
      current.sequence = e.sequence;
      current.log_time = e.log_time;
      current.publish_time = e.publish_time;
      current.data = Bytes(chunk.records.data() + e.data_offset, e.data_size);
      current.owner = chunk.storage;
      if (++chunk.next < chunk.entries.size()) {
        std::push_heap(heap.begin(), heap.end(), later);
      } else {
        heap.pop_back();
      }
      return true;
    }
  }
};

MessageIterator::MessageIterator(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
MessageIterator::MessageIterator(MessageIterator&&) noexcept = default;
MessageIterator& MessageIterator::operator=(MessageIterator&&) noexcept = default;
MessageIterator::~MessageIterator() = default;

bool MessageIterator::next() {
  return impl_ && impl_->next();
}
const MessageView& MessageIterator::message() const {
  return impl_->current;
}
const std::vector<Damage>& MessageIterator::damages() const {
  return impl_->damages;
}
std::size_t MessageIterator::chunksLoaded() const {
  return impl_ ? impl_->loaded : 0;
}
Status MessageIterator::status() const {
  if (!impl_ || impl_->damages.empty()) return Status::ok();
  return corrupt(fmt::format("'{}': {}", impl_->reader->path, impl_->damages.front().toString()));
}

MessageIterator McapReader::messages(const ReadOptions& options) const {
  auto it = std::make_unique<MessageIterator::Impl>();
  if (!impl_) return MessageIterator(std::move(it));
  it->reader = impl_;
  it->options = options;
  if (!options.channels.empty()) {
    it->wanted.assign(65536, false);
    for (std::uint16_t id : options.channels) it->wanted[id] = true;
  }
  const std::uint64_t lo = options.start_time.value_or(0);
  const std::uint64_t hi = options.end_time.value_or(std::numeric_limits<std::uint64_t>::max());
  for (std::size_t i = 0; i < impl_->chunks.size(); ++i) {
    const ChunkInfo& c = impl_->chunks[i];
    if (c.message_end_time < lo || c.message_start_time > hi) continue;
    if (!it->wanted.empty() && !c.channels.empty() &&
        std::none_of(c.channels.begin(), c.channels.end(),
                     [&](std::uint16_t id) { return it->wanted[id]; }))
      continue;
    it->pending.push_back(i);
  }
  std::stable_sort(it->pending.begin(), it->pending.end(), [&](std::size_t a, std::size_t b) {
    return impl_->chunks[a].message_start_time < impl_->chunks[b].message_start_time;
  });
  return MessageIterator(std::move(it));
}

}  // namespace cdff::io
