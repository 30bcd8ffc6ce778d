#pragma once
// The draws behind every accuracy figure. A draw is one independent trial of a scenario: its
// number seeds the simulator (sensor noise, dropped frames, lighting jitter) and, through a
// separate stream, the initial error given to the tracker, so that no two draws share their
// noise or their error. Parameters and rules are chosen on the tuning draws; the figures in
// docs/ and the benchmarks come from the evaluation draws, which nothing is tuned on. Both sets
// are fixed in data/evaluation/draws.yaml; CI runs the first few evaluation draws.
#include <cstdint>
#include <string>
#include <vector>

#include "cdff/types/status.hpp"

namespace cdff::eval {

struct Draw {
  std::uint64_t number = 0;
  std::uint64_t simulator_seed = 0;      // the number itself (`cdff sim --seed`)
  std::uint64_t initial_error_seed = 0;  // a stream independent of the simulator's
};
Draw drawOf(std::uint64_t number);

/// A run of consecutive draw numbers.
struct DrawRange {
  std::uint64_t first = 1;
  std::uint64_t count = 0;
  std::uint64_t end() const { return first + count; }
  bool contains(std::uint64_t n) const { return n >= first && n < end(); }
  std::vector<std::uint64_t> numbers() const;
};

struct DrawSets {
  DrawRange tuning;
  DrawRange evaluation;
  std::uint64_t ci = 0;  // CI runs evaluation draws first .. first + ci - 1
  std::string source;

  /// The first `n` evaluation draws (all of them when n is 0 or larger than the set).
  std::vector<Draw> evaluationDraws(std::uint64_t n = 0) const;
  std::vector<Draw> ciDraws() const { return evaluationDraws(ci); }
  /// The first `n` tuning draws (at most 10000 of them, all of them when n is 0 or larger).
  std::vector<Draw> tuningDraws(std::uint64_t n) const;
};

/// Reads a draw-set file: the two ranges must not overlap, `ci` is at most the evaluation count.
Result<DrawSets> loadDrawSets(const std::string& path);

}  // namespace cdff::eval
