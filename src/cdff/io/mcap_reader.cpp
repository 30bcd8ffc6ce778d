// MCAP reader: summary first (O(chunks)), a scan of the data section when the summary is missing
// or damaged, and a lazy k-way merge of chunks for log-time ordered iteration. This file opens a
// file and answers the public interface; the parts are listed in mcap_reader_impl.hpp.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <limits>

#include "cdff/io/crc32.hpp"
#include "cdff/io/mcap.hpp"
#include "cdff/io/mcap_format.hpp"
#include "cdff/io/mcap_reader_impl.hpp"

namespace cdff::io {

using namespace format;
using detail::Decompressor;
using detail::parseRecords;
using detail::Source;

namespace format {

const char* opcodeName(std::uint8_t opcode) {
  switch (opcode) {
    case kHeader:
      return "Header";
    case kFooter:
      return "Footer";
    case kSchema:
      return "Schema";
    case kChannel:
      return "Channel";
    case kMessage:
      return "Message";
    case kChunk:
      return "Chunk";
    case kMessageIndex:
      return "Message Index";
    case kChunkIndex:
      return "Chunk Index";
    case kAttachment:
      return "Attachment";
    case kAttachmentIndex:
      return "Attachment Index";
    case kStatistics:
      return "Statistics";
    case kMetadata:
      return "Metadata";
    case kMetadataIndex:
      return "Metadata Index";
    case kSummaryOffset:
      return "Summary Offset";
    case kDataEnd:
      return "Data End";
    default:
      return "unknown";
  }
}

bool Cursor::stringMap(std::map<std::string, std::string>& map, const char* field) {
  std::uint32_t n = 0;
  if (!read(n, field)) return false;
  if (n > remaining()) return skip(n, field);  // fails with the message
  const std::size_t end = pos_ + n;
  while (ok_ && pos_ < end) {
    std::string key, value;
    if (!string(key, field) || !string(value, field)) return false;
    if (pos_ > end)
      return fail(fmt::format("{} overruns its length at byte offset {}", field, offset()));
    map[std::move(key)] = std::move(value);
  }
  return ok_;
}

bool parseSchema(Cursor& c, Schema& s) {
  Bytes data;
  if (!c.read(s.id, "Schema id") || !c.string(s.name, "Schema name") ||
      !c.string(s.encoding, "Schema encoding") || !c.bytes32(data, "Schema data"))
    return false;
  s.data.assign(data.begin(), data.end());
  return true;
}

bool parseChannel(Cursor& c, Channel& ch) {
  return c.read(ch.id, "Channel id") && c.read(ch.schema_id, "Channel schema id") &&
         c.string(ch.topic, "Channel topic") &&
         c.string(ch.message_encoding, "Channel message encoding") &&
         c.stringMap(ch.metadata, "Channel metadata");
}

}  // namespace format

std::string Damage::toString() const {
  return fmt::format("byte offset {}: {}", offset, what);
}

namespace {

// ---- byte sources ----------------------------------------------------------------------------

class FileSource final : public Source {
 public:
  FileSource(int fd, std::string path) : fd_(fd), path_(std::move(path)) {}
  ~FileSource() override { ::close(fd_); }
  Status read(std::uint64_t offset, std::size_t n, std::uint8_t* out) const override {
    std::size_t done = 0;
    while (done < n) {
      const ssize_t r = ::pread(fd_, out + done, n - done, static_cast<off_t>(offset + done));
      if (r < 0) {
        if (errno == EINTR) continue;
        return ioError("reading '{}' at byte offset {}: {}", path_, offset + done,
                       std::strerror(errno));
      }
      if (r == 0)
        return corrupt(
            fmt::format("'{}' ends at byte offset {} while {} bytes were expected "
                        "there (the file shrank while being read?)",
                        path_, offset + done, n - done));
      done += static_cast<std::size_t>(r);
    }
    return Status::ok();
  }

 private:
  int fd_;
  std::string path_;
};

class MemorySource final : public Source {
 public:
  explicit MemorySource(std::vector<std::uint8_t> bytes) : bytes_(std::move(bytes)) {
    size = bytes_.size();
  }
  Status read(std::uint64_t offset, std::size_t n, std::uint8_t* out) const override {
    if (offset > bytes_.size() || n > bytes_.size() - offset)
      return corrupt(fmt::format("read of {} bytes at byte offset {} beyond the end ({})", n,
                                 offset, bytes_.size()));
    if (n) std::memcpy(out, bytes_.data() + offset, n);
    return Status::ok();
  }

