// MCAP writer: chunks in memory, one write per finished chunk, summary at close().
#include <fcntl.h>
#include <sys/uio.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <limits>

#include <lz4frame.h>
#include <zstd.h>

#include "cdff/io/crc32.hpp"
#include "cdff/io/mcap.hpp"
#include "cdff/io/mcap_format.hpp"

namespace cdff::io {

const char* mcapName(Compression compression) {
  switch (compression) {
    case Compression::kNone:
      return "";
    case Compression::kLz4:
      return "lz4";
    case Compression::kZstd:
      return "zstd";
  }
  return "";
}

const char* toString(Compression compression) {
  return compression == Compression::kNone ? "none" : mcapName(compression);
}

std::optional<Compression> compressionFromString(std::string_view name) {
  if (name.empty() || name == "none") return Compression::kNone;
  if (name == "lz4") return Compression::kLz4;
  if (name == "zstd") return Compression::kZstd;
  return std::nullopt;
}

namespace format {

void putStringMap(ByteVector& b, const std::map<std::string, std::string>& map) {
  const std::size_t at = b.size();
  putU32(b, 0);
  for (const auto& [key, value] : map) {
    putString(b, key);
    putString(b, value);
  }
  patchU32(b, at, static_cast<std::uint32_t>(b.size() - at - 4));
}

void putSchema(ByteVector& b, const Schema& schema) {
  const std::size_t at = beginRecord(b, kSchema);
  putU16(b, schema.id);
  putString(b, schema.name);
  putString(b, schema.encoding);
  putU32(b, static_cast<std::uint32_t>(schema.data.size()));
  putBytes(b, schema.data.data(), schema.data.size());
  endRecord(b, at);
}

void putChannel(ByteVector& b, const Channel& channel) {
  const std::size_t at = beginRecord(b, kChannel);
  putU16(b, channel.id);
  putU16(b, channel.schema_id);
  putString(b, channel.topic);
  putString(b, channel.message_encoding);
  putStringMap(b, channel.metadata);
  endRecord(b, at);
}

}  // namespace format

using namespace format;

namespace {

struct ChunkIndexRecord {
  std::uint64_t start = 0, end = 0, offset = 0, length = 0;
  std::vector<std::pair<std::uint16_t, std::uint64_t>> message_index_offsets;
  std::uint64_t message_index_length = 0;
  Compression compression = Compression::kNone;
  std::uint64_t compressed_size = 0, uncompressed_size = 0;
};

}  // namespace

struct McapWriter::Impl {
  McapWriterOptions options;
  std::string path;
  int fd = -1;
  Status error;  // sticky after the first I/O failure
  std::uint64_t position = 0;
  std::uint32_t data_crc = 0;

  std::vector<Schema> schemas;    // id = index + 1
  std::vector<Channel> channels;  // id = index + 1
  std::vector<std::uint32_t> next_sequence;
  // The chunk "generation" in which a schema / channel record was last written: every chunk
  // repeats the records its messages need, so each chunk can be decoded on its own (after a
  // damaged chunk, the next ones stay readable).
  std::vector<std::uint64_t> schema_in_chunk, channel_in_chunk;
  std::uint64_t generation = 1;

  ByteVector chunk;
  bool chunk_has_messages = false;
  std::uint64_t chunk_start = 0, chunk_end = 0;
  std::vector<std::vector<std::pair<std::uint64_t, std::uint64_t>>> index;  // per channel
  std::vector<std::uint16_t> chunk_channels;  // in order of first message

  ByteVector compressed, head, tail;
  ZSTD_CCtx* zstd = nullptr;

  Statistics stats;
  bool has_messages = false;
  std::vector<ChunkIndexRecord> chunk_indexes;
  std::vector<AttachmentInfo> attachment_indexes;
  std::vector<MetadataInfo> metadata_indexes;

  ~Impl() {
    if (zstd) ZSTD_freeCCtx(zstd);
    if (fd >= 0) ::close(fd);
  }

  Status fail(Status s) {
    if (error.isOk()) error = s;
    return s;
  }

