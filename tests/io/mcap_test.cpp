// The MCAP writer and reader: round trips, ordering, seeks, damaged files.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>

#include "cdff/io/crc32.hpp"
#include "cdff/io/mcap.hpp"

namespace cdff::io {
namespace {

namespace fs = std::filesystem;

fs::path tempDir() {
  return fs::temp_directory_path() / ("cdff_mcap_test_" + std::to_string(::getpid()));
}

std::string tempPath(const std::string& name) {
  fs::create_directories(tempDir());
  return (tempDir() / name).string();
}

class RemoveTempDir : public ::testing::Environment {
 public:
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(tempDir(), ignored);
  }
};
const auto* const kCleanup = ::testing::AddGlobalTestEnvironment(new RemoveTempDir);

std::vector<std::uint8_t> readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

struct Written {
  std::uint16_t channel;
  std::uint64_t log_time;
  std::vector<std::uint8_t> data;
};

// A payload whose bytes say which message it is (so a mix-up cannot go unnoticed), partly
// compressible.
std::vector<std::uint8_t> payload(std::size_t i, std::size_t size) {
  std::vector<std::uint8_t> d(size);
  std::mt19937 rng(static_cast<std::uint32_t>(i));
  for (std::size_t k = 0; k < size; ++k)
    d[k] = k % 4 == 0 ? static_cast<std::uint8_t>(rng()) : static_cast<std::uint8_t>(i + k / 64);
  return d;
}

// Writes `count` messages over three channels; returns them in the order written.
std::vector<Written> writeSample(const std::string& path, const McapWriterOptions& options,
                                 std::size_t count, std::size_t size = 3000) {
  McapWriter w;
  EXPECT_TRUE(w.open(path, options).isOk());
  const std::vector<std::uint8_t> schema_data = {'{', '}'};
  const auto schema = w.addSchema("test.Blob", "jsonschema", schema_data);
  EXPECT_TRUE(schema.isOk());
  std::vector<std::uint16_t> ids;
  for (const char* topic : {"/a", "/b", "/c"}) {
    auto id = w.addChannel(topic, "json", *schema, {{"k", topic}});
    EXPECT_TRUE(id.isOk());
    ids.push_back(*id);
  }
  std::vector<Written> written;
  for (std::size_t i = 0; i < count; ++i) {
    const std::uint16_t ch = ids[i % 3];
    const std::uint64_t t = 1'000'000'000ull + i * 10'000'000ull;
    Written m{ch, t, payload(i, size + (i % 7) * 100)};
    EXPECT_TRUE(w.write(ch, t, t + 1, m.data).isOk());
    written.push_back(std::move(m));
  }
  EXPECT_TRUE(w.close().isOk());
  return written;
}

std::vector<Written> readAll(const McapReader& r, const ReadOptions& options = {},
                             Status* status = nullptr) {
  std::vector<Written> out;
  MessageIterator it = r.messages(options);
  while (it.next()) {
    const MessageView& m = it.message();
    out.push_back({m.channel->id, m.log_time, {m.data.begin(), m.data.end()}});
  }
  if (status) *status = it.status();
  return out;
}

TEST(Crc32, KnownValuesAndCombine) {
  const std::string check = "123456789";
  EXPECT_EQ(crc32Update(0, check.data(), check.size()), 0xCBF43926u);
  EXPECT_EQ(crc32Update(0, nullptr, 0), 0u);
  const auto data = payload(3, 100'003);
  const std::uint32_t whole = crc32(data);
  for (std::size_t split : {0ul, 1ul, 15ul, 16ul, 17ul, 50'000ul, 100'003ul}) {
    const std::uint32_t a = crc32Update(0, data.data(), split);
    EXPECT_EQ(crc32Update(a, data.data() + split, data.size() - split), whole) << split;
    const std::uint32_t b = crc32Update(0, data.data() + split, data.size() - split);
    EXPECT_EQ(crc32Combine(a, b, data.size() - split), whole) << split;
  }
}

class McapRoundTrip : public ::testing::TestWithParam<Compression> {};

TEST_P(McapRoundTrip, EveryMessageComesBackInOrderWithIndexAndStatistics) {
  McapWriterOptions options;
  options.compression = GetParam();
  options.chunk_size = 20'000;  // many chunks
  const std::string path = tempPath(std::string("roundtrip_") + toString(GetParam()) + ".mcap");
  const auto written = writeSample(path, options, 300);

  McapReader r;
  ASSERT_TRUE(r.open(path).isOk());
  EXPECT_TRUE(r.recovery().indexed);
  EXPECT_FALSE(r.recovery().damaged());
  EXPECT_EQ(r.library(), "cdff");
  ASSERT_EQ(r.channels().size(), 3u);
  ASSERT_EQ(r.schemas().size(), 1u);
  EXPECT_EQ(r.schemas().begin()->second.name, "test.Blob");
  EXPECT_EQ(r.channel("/b")->metadata.at("k"), "/b");
  EXPECT_EQ(r.statistics().message_count, 300u);
  EXPECT_EQ(r.statistics().channel_message_counts.at(r.channel("/a")->id), 100u);
  EXPECT_EQ(r.statistics().message_start_time, written.front().log_time);
  EXPECT_EQ(r.statistics().message_end_time, written.back().log_time);
  EXPECT_GT(r.chunks().size(), 10u);
  EXPECT_EQ(r.statistics().chunk_count, r.chunks().size());
  for (const ChunkInfo& c : r.chunks()) {
    EXPECT_EQ(c.compression, GetParam());
  }

  const auto read = readAll(r);
  ASSERT_EQ(read.size(), written.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    EXPECT_EQ(read[i].channel, written[i].channel) << i;
    EXPECT_EQ(read[i].log_time, written[i].log_time) << i;
    EXPECT_EQ(read[i].data, written[i].data) << i;
  }
  EXPECT_TRUE(r.verify().empty());
}

INSTANTIATE_TEST_SUITE_P(Compressions, McapRoundTrip,
                         ::testing::Values(Compression::kNone, Compression::kLz4,
                                           Compression::kZstd),
                         [](const auto& info) { return std::string(toString(info.param)); });

TEST(Mcap, OutOfOrderTimesAreMergedAcrossChunks) {
  McapWriterOptions options;
  options.chunk_size = 2'000;
  options.chunk_duration_ns = 0;
  const std::string path = tempPath("unordered.mcap");
  McapWriter w;
  ASSERT_TRUE(w.open(path, options).isOk());
  const auto ch = w.addChannel("/x", "raw", 0);
  ASSERT_TRUE(ch.isOk());
  std::vector<std::uint64_t> times;
  std::mt19937 rng(7);
  for (int i = 0; i < 400; ++i) {
    const std::uint64_t t = rng() % 1000;  // with many ties
    times.push_back(t);
    const auto d = payload(static_cast<std::size_t>(i), 100);
    ASSERT_TRUE(w.write(*ch, t, t, d).isOk());
  }
  ASSERT_TRUE(w.close().isOk());
  McapReader r;
  ASSERT_TRUE(r.open(path).isOk());
  std::vector<std::uint64_t> got;
  std::vector<std::uint32_t> seqs;
  auto it = r.messages();
  while (it.next()) {
    got.push_back(it.message().log_time);
    seqs.push_back(it.message().sequence);
  }
  ASSERT_TRUE(it.status().isOk());
  std::vector<std::uint64_t> sorted = times;
  std::sort(sorted.begin(), sorted.end());
  EXPECT_EQ(got, sorted);
  // Ties keep the writing order (the sequence numbers count the writes).
  for (std::size_t i = 1; i < got.size(); ++i)
    if (got[i] == got[i - 1]) {
      EXPECT_LT(seqs[i - 1], seqs[i]);
    }
}

TEST(Mcap, TimeRangeSeekReadsOnlyTheChunksItNeeds) {
  McapWriterOptions options;
  options.chunk_size = 10'000;
  const std::string path = tempPath("seek.mcap");
  const auto written = writeSample(path, options, 600, 1000);
  McapReader r;
  ASSERT_TRUE(r.open(path).isOk());
  const std::size_t chunks = r.chunks().size();
  ASSERT_GT(chunks, 40u);
  ReadOptions o;
  o.start_time = written[300].log_time;
  o.end_time = written[320].log_time;
  auto it = r.messages(o);
  std::size_t n = 0;
  std::uint64_t first = 0, last = 0;
  while (it.next()) {
    if (n == 0) first = it.message().log_time;
    last = it.message().log_time;
    ++n;
  }
  EXPECT_EQ(n, 21u);
  EXPECT_EQ(first, written[300].log_time);
  EXPECT_EQ(last, written[320].log_time);
  EXPECT_LE(it.chunksLoaded(), 4u) << "of " << chunks;

  ReadOptions only_b;
  only_b.channels = {r.channel("/b")->id};
  const auto b = readAll(r, only_b);
  EXPECT_EQ(b.size(), 200u);
  for (const auto& m : b) EXPECT_EQ(m.channel, r.channel("/b")->id);
}

TEST(Mcap, AttachmentsAndMetadataRoundTrip) {
  const std::string path = tempPath("attach.mcap");
  McapWriter w;
  ASSERT_TRUE(w.open(path).isOk());
  const std::vector<std::uint8_t> blob = payload(1, 5000);
  ASSERT_TRUE(w.writeAttachment("target.obj", "model/obj", 42, blob).isOk());
  ASSERT_TRUE(w.writeMetadata("run", {{"scenario", "approach"}, {"seed", "7"}}).isOk());
  ASSERT_TRUE(w.close().isOk());
  McapReader r;
  ASSERT_TRUE(r.open(path).isOk());
  ASSERT_EQ(r.attachments().size(), 1u);
  EXPECT_EQ(r.attachments()[0].name, "target.obj");
  EXPECT_EQ(r.attachments()[0].media_type, "model/obj");
  EXPECT_EQ(r.attachments()[0].log_time, 42u);
  auto data = r.readAttachment(r.attachments()[0]);
  ASSERT_TRUE(data.isOk()) << data.status().toString();
  EXPECT_EQ(*data, blob);
  ASSERT_EQ(r.metadata().size(), 1u);
  auto md = r.readMetadata(r.metadata()[0]);
  ASSERT_TRUE(md.isOk());
  EXPECT_EQ(md->at("scenario"), "approach");
  EXPECT_EQ(r.statistics().message_count, 0u);
  EXPECT_EQ(r.statistics().attachment_count, 1u);
}

TEST(Mcap, WriterRefusesBadCalls) {
  McapWriter w;
  EXPECT_FALSE(w.write(1, 0, 0, Bytes{}).isOk());
  const std::string path = tempPath("refuse.mcap");
  ASSERT_TRUE(w.open(path).isOk());
  EXPECT_EQ(w.write(3, 0, 0, Bytes{}).code(), StatusCode::kInvalidInput);
  EXPECT_FALSE(w.addChannel("/x", "json", 9).isOk());
  ASSERT_TRUE(w.addChannel("/x", "json", 0).isOk());
  EXPECT_FALSE(w.addChannel("/x", "json", 0).isOk());
  ASSERT_TRUE(w.close().isOk());
  McapWriter bad;
  const Status s = bad.open("/nonexistent-dir/x.mcap");
  EXPECT_EQ(s.code(), StatusCode::kIoError);
  EXPECT_NE(s.message().find("/nonexistent-dir/x.mcap"), std::string::npos);
}

// ---- damaged files ---------------------------------------------------------------------------

TEST(McapDamage, EmptyShortAndForeignFilesAreRefusedWithTheReason) {
  McapReader r;
  Status s = r.openBuffer({}, "empty.mcap");
  EXPECT_EQ(s.code(), StatusCode::kCorruptData);
  EXPECT_NE(s.message().find("empty (0 bytes)"), std::string::npos) << s.message();

  const std::vector<std::uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n', 0, 0, 0, 13};
  s = r.openBuffer(png, "image.mcap");
  EXPECT_EQ(s.code(), StatusCode::kCorruptData);
  EXPECT_NE(s.message().find("not an MCAP file"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("PNG"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("bytes 0-7"), std::string::npos) << s.message();

  s = r.openBuffer({0x89, 'M', 'C'}, "short.mcap");
  EXPECT_NE(s.message().find("truncated inside the 8-byte MCAP magic"), std::string::npos)
      << s.message();

  s = r.open("/nonexistent/file.mcap");
  EXPECT_EQ(s.code(), StatusCode::kIoError);
}

// Messages recovered from a damaged copy must be exactly the first ones written (all those in
// chunks before the damage), byte for byte.
void expectPrefixOf(const std::vector<Written>& got, const std::vector<Written>& written) {
  ASSERT_LE(got.size(), written.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    ASSERT_EQ(got[i].log_time, written[i].log_time) << i;
    ASSERT_EQ(got[i].data, written[i].data) << i;
  }
}

TEST(McapDamage, TruncationAtEveryChunkBoundaryAndInsideKeepsEveryFinishedChunk) {
  for (Compression compression : {Compression::kNone, Compression::kZstd}) {
    McapWriterOptions options;
    options.compression = compression;
    options.chunk_size = 8'000;
    const std::string path = tempPath("truncate.mcap");
    const auto written = writeSample(path, options, 120, 1500);
    const auto bytes = readFile(path);
    McapReader sound;
    ASSERT_TRUE(sound.open(path).isOk());
    const auto chunks = sound.chunks();
    ASSERT_GT(chunks.size(), 8u);

    // Cut points: each chunk start, inside each chunk, just after each chunk's message indexes,
    // inside the summary and the footer.
    std::vector<std::uint64_t> cuts;
    for (const ChunkInfo& c : chunks) {
      cuts.push_back(c.offset);
      cuts.push_back(c.offset + 5);
      cuts.push_back(c.offset + c.length / 2);
      cuts.push_back(c.offset + c.length);  // before its message indexes
    }
    cuts.push_back(bytes.size() - 1);
    cuts.push_back(bytes.size() - 20);
    cuts.push_back(bytes.size() - 200);
    for (std::uint64_t cut : cuts) {
      std::vector<std::uint8_t> truncated(bytes.begin(), bytes.begin() + static_cast<long>(cut));
      McapReader r;
      const Status s = r.openBuffer(truncated, "cut.mcap");
      ASSERT_TRUE(s.isOk()) << cut << ": " << s.toString();
      // Chunks entirely before the cut are kept, the others are not.
      std::size_t expected = 0;
      for (const ChunkInfo& c : chunks) {
        if (c.offset + c.length > cut) continue;
        ReadOptions window;
        window.start_time = c.message_start_time;
        window.end_time = c.message_end_time;
        auto it = sound.messages(window);
        while (it.next()) ++expected;
      }
      Status it_status;
      const auto got = readAll(r, {}, &it_status);
      EXPECT_TRUE(it_status.isOk()) << cut << ": " << it_status.toString();
      expectPrefixOf(got, written);
      EXPECT_EQ(got.size(), expected) << "cut at " << cut;
      EXPECT_FALSE(r.recovery().indexed) << cut;
      ASSERT_TRUE(r.recovery().damaged()) << cut;
      // The damage is reported at the start of the first incomplete record, at or before the cut.
      const Damage& first = r.recovery().damages.front();
      EXPECT_LE(first.offset, cut) << first.toString();
      for (const ChunkInfo& c : chunks) {
        if (c.offset < cut && cut < c.offset + c.length) {
          EXPECT_EQ(first.offset, c.offset) << cut << ": " << first.toString();
        }
      }
      EXPECT_EQ(r.recovery().intact_bytes, first.offset);
    }
  }
}

TEST(McapDamage, BitFlipInAChunkIsReportedAndTheOtherChunksAreDelivered) {
  for (Compression compression : {Compression::kNone, Compression::kLz4, Compression::kZstd}) {
    McapWriterOptions options;
    options.compression = compression;
    options.chunk_size = 8'000;
    const std::string path = tempPath("flip.mcap");
    const auto written = writeSample(path, options, 90, 1500);
    auto bytes = readFile(path);
    McapReader sound;
    ASSERT_TRUE(sound.open(path).isOk());
    const ChunkInfo victim = sound.chunks()[3];
    std::size_t victim_messages = 0;
    {
      ReadOptions window;
      window.start_time = victim.message_start_time;
      window.end_time = victim.message_end_time;
      auto it = sound.messages(window);
      while (it.next()) ++victim_messages;
    }
    // Flip one bit in the middle of the chunk's records.
    bytes[victim.offset + victim.length - victim.compressed_size / 2] ^= 0x10;

    McapReader r;
    ASSERT_TRUE(r.openBuffer(bytes, "flip.mcap").isOk());
    EXPECT_TRUE(r.recovery().indexed);  // the summary is intact
    Status status;
    const auto got = readAll(r, {}, &status);
    EXPECT_EQ(status.code(), StatusCode::kCorruptData) << toString(compression);
    EXPECT_NE(status.message().find(fmt::format("byte offset {}", victim.offset)),
              std::string::npos)
        << status.message();
    EXPECT_EQ(got.size(), written.size() - victim_messages) << toString(compression);
    const auto damages = r.verify();
    ASSERT_FALSE(damages.empty());
    EXPECT_EQ(damages.front().offset, victim.offset);
  }
}

TEST(McapDamage, BitFlipInTheSummaryFallsBackToAScanThatKeepsEverything) {
  const std::string path = tempPath("flip_summary.mcap");
  McapWriterOptions options;
  options.chunk_size = 8'000;
  const auto written = writeSample(path, options, 60, 1500);
  auto bytes = readFile(path);
  bytes[bytes.size() - 100] ^= 0x01;  // in the summary
  McapReader r;
  ASSERT_TRUE(r.openBuffer(bytes, "flip.mcap").isOk());
  EXPECT_FALSE(r.recovery().indexed);
  ASSERT_TRUE(r.recovery().damaged());
  EXPECT_NE(r.recovery().damages.front().what.find("summary"), std::string::npos)
      << r.recovery().damages.front().toString();
  const auto got = readAll(r);
  EXPECT_EQ(got.size(), written.size());
  EXPECT_EQ(r.statistics().message_count, written.size());
}

TEST(McapDamage, BitFlipsAnywhereNeverCrashAndAreDetected) {
  const std::string path = tempPath("flip_any.mcap");
  McapWriterOptions options;
  options.chunk_size = 4'000;
  options.compression = Compression::kZstd;
  writeSample(path, options, 40, 700);
  const auto bytes = readFile(path);
  std::mt19937 rng(11);
  std::size_t detected = 0, trials = 0;
  for (std::size_t at = 0; at < bytes.size(); at += 1 + rng() % 97) {
    auto damaged = bytes;
    damaged[at] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
    ++trials;
    McapReader r;
    const Status s = r.openBuffer(damaged, "flip.mcap");
    if (!s.isOk()) {
      ++detected;
      EXPECT_NE(s.message().find("byte"), std::string::npos) << s.message();
      continue;
    }
    Status it_status;
    (void)readAll(r, {}, &it_status);
    const bool found = r.recovery().damaged() || !it_status.isOk() || !r.verify().empty();
    if (found) ++detected;
  }
  ::testing::Test::RecordProperty("flips", static_cast<int>(trials));
  ::testing::Test::RecordProperty("detected", static_cast<int>(detected));
  // Every flip lands in a CRC-protected byte except a few fields (e.g. timestamps in the
  // chunk header, or the library name), so nearly all are caught.
  EXPECT_GE(static_cast<double>(detected), 0.9 * static_cast<double>(trials))
      << detected << " of " << trials;
}

TEST(McapDamage, AKilledWriterLeavesEveryFinishedChunkReadable) {
  const std::string path = tempPath("killed.mcap");
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    McapWriterOptions options;
    options.chunk_size = 10'000;
    McapWriter w;
    if (!w.open(path, options).isOk()) ::_exit(3);
    auto ch = w.addChannel("/imu", "raw", 0);
    for (std::size_t i = 0; i < 100; ++i) {
      const auto d = payload(i, 1000);
      if (!w.write(*ch, i * 1000, i * 1000, d).isOk()) ::_exit(4);
    }
    ::raise(SIGKILL);  // dies without close(): no summary, and a chunk still in memory
    ::_exit(5);
  }
  int wstatus = 0;
  ASSERT_EQ(::waitpid(child, &wstatus, 0), child);
  ASSERT_TRUE(WIFSIGNALED(wstatus));
  McapReader r;
  ASSERT_TRUE(r.open(path).isOk());
  EXPECT_FALSE(r.recovery().indexed);
  ASSERT_TRUE(r.recovery().damaged());
  EXPECT_NE(r.recovery().damages.front().what.find("did not finish"), std::string::npos);
  EXPECT_EQ(r.recovery().damages.front().offset, fs::file_size(path));
  std::size_t n = 0;
  auto it = r.messages();
  while (it.next()) {
    EXPECT_EQ(it.message().log_time, n * 1000);
    EXPECT_EQ(std::vector<std::uint8_t>(it.message().data.begin(), it.message().data.end()),
              payload(n, 1000));
    ++n;
  }
  // Each 10 kB chunk holds 9 messages of ~1 kB: 99 were written in finished chunks.
  EXPECT_EQ(n, 99u);
}

}  // namespace
}  // namespace cdff::io