 private:
  std::vector<std::uint8_t> bytes_;
};

// What the first bytes of a non-MCAP file look like, to say so in the error.
std::string describeSignature(const std::uint8_t* b, std::size_t n) {
  auto starts = [&](std::string_view sig) {
    return n >= sig.size() && std::memcmp(b, sig.data(), sig.size()) == 0;
  };
  if (starts("\x89PNG")) return " (it looks like a PNG image)";
  if (starts("\xFF\xD8\xFF")) return " (it looks like a JPEG image)";
  if (starts("#ROSBAG")) return " (it looks like a ROS 1 bag)";
  if (starts("SQLite format")) return " (it looks like an SQLite database, e.g. a ROS 2 .db3 bag)";
  if (starts("\x1F\x8B")) return " (it looks like a gzip file)";
  if (starts("PK\x03\x04")) return " (it looks like a zip archive)";
  if (starts("\x89MCAP")) return " (an MCAP file of another major version)";
  if (n > 0 && (b[0] == '{' || b[0] == '[')) return " (it looks like JSON text)";
  return "";
}

std::string hexBytes(const std::uint8_t* b, std::size_t n) {
  std::string s;
  for (std::size_t i = 0; i < n; ++i) s += fmt::format("{}{:02X}", i ? " " : "", b[i]);
  return s;
}
}  // namespace

Status McapReader::Impl::readHeader() {
  const std::uint64_t size = source->size;
  if (size == 0) return fileError("the file is empty (0 bytes); expected an MCAP file");
  std::uint8_t magic[8];
  const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(size, 8));
  CDFF_RETURN_IF_ERROR(source->read(0, n, magic));
  if (n < 8 || std::memcmp(magic, kMagic, 8) != 0) {
    if (n < 8 && std::memcmp(magic, kMagic, n) == 0)
      return fileError(
          fmt::format("the file is {} bytes long, truncated inside the 8-byte MCAP magic", size));
    return fileError(fmt::format(
        "not an MCAP file: bytes 0-{} are {}{}; expected the MCAP magic 89 4D 43 41 50 30 0D 0A",
        n - 1, hexBytes(magic, n), describeSignature(magic, n)));
  }
  if (size < 8 + kRecordPrefix)
    return fileError(
        fmt::format("truncated at byte offset {}: the file ends before its Header record", size));
  std::uint8_t prefix[kRecordPrefix];
  CDFF_RETURN_IF_ERROR(source->read(8, kRecordPrefix, prefix));
  std::uint64_t length = 0;
  std::memcpy(&length, prefix + 1, 8);
  if (prefix[0] != kHeader)
    return fileError(fmt::format(
        "byte offset 8: expected the Header record (opcode 0x01), found opcode 0x{:02X} ({})",
        prefix[0], opcodeName(prefix[0])));
  if (length > size - 8 - kRecordPrefix)
    return fileError(
        fmt::format("byte offset 8: the Header record claims {} bytes but the file has {} after it "
                    "(truncated?)",
                    length, size - 8 - kRecordPrefix));
  if (length > (64u << 20))
    return fileError(fmt::format("byte offset 8: implausible Header record length {}", length));
  ByteVector body;
  CDFF_RETURN_IF_ERROR(readAt(8 + kRecordPrefix, static_cast<std::size_t>(length), body));
  Cursor c(body.data(), body.size(), 8 + kRecordPrefix);
  if (!c.string(profile, "Header profile") || !c.string(library, "Header library"))
    return fileError(c.error());
  header_end = 8 + kRecordPrefix + length;
  return Status::ok();
}

Status McapReader::Impl::open() {
  CDFF_RETURN_IF_ERROR(readHeader());
  std::string why;
  std::uint64_t why_offset = 0;
  const Summary summary = readSummary(why, why_offset);
  if (summary == Summary::kRead) {
    recovery.indexed = true;
    recovery.intact_bytes = source->size;
    return Status::ok();
  }
  schemas.clear();
  channels.clear();
  chunks.clear();
  attachments.clear();
  metadata.clear();
  stats = {};
  scan();
  // A truncated file reports where its data section breaks (from the scan); a bad summary in
  // an otherwise sound file is reported as such.
  if (summary == Summary::kDamaged)
    recovery.damages.insert(recovery.damages.begin(), {why_offset, why});
  if (summary == Summary::kNoFooter && recovery.damages.empty())
    addDamage(source->size,
              "the file ends after its data section but without a complete summary "
              "and footer (truncated): every message is intact, the index is lost");
  recovery.intact_bytes = recovery.damages.empty() ? source->size : recovery.damages.front().offset;
  return Status::ok();
}