  Status writeParts(std::initializer_list<Bytes> parts, bool in_data_section) {
    iovec iov[8];
    int n = 0;
    std::size_t total = 0;
    for (const Bytes& p : parts) {
      if (p.empty()) continue;
      iov[n].iov_base = const_cast<std::uint8_t*>(p.data());
      iov[n].iov_len = p.size();
      total += p.size();
      ++n;
      if (in_data_section && options.data_section_crc)
        data_crc = crc32Update(data_crc, p.data(), p.size());
    }
    return writeIov(iov, n, total);
  }

  Status writeIov(iovec* iov, int n, std::size_t total) {
    std::size_t done = 0;
    int first = 0;
    while (done < total) {
      const ssize_t w = ::writev(fd, iov + first, n - first);
      if (w < 0) {
        if (errno == EINTR) continue;
        return fail(ioError("writing '{}' at byte offset {}: {}", path, position + done,
                            std::strerror(errno)));
      }
      done += static_cast<std::size_t>(w);
      std::size_t left = static_cast<std::size_t>(w);
      while (first < n && left >= iov[first].iov_len) left -= iov[first++].iov_len;
      if (first < n) {
        iov[first].iov_base = static_cast<std::uint8_t*>(iov[first].iov_base) + left;
        iov[first].iov_len -= left;
      }
    }
    position += total;
    return Status::ok();
  }

  Status compress(const ByteVector& in, Bytes& out) {
    switch (options.compression) {
      case Compression::kNone:
        out = Bytes(in);
        return Status::ok();
      case Compression::kLz4: {
        LZ4F_preferences_t prefs;
        std::memset(&prefs, 0, sizeof(prefs));
        prefs.frameInfo.blockSizeID = LZ4F_max4MB;
        prefs.frameInfo.contentSize = in.size();
        prefs.compressionLevel = options.compression_level;
        compressed.resize(LZ4F_compressFrameBound(in.size(), &prefs));
        const std::size_t n =
            LZ4F_compressFrame(compressed.data(), compressed.size(), in.data(), in.size(), &prefs);
        if (LZ4F_isError(n))
          return fail({StatusCode::kInternal,
                       fmt::format("lz4 compression failed: {}", LZ4F_getErrorName(n))});
        out = Bytes(compressed.data(), n);
        return Status::ok();
      }
      case Compression::kZstd: {
        if (!zstd) zstd = ZSTD_createCCtx();
        compressed.resize(ZSTD_compressBound(in.size()));
        const int level = options.compression_level == 0 ? 1 : options.compression_level;
        const std::size_t n = ZSTD_compressCCtx(zstd, compressed.data(), compressed.size(),
                                                in.data(), in.size(), level);
        if (ZSTD_isError(n))
          return fail({StatusCode::kInternal,
                       fmt::format("zstd compression failed: {}", ZSTD_getErrorName(n))});
        out = Bytes(compressed.data(), n);
        return Status::ok();
      }
    }
    return Status::ok();
  }

