#include "cdff/eval/draws.hpp"

#include <algorithm>

#include "cdff/schema/table.hpp"

namespace cdff::eval {

namespace {

// SplitMix64's finaliser: a well-mixed 64-bit function of the draw number, so that the
// initial error's stream shares nothing with the simulator's seed.
std::uint64_t mix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

Status readCount(const schema::Field& f, std::uint64_t& out, std::int64_t low) {
  std::int64_t v = 0;
  CDFF_RETURN_IF_ERROR(f.read(v, low, std::int64_t{1} << 48));
  out = static_cast<std::uint64_t>(v);
  return Status::ok();
}

Status readRange(const schema::Field& f, DrawRange& out) {
  static const schema::Table<DrawRange> table =
      schema::Table<DrawRange>("a range of draws")
          .required(
              "first",
              [](const schema::Field& g, DrawRange& r) { return readCount(g, r.first, 1); },
              "the first draw number (>= 1)")
          .required(
              "count",
              [](const schema::Field& g, DrawRange& r) { return readCount(g, r.count, 1); },
              "how many draws (>= 1)");
  return table.read(f, out);
}

}  // namespace

Draw drawOf(std::uint64_t number) {
  return {number, number, mix(number ^ 0x1417c0ffee5eedULL)};
}

std::vector<std::uint64_t> DrawRange::numbers() const {
  std::vector<std::uint64_t> out;
  for (std::uint64_t n = first; n < end(); ++n) out.push_back(n);
  return out;
}

std::vector<Draw> DrawSets::evaluationDraws(std::uint64_t n) const {
  const std::uint64_t count = n == 0 ? evaluation.count : std::min(n, evaluation.count);
  std::vector<Draw> out;
  for (std::uint64_t k = 0; k < count; ++k) out.push_back(drawOf(evaluation.first + k));
  return out;
}

std::vector<Draw> DrawSets::tuningDraws(std::uint64_t n) const {
  const std::uint64_t cap = std::min<std::uint64_t>(tuning.count, 10000);
  const std::uint64_t count = n == 0 ? cap : std::min(n, cap);
  std::vector<Draw> out;
  for (std::uint64_t k = 0; k < count; ++k) out.push_back(drawOf(tuning.first + k));
  return out;
}

Result<DrawSets> loadDrawSets(const std::string& path) {
  Result<schema::Document> document = schema::Document::loadFile(path, "draw-set file");
  if (!document) return document.status();
  static const schema::Table<DrawSets> table =
      schema::Table<DrawSets>("draw sets")
          .required(
              "tuning", [](const schema::Field& f, DrawSets& s) { return readRange(f, s.tuning); },
              "{first, count}: the draws parameters are chosen on")
          .required(
              "evaluation",
              [](const schema::Field& f, DrawSets& s) { return readRange(f, s.evaluation); },
              "{first, count}: the draws the figures come from")
          .required(
              "ci", [](const schema::Field& f, DrawSets& s) { return readCount(f, s.ci, 0); },
              "how many evaluation draws CI runs");
  DrawSets sets;
  sets.source = path;
  const schema::Field root = document->root();
  CDFF_RETURN_IF_ERROR(table.read(root, sets));
  const DrawRange& t = sets.tuning;
  const DrawRange& e = sets.evaluation;
  if (t.first < e.end() && e.first < t.end())
    return root["evaluation"].fail(
        fmt::format("draws disjoint from the tuning draws [{}, {})", t.first, t.end()),
        fmt::format("[{}, {}) overlaps them", e.first, e.end()));
  if (sets.ci > e.count)
    return root["ci"].fail(fmt::format("at most the {} evaluation draws", e.count), "too many");
  return sets;
}

}  // namespace cdff::eval