McapReader::McapReader() = default;
McapReader::~McapReader() = default;

Status McapReader::open(const std::string& path, const McapReaderOptions& options) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return ioError("cannot open '{}': {}", path, std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    return ioError("'{}' is not a regular file", path);
  }
  auto impl = std::make_shared<Impl>();
  impl->path = path;
  impl->options = options;
  impl->source = std::make_unique<FileSource>(fd, path);
  impl->source->size = static_cast<std::uint64_t>(st.st_size);
  CDFF_RETURN_IF_ERROR(impl->open());
  impl_ = std::move(impl);
  return Status::ok();
}

Status McapReader::openBuffer(std::vector<std::uint8_t> bytes, const std::string& name,
                              const McapReaderOptions& options) {
  auto impl = std::make_shared<Impl>();
  impl->path = name;
  impl->options = options;
  impl->source = std::make_unique<MemorySource>(std::move(bytes));
  CDFF_RETURN_IF_ERROR(impl->open());
  impl_ = std::move(impl);
  return Status::ok();
}

namespace {
const std::string kEmptyString;
const std::map<std::uint16_t, Schema> kNoSchemas;
const std::map<std::uint16_t, Channel> kNoChannels;
const Statistics kNoStatistics;
const std::vector<ChunkInfo> kNoChunks;
const std::vector<AttachmentInfo> kNoAttachments;
const std::vector<MetadataInfo> kNoMetadata;
const RecoveryReport kNoRecovery;
}  // namespace

const std::string& McapReader::path() const {
  return impl_ ? impl_->path : kEmptyString;
}
std::uint64_t McapReader::fileSize() const {
  return impl_ ? impl_->source->size : 0;
}
const std::string& McapReader::profile() const {
  return impl_ ? impl_->profile : kEmptyString;
}
const std::string& McapReader::library() const {
  return impl_ ? impl_->library : kEmptyString;
}
const std::map<std::uint16_t, Schema>& McapReader::schemas() const {
  return impl_ ? impl_->schemas : kNoSchemas;
}
const std::map<std::uint16_t, Channel>& McapReader::channels() const {
  return impl_ ? impl_->channels : kNoChannels;
}
const Channel* McapReader::channel(std::string_view topic) const {
  if (!impl_) return nullptr;
  for (const auto& [id, c] : impl_->channels)
    if (c.topic == topic) return &c;
  return nullptr;
}
const Schema* McapReader::schemaOf(const Channel& channel) const {
  if (!impl_ || channel.schema_id == 0) return nullptr;
  auto it = impl_->schemas.find(channel.schema_id);
  return it == impl_->schemas.end() ? nullptr : &it->second;
}
const Statistics& McapReader::statistics() const {
  return impl_ ? impl_->stats : kNoStatistics;
}
const std::vector<ChunkInfo>& McapReader::chunks() const {
  return impl_ ? impl_->chunks : kNoChunks;
}
const std::vector<AttachmentInfo>& McapReader::attachments() const {
  return impl_ ? impl_->attachments : kNoAttachments;
}
const std::vector<MetadataInfo>& McapReader::metadata() const {
  return impl_ ? impl_->metadata : kNoMetadata;
}
const RecoveryReport& McapReader::recovery() const {
  return impl_ ? impl_->recovery : kNoRecovery;
}