  Status finishChunk() {
    if (chunk.empty()) return Status::ok();
    const std::uint32_t records_crc = options.chunk_crc ? crc32(chunk) : 0;
    Bytes body;
    CDFF_RETURN_IF_ERROR(compress(chunk, body));

    const std::string_view compression_name = mcapName(options.compression);
    head.clear();
    head.push_back(kChunk);
    putU64(head, 8 + 8 + 8 + 4 + 4 + compression_name.size() + 8 + body.size());
    putU64(head, chunk_has_messages ? chunk_start : 0);
    putU64(head, chunk_has_messages ? chunk_end : 0);
    putU64(head, chunk.size());
    putU32(head, records_crc);
    putString(head, compression_name);
    putU64(head, body.size());

    ChunkIndexRecord entry;
    entry.start = chunk_has_messages ? chunk_start : 0;
    entry.end = chunk_has_messages ? chunk_end : 0;
    entry.offset = position;
    entry.length = head.size() + body.size();
    entry.compression = options.compression;
    entry.compressed_size = body.size();
    entry.uncompressed_size = chunk.size();

    tail.clear();
    for (std::uint16_t id : chunk_channels) {
      auto& entries = index[id - 1];
      // Readers seek in message indexes by time: keep them sorted even when messages are not.
      if (!std::is_sorted(entries.begin(), entries.end()))
        std::stable_sort(entries.begin(), entries.end(),
                         [](const auto& a, const auto& b) { return a.first < b.first; });
      entry.message_index_offsets.emplace_back(id, entry.offset + entry.length + tail.size());
      tail.push_back(kMessageIndex);
      putU64(tail, 2 + 4 + 16 * entries.size());
      putU16(tail, id);
      putU32(tail, static_cast<std::uint32_t>(16 * entries.size()));
      for (const auto& [time, offset] : entries) {
        putU64(tail, time);
        putU64(tail, offset);
      }
      entries.clear();
    }
    entry.message_index_length = tail.size();

    if (options.data_section_crc) {
      data_crc = crc32Update(data_crc, head.data(), head.size());
      // An uncompressed body is the records, whose CRC is known: fold it in instead of reading
      // the bytes a second time.
      if (options.chunk_crc && options.compression == Compression::kNone)
        data_crc = crc32Combine(data_crc, records_crc, body.size());
      else
        data_crc = crc32Update(data_crc, body.data(), body.size());
      data_crc = crc32Update(data_crc, tail.data(), tail.size());
    }
    CDFF_RETURN_IF_ERROR(writeParts({Bytes(head), body, Bytes(tail)}, false));
    if (options.sync_each_chunk && ::fsync(fd) != 0)
      return fail(ioError("fsync of '{}' failed: {}", path, std::strerror(errno)));

    chunk_indexes.push_back(std::move(entry));
    ++stats.chunk_count;
    chunk.clear();
    chunk_channels.clear();
    chunk_has_messages = false;
    ++generation;
    return Status::ok();
  }

  void addToChunk(const Channel& channel) {
    if (channel.schema_id != 0 && schema_in_chunk[channel.schema_id - 1] != generation) {
      putSchema(chunk, schemas[channel.schema_id - 1]);
      schema_in_chunk[channel.schema_id - 1] = generation;
    }
    putChannel(chunk, channel);
    channel_in_chunk[channel.id - 1] = generation;
  }

  // The summary section (from byte offset summary_start), its summary offsets and the footer.
  ByteVector summary(std::uint64_t summary_start) const;

