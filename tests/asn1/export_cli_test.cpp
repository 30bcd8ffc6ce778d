// `cdff log export --asn1-uper`: a recording of every type becomes one uPER file per message of
// the types with an ASN.1 type, listed in index.csv; each file decodes to the recorded value
// (its MCAP message equal, except an image's row padding); a channel asked for without an
// ASN.1 type is an error.
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>

#include "cdff/asn1/uper.hpp"
#include "cdff/io/replay.hpp"
#include "samples.hpp"
#include "support/command.hpp"

namespace cdff::asn1 {
namespace {

namespace fs = std::filesystem;
using cdff::testing::runCdff;

std::vector<std::uint8_t> readBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::vector<std::uint8_t> messageOf(const Value& v) {
  codec::Encoded e;
  EXPECT_TRUE(v.type().info().encode(v.raw(), 0, e).isOk());
  return e.flatten();
}

// The recording's values per channel, in order, with images packed (the ASN.1 rows are).
std::map<std::string, std::vector<Value>> recordedValues(const std::string& path) {
  std::map<std::string, std::vector<Value>> values;
  io::Replay replay;
  EXPECT_TRUE(replay.open({path}).isOk());
  while (replay.next()) {
    if (!hasAsn1Type(replay.message().type())) continue;
    Result<Value> v = replay.message().decode();
    EXPECT_TRUE(v.isOk()) << v.status().message();
    values[replay.message().channel()].push_back(*v);
  }
  return values;
}

TEST(Asn1ExportCli, EveryConvertibleMessageBecomesAFileThatDecodesToItsValue) {
  const fs::path dir = cdff::testing::scratchDirectory("cdff_asn1_export");
  const std::string input = (dir / "in.mcap").string(), out = (dir / "uper").string();
  {
    io::Recorder recorder;
    ASSERT_TRUE(recorder.open(input).isOk());
    for (int i = 0; i < 3; ++i) {
      const cdff::testing::IoSamples s = cdff::testing::makeIoSamples(i, 1000 + i * 100'000);
      ASSERT_TRUE(cdff::testing::writeIoSamples(recorder, s, 1000 + i * 100'000).isOk());
    }
    ASSERT_TRUE(recorder.close().isOk());
  }
  fs::remove_all(out);
  auto r = runCdff("log export --asn1-uper " + out + " " + input);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("not exported: /chaser/imu (ImuSample has no ASN.1 type)"),
            std::string::npos)
      << r.output;

  std::map<std::string, std::vector<Value>> recorded = recordedValues(input);
  std::ifstream index(fs::path(out) / "index.csv");
  std::string line;
  std::getline(index, line);
  EXPECT_EQ(line, "channel,index,log_time_ns,asn1_type,bytes,file");
  std::map<std::string, std::size_t> rows;
  while (std::getline(index, line)) {
    std::vector<std::string> f;
    std::stringstream fields(line);
    for (std::string part; std::getline(fields, part, ',');) f.push_back(part);
    ASSERT_EQ(f.size(), 6u) << line;
    const std::vector<std::uint8_t> bytes = readBytes(fs::path(out) / f[5]);
    EXPECT_EQ(std::to_string(bytes.size()), f[4]);
    std::optional<Asn1Type> type = asn1TypeNamed(f[3]);
    ASSERT_TRUE(type) << line;
    Result<Value> v = decode(*type, bytes);
    ASSERT_TRUE(v.isOk()) << line << ": " << v.status().message();
    const std::size_t i = rows[f[0]]++;
    ASSERT_EQ(std::to_string(i), f[1]);
    ASSERT_LT(i, recorded[f[0]].size()) << line;
    const Value& original = recorded[f[0]][i];
    if (const Image* image = original.get<Image>()) {
      const Image& back = *v->get<Image>();
      ASSERT_EQ(back.width, image->width);
      ASSERT_EQ(back.height, image->height);
      const std::size_t row = static_cast<std::size_t>(image->width) * bytesPerPixel(image->format);
      for (int y = 0; y < image->height; ++y)
        ASSERT_EQ(std::memcmp(back.row(y), image->row(y), row), 0) << line << " row " << y;
    } else {
      EXPECT_EQ(messageOf(*v), messageOf(original)) << line;
    }
  }
  ASSERT_FALSE(rows.empty());
  for (const auto& [channel, values] : recorded) EXPECT_EQ(rows[channel], values.size()) << channel;

  r = runCdff("log export --asn1-uper " + out + " " + input + " -c /chaser/imu");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("channel '/chaser/imu' at 1000000 ns: ImuSample has no ASN.1 type"),
            std::string::npos)
      << r.output;
}

}  // namespace
}  // namespace cdff::asn1