Result<std::vector<std::uint8_t>> McapReader::readAttachment(const AttachmentInfo& a) const {
  if (!impl_) return Status{StatusCode::kInvalidInput, "MCAP reader is not open"};
  if (a.offset > impl_->source->size || a.length > impl_->source->size - a.offset ||
      a.length > impl_->options.max_chunk_bytes)
    return impl_->fileError(
        fmt::format("attachment '{}' at byte offset {} (+{}) lies outside "
                    "the file",
                    a.name, a.offset, a.length));
  ByteVector rec;
  CDFF_RETURN_IF_ERROR(impl_->readAt(a.offset, static_cast<std::size_t>(a.length), rec));
  Cursor c(rec.data(), rec.size(), a.offset);
  std::uint8_t op = 0;
  std::uint64_t len = 0, log_time = 0, create_time = 0;
  std::string name, media_type;
  Bytes data;
  std::uint32_t crc = 0;
  if (!c.read(op, "Attachment opcode") || !c.read(len, "Attachment length") || op != kAttachment)
    return impl_->fileError(fmt::format("byte offset {}: expected an Attachment record", a.offset));
  const std::size_t content_start = c.position();
  if (!c.read(log_time, "Attachment log time") || !c.read(create_time, "Attachment create time") ||
      !c.string(name, "Attachment name") || !c.string(media_type, "Attachment media type") ||
      !c.bytes64(data, "Attachment data"))
    return impl_->fileError(c.error());
  const std::size_t crc_at = c.position();
  if (!c.read(crc, "Attachment CRC")) return impl_->fileError(c.error());
  if (crc != 0 && impl_->options.verify_crcs) {
    const std::uint32_t actual = crc32Update(0, rec.data() + content_start, crc_at - content_start);
    if (actual != crc)
      return impl_->fileError(
          fmt::format("byte offset {}: attachment '{}' CRC mismatch (0x{:08X}, "
                      "expected 0x{:08X})",
                      a.offset, name, actual, crc));
  }
  return std::vector<std::uint8_t>(data.begin(), data.end());
}

Result<std::map<std::string, std::string>> McapReader::readMetadata(const MetadataInfo& m) const {
  if (!impl_) return Status{StatusCode::kInvalidInput, "MCAP reader is not open"};
  if (m.offset > impl_->source->size || m.length > impl_->source->size - m.offset ||
      m.length > impl_->options.max_chunk_bytes)
    return impl_->fileError(
        fmt::format("metadata '{}' at byte offset {} lies outside the file", m.name, m.offset));
  ByteVector rec;
  CDFF_RETURN_IF_ERROR(impl_->readAt(m.offset, static_cast<std::size_t>(m.length), rec));
  Cursor c(rec.data(), rec.size(), m.offset);
  std::uint8_t op = 0;
  std::uint64_t len = 0;
  std::string name;
  std::map<std::string, std::string> values;
  if (!c.read(op, "Metadata opcode") || !c.read(len, "Metadata length") || op != kMetadata)
    return impl_->fileError(fmt::format("byte offset {}: expected a Metadata record", m.offset));
  if (!c.string(name, "Metadata name") || !c.stringMap(values, "Metadata values"))
    return impl_->fileError(c.error());
  return values;
}

std::vector<Damage> McapReader::verify(bool chunks) const {
  std::vector<Damage> damages;
  if (!impl_) return damages;
  const Impl& r = *impl_;
  Decompressor d;
  for (const ChunkInfo& chunk : r.chunks) {
    if (!chunks) break;
    std::shared_ptr<ByteVector> storage;
    Bytes records;
    std::string error = r.loadChunk(chunk, d, storage, records);
    if (error.empty()) {
      std::uint16_t unknown = 0;
      bool has_unknown = false;
      error = parseRecords(
          records,
          [&](std::size_t, std::uint16_t channel, std::uint32_t, std::uint64_t, std::uint64_t,
              Bytes) {
            if (!r.channels.count(channel) && !has_unknown) {
              has_unknown = true;
              unknown = channel;
            }
          },
          [](std::size_t, Schema) {}, [](std::size_t, Channel) {});
      if (error.empty() && has_unknown)
        error =
            fmt::format("a message is on channel id {}, which no Channel record defines", unknown);
    }
    if (!error.empty()) damages.push_back({chunk.offset, error});
  }
  if (r.recovery.indexed && r.data_section_crc != 0 && r.options.verify_crcs && r.data_end > 0) {
    ByteVector block;
    std::uint32_t crc = 0;
    for (std::uint64_t at = 0; at < r.data_end;) {
      const std::size_t n =
          static_cast<std::size_t>(std::min<std::uint64_t>(4u << 20, r.data_end - at));
      if (Status s = r.readAt(at, n, block); !s.isOk()) {
        damages.push_back({at, s.message()});
        return damages;
      }
      crc = crc32Update(crc, block.data(), n);
      at += n;
    }
    if (crc != r.data_section_crc)
      damages.push_back({r.data_end, fmt::format("data section CRC mismatch: bytes [0, {}) have "
                                                 "CRC 0x{:08X}, the Data End record says 0x{:08X}",
                                                 r.data_end, crc, r.data_section_crc)});
  }
  return damages;
}

}  // namespace cdff::io