  Status check() const {
    if (fd < 0) return {StatusCode::kInvalidInput, "MCAP writer is not open"};
    return error;
  }
};

McapWriter::McapWriter() = default;
McapWriter::~McapWriter() {
  if (isOpen()) (void)close();
}

bool McapWriter::isOpen() const {
  return impl_ && impl_->fd >= 0;
}
const std::string& McapWriter::path() const {
  static const std::string kNone;
  return impl_ ? impl_->path : kNone;
}

Status McapWriter::open(const std::string& path, const McapWriterOptions& options) {
  if (isOpen()) CDFF_RETURN_IF_ERROR(close());
  if (options.chunk_size == 0)
    return invalidParameter("MCAP writer chunk_size is 0; expected a positive number of bytes");
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  impl->path = path;
  impl->fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (impl->fd < 0) return ioError("cannot create '{}': {}", path, std::strerror(errno));
  impl->chunk.reserve(options.chunk_size + (64u << 10));

  ByteVector b;
  putBytes(b, kMagic, sizeof(kMagic));
  const std::size_t at = beginRecord(b, kHeader);
  putString(b, options.profile);
  putString(b, options.library);
  endRecord(b, at);
  CDFF_RETURN_IF_ERROR(impl->writeParts({Bytes(b)}, true));
  impl_ = std::move(impl);
  return Status::ok();
}

Result<std::uint16_t> McapWriter::addSchema(const std::string& name, const std::string& encoding,
                                            Bytes data) {
  if (!impl_) return Status{StatusCode::kInvalidInput, "MCAP writer is not open"};
  CDFF_RETURN_IF_ERROR(impl_->check());
  for (const Schema& s : impl_->schemas)
    if (s.name == name && s.encoding == encoding && s.data.size() == data.size() &&
        std::equal(data.begin(), data.end(), s.data.begin()))
      return s.id;
  if (impl_->schemas.size() >= std::numeric_limits<std::uint16_t>::max())
    return invalidInput("'{}': too many schemas (65535 at most in one MCAP file)", impl_->path);
  Schema s;
  s.id = static_cast<std::uint16_t>(impl_->schemas.size() + 1);
  s.name = name;
  s.encoding = encoding;
  s.data.assign(data.begin(), data.end());
  impl_->schemas.push_back(std::move(s));
  impl_->schema_in_chunk.push_back(0);
  ++impl_->stats.schema_count;
  return impl_->schemas.back().id;
}

Result<std::uint16_t> McapWriter::addChannel(const std::string& topic,
                                             const std::string& message_encoding,
                                             std::uint16_t schema_id,
                                             const std::map<std::string, std::string>& metadata) {
  if (!impl_) return Status{StatusCode::kInvalidInput, "MCAP writer is not open"};
  CDFF_RETURN_IF_ERROR(impl_->check());
  if (schema_id > impl_->schemas.size())
    return invalidInput("channel '{}': unknown schema id {}; {} schemas are registered", topic,
                        schema_id, impl_->schemas.size());
  for (const Channel& c : impl_->channels)
    if (c.topic == topic)
      return invalidInput("channel '{}' is already registered (id {})", topic, c.id);
  if (impl_->channels.size() >= std::numeric_limits<std::uint16_t>::max())
    return invalidInput("'{}': too many channels (65535 at most in one MCAP file)", impl_->path);
  Channel c;
  c.id = static_cast<std::uint16_t>(impl_->channels.size() + 1);
  c.schema_id = schema_id;
  c.topic = topic;
  c.message_encoding = message_encoding;
  c.metadata = metadata;
  impl_->channels.push_back(std::move(c));
  impl_->next_sequence.push_back(0);
  impl_->channel_in_chunk.push_back(0);
  impl_->index.emplace_back();
  ++impl_->stats.channel_count;
  return impl_->channels.back().id;
}

Status McapWriter::write(std::uint16_t channel_id, std::uint64_t log_time,
                         std::uint64_t publish_time, std::span<const Bytes> parts,
                         std::optional<std::uint32_t> sequence) {
  if (!impl_) return Status{StatusCode::kInvalidInput, "MCAP writer is not open"};
  Impl& w = *impl_;
  CDFF_RETURN_IF_ERROR(w.check());
  if (channel_id == 0 || channel_id > w.channels.size())
    return invalidInput("'{}': unknown channel id {}; {} channels are registered", w.path,
                        channel_id, w.channels.size());
  std::size_t size = 0;
  for (const Bytes& p : parts) size += p.size();
  const std::size_t record = kRecordPrefix + kMessageFixed + size;

  if (w.chunk_has_messages) {
    const std::uint64_t start = std::min(w.chunk_start, log_time);
    const std::uint64_t end = std::max(w.chunk_end, log_time);
    const bool too_long =
        w.options.chunk_duration_ns != 0 && end - start > w.options.chunk_duration_ns;
    if (too_long || w.chunk.size() + record > w.options.chunk_size)
      CDFF_RETURN_IF_ERROR(w.finishChunk());
  }
  const Channel& channel = w.channels[channel_id - 1];
  if (w.channel_in_chunk[channel_id - 1] != w.generation) w.addToChunk(channel);

  const std::uint64_t offset = w.chunk.size();
  const std::size_t at = w.chunk.size();
  w.chunk.resize(at + record);
  std::uint8_t* p = w.chunk.data() + at;
  const std::uint64_t length = kMessageFixed + size;
  const std::uint32_t seq = sequence ? *sequence : w.next_sequence[channel_id - 1];
  w.next_sequence[channel_id - 1] = seq + 1;
  p[0] = kMessage;
  std::memcpy(p + 1, &length, 8);
  std::memcpy(p + 9, &channel_id, 2);
  std::memcpy(p + 11, &seq, 4);
  std::memcpy(p + 15, &log_time, 8);
  std::memcpy(p + 23, &publish_time, 8);
  p += kRecordPrefix + kMessageFixed;
  for (const Bytes& part : parts) {
    if (part.empty()) continue;
    std::memcpy(p, part.data(), part.size());
    p += part.size();
  }

  auto& entries = w.index[channel_id - 1];
  if (entries.empty()) w.chunk_channels.push_back(channel_id);
  entries.emplace_back(log_time, offset);
  if (!w.chunk_has_messages) {
    w.chunk_start = w.chunk_end = log_time;
    w.chunk_has_messages = true;
  } else {
    w.chunk_start = std::min(w.chunk_start, log_time);
    w.chunk_end = std::max(w.chunk_end, log_time);
  }
  if (!w.has_messages) {
    w.stats.message_start_time = w.stats.message_end_time = log_time;
    w.has_messages = true;
  } else {
    w.stats.message_start_time = std::min(w.stats.message_start_time, log_time);
    w.stats.message_end_time = std::max(w.stats.message_end_time, log_time);
  }
  ++w.stats.message_count;
  ++w.stats.channel_message_counts[channel_id];

  if (w.chunk.size() >= w.options.chunk_size) CDFF_RETURN_IF_ERROR(w.finishChunk());
  return Status::ok();
}

Status McapWriter::writeAttachment(const std::string& name, const std::string& media_type,
                                   std::uint64_t log_time, Bytes data, std::uint64_t create_time) {
  if (!impl_) return Status{StatusCode::kInvalidInput, "MCAP writer is not open"};
  Impl& w = *impl_;
  CDFF_RETURN_IF_ERROR(w.check());
  ByteVector head;
  head.push_back(kAttachment);
  putU64(head, 8 + 8 + 4 + name.size() + 4 + media_type.size() + 8 + data.size() + 4);
  putU64(head, log_time);
  putU64(head, create_time);
  putString(head, name);
  putString(head, media_type);
  putU64(head, data.size());
  std::uint32_t crc = crc32Update(0, head.data() + kRecordPrefix, head.size() - kRecordPrefix);
  crc = crc32Update(crc, data.data(), data.size());
  std::uint8_t crc_bytes[4];
  std::memcpy(crc_bytes, &crc, 4);
  AttachmentInfo info;
  info.offset = w.position;
  info.length = head.size() + data.size() + 4;
  info.log_time = log_time;
  info.create_time = create_time;
  info.data_size = data.size();
  info.name = name;
  info.media_type = media_type;
  CDFF_RETURN_IF_ERROR(w.writeParts({Bytes(head), data, Bytes(crc_bytes, 4)}, true));
  w.attachment_indexes.push_back(std::move(info));
  ++w.stats.attachment_count;
  return Status::ok();
}

Status McapWriter::writeMetadata(const std::string& name,
                                 const std::map<std::string, std::string>& values) {
  if (!impl_) return Status{StatusCode::kInvalidInput, "MCAP writer is not open"};
  Impl& w = *impl_;
  CDFF_RETURN_IF_ERROR(w.check());
  ByteVector b;
  const std::size_t at = beginRecord(b, kMetadata);
  putString(b, name);
  putStringMap(b, values);
  endRecord(b, at);
  MetadataInfo info;
  info.offset = w.position;
  info.length = b.size();
  info.name = name;
  CDFF_RETURN_IF_ERROR(w.writeParts({Bytes(b)}, true));
  w.metadata_indexes.push_back(std::move(info));
  ++w.stats.metadata_count;
  return Status::ok();
}

Status McapWriter::flush() {
  if (!impl_) return Status{StatusCode::kInvalidInput, "MCAP writer is not open"};
  CDFF_RETURN_IF_ERROR(impl_->check());
  return impl_->finishChunk();
}

Status McapWriter::close() {
  if (!isOpen()) return impl_ ? impl_->error : Status::ok();
  Impl& w = *impl_;
  Status status = w.error;
  if (status.isOk()) status = w.finishChunk();
  if (status.isOk()) {
    ByteVector b;
    b.push_back(kDataEnd);
    putU64(b, kDataEndContent);
    putU32(b, w.options.data_section_crc ? w.data_crc : 0);
    status = w.writeParts({Bytes(b)}, false);
  }
  if (status.isOk()) {
    const ByteVector s = w.summary(w.position);
    status = w.writeParts({Bytes(s)}, false);
  }
  if (status.isOk() && w.options.sync_each_chunk && ::fsync(w.fd) != 0)
    status = ioError("fsync of '{}' failed: {}", w.path, std::strerror(errno));
  if (::close(w.fd) != 0 && status.isOk())
    status = ioError("closing '{}' failed: {}", w.path, std::strerror(errno));
  w.fd = -1;
  if (!status.isOk()) (void)w.fail(status);
  return status;
}

namespace {

void putStatistics(ByteVector& s, const Statistics& stats) {
  const std::size_t at = beginRecord(s, kStatistics);
  putU64(s, stats.message_count);
  putU16(s, stats.schema_count);
  putU32(s, stats.channel_count);
  putU32(s, stats.attachment_count);
  putU32(s, stats.metadata_count);
  putU32(s, stats.chunk_count);
  putU64(s, stats.message_start_time);
  putU64(s, stats.message_end_time);
  putU32(s, static_cast<std::uint32_t>(stats.channel_message_counts.size() * 10));
  for (const auto& [id, count] : stats.channel_message_counts) {
    putU16(s, id);
    putU64(s, count);
  }
  endRecord(s, at);
}

void putChunkIndex(ByteVector& s, const ChunkIndexRecord& c) {
  const std::size_t at = beginRecord(s, kChunkIndex);
  putU64(s, c.start);
  putU64(s, c.end);
  putU64(s, c.offset);
  putU64(s, c.length);
  putU32(s, static_cast<std::uint32_t>(c.message_index_offsets.size() * 10));
  for (const auto& [id, offset] : c.message_index_offsets) {
    putU16(s, id);
    putU64(s, offset);
  }
  putU64(s, c.message_index_length);
  putString(s, mcapName(c.compression));
  putU64(s, c.compressed_size);
  putU64(s, c.uncompressed_size);
  endRecord(s, at);
}

void putAttachmentIndex(ByteVector& s, const AttachmentInfo& a) {
  const std::size_t at = beginRecord(s, kAttachmentIndex);
  putU64(s, a.offset);
  putU64(s, a.length);
  putU64(s, a.log_time);
  putU64(s, a.create_time);
  putU64(s, a.data_size);
  putString(s, a.name);
  putString(s, a.media_type);
  endRecord(s, at);
}

void putMetadataIndex(ByteVector& s, const MetadataInfo& m) {
  const std::size_t at = beginRecord(s, kMetadataIndex);
  putU64(s, m.offset);
  putU64(s, m.length);
  putString(s, m.name);
  endRecord(s, at);
}

}  // namespace

ByteVector McapWriter::Impl::summary(std::uint64_t summary_start) const {
  ByteVector s;
  struct Group {
    std::uint8_t opcode;
    std::uint64_t start, length;
  };
  std::vector<Group> groups;
  std::size_t begin = 0;
  // Ends the group of records of `opcode` that started at `begin` (none: no group).
  auto group = [&](std::uint8_t opcode) {
    if (s.size() > begin) groups.push_back({opcode, summary_start + begin, s.size() - begin});
    begin = s.size();
  };
  for (const Schema& schema : schemas) putSchema(s, schema);
  group(kSchema);
  for (const Channel& channel : channels) putChannel(s, channel);
  group(kChannel);
  putStatistics(s, stats);
  group(kStatistics);
  for (const ChunkIndexRecord& c : chunk_indexes) putChunkIndex(s, c);
  group(kChunkIndex);
  for (const AttachmentInfo& a : attachment_indexes) putAttachmentIndex(s, a);
  group(kAttachmentIndex);
  for (const MetadataInfo& m : metadata_indexes) putMetadataIndex(s, m);
  group(kMetadataIndex);

  const std::uint64_t summary_offset_start = summary_start + s.size();
  for (const Group& g : groups) {
    const std::size_t at = beginRecord(s, kSummaryOffset);
    putU8(s, g.opcode);
    putU64(s, g.start);
    putU64(s, g.length);
    endRecord(s, at);
  }
  s.push_back(kFooter);
  putU64(s, kFooterContent);
  putU64(s, summary_start);
  putU64(s, summary_offset_start);
  putU32(s, crc32(s));
  putBytes(s, kMagic, sizeof(kMagic));
  return s;
}

const Statistics& McapWriter::statistics() const {
  static const Statistics kEmpty;
  return impl_ ? impl_->stats : kEmpty;
}

std::uint64_t McapWriter::bytesWritten() const {
  return impl_ ? impl_->position : 0;
}

}  // namespace cdff::io
