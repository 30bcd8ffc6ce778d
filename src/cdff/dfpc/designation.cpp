#include "cdff/dfpc/designation.hpp"

#include <charconv>
#include <cmath>

namespace cdff::dfpc {
namespace {

bool parseNumber(std::string_view text, double& out) {
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, out);
  return ec == std::errc() && ptr == end && std::isfinite(out);
}

}  // namespace

Result<Designation> parseDesignation(const std::string& text) {
  const auto expected = [&](std::string_view what) {
    return invalidInput(
        "designation '{}': {}; expected X,Y,W,H@TIME (the box's corner and size in pixels, the "
        "time in seconds from the start), e.g. 500,490,24,24@0",
        text, what);
  };
  const std::size_t at = text.find('@');
  if (at == std::string::npos) return expected("no '@TIME'");
  std::vector<double> box;
  std::string_view numbers(text.data(), at);
  while (true) {
    const std::size_t comma = numbers.find(',');
    double v = 0;
    if (!parseNumber(numbers.substr(0, comma), v))
      return expected(fmt::format("'{}' is not a number", numbers.substr(0, comma)));
    box.push_back(v);
    if (comma == std::string_view::npos) break;
    numbers.remove_prefix(comma + 1);
  }
  if (box.size() != 4) return expected(fmt::format("{} numbers before '@'", box.size()));
  if (box[2] < 1 || box[3] < 1 || box[2] != std::floor(box[2]) || box[3] != std::floor(box[3]))
    return expected(fmt::format("size {}x{}", box[2], box[3]));
  Designation d;
  if (!parseNumber(std::string_view(text).substr(at + 1), d.time_s) || d.time_s < 0)
    return expected(fmt::format("time '{}'", text.substr(at + 1)));
  d.region = ImageRegion::box(box[0], box[1], static_cast<int>(box[2]), static_cast<int>(box[3]));
  d.region.source = "user";
  return d;
}

namespace {

/// Another stream, not owned.
class Borrowed final : public InputStream {
 public:
  explicit Borrowed(InputStream& input) : input_(input) {}
  Result<std::optional<Message>> next() override { return input_.next(); }
  std::vector<ChannelInfo> channels() const override { return input_.channels(); }
  std::optional<std::pair<Timestamp, Timestamp>> timeRange() const override {
    return input_.timeRange();
  }

 private:
  InputStream& input_;
};

}  // namespace

std::unique_ptr<InputStream> withMessages(InputStream& input, std::vector<Message> extra) {
  std::vector<std::unique_ptr<InputStream>> streams;
  streams.push_back(std::make_unique<MemoryStream>(std::move(extra)));
  streams.push_back(std::make_unique<Borrowed>(input));
  return std::make_unique<MergedStream>(std::move(streams));
}

}  // namespace cdff::dfpc
