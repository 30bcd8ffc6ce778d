#pragma once
// Conditions: the small expression language of `active_when`, `diverged_when` and `tick_when`.
//
//   condition  := conjunction ('or' conjunction)*
//   conjunction:= term ('and' term)*
//   term       := ['not'] comparison
//   comparison := ref                          (a Bool output: true)
//              |  ref ('in' | 'not' 'in') '[' literal (',' literal)* ']'
//              |  ref ('==' | '!=' | '<' | '<=' | '>' | '>=') literal
//   ref        := instance '.' port | 'track_state'
//   literal    := number | 'true' | 'false' | 'unset' | identifier | 'quoted text'
//
// A ref reads the latest value of a DFN output (TrackState, String, Bool, Int, Double or
// Timestamp) or the DFPC's track state (a TrackState: its literals are checked against the
// states' names). Before the output has ever been produced it is `unset`: it equals only the
// literal `unset`, so `tracker.status in [LOST, unset]` holds until the tracker first runs.
// Outputs of other types (a state, a cloud...) can only be compared with unset
// (`ekf.state != unset`: the filter has produced a state).
// Comparisons with <, >... are false for an unset ref. Examples:
//   tracker.status in [LOST, UNINITIALISED, unset]
//   track_state != TRACKING
//   ekf.innovation_nis > 50 and not ekf.measurement_accepted

#include <functional>
#include <string>
#include <vector>

#include "cdff/types/status.hpp"
#include "cdff/types/type_registry.hpp"

namespace cdff::dfpc {

class Condition {
 public:
  struct Ref {
    std::string instance;  // "" for track_state
    std::string port;      // "track_state" when instance is ""
    std::string text() const { return instance.empty() ? port : instance + "." + port; }
  };

  /// Parses `text`, written at `where` (errors point at the character).
  static Result<Condition> parse(const std::string& text, const SourceLocation& where);

  const std::string& text() const { return text_; }
  const std::vector<Ref>& refs() const { return refs_; }

  /// Checks every comparison against the type of its ref (`types[i]` for refs()[i]): a String
  /// compared with a number, a Bool with <, a literal that is not a number for a Double...
  Status bind(const std::vector<TypeId>& types, const SourceLocation& where);

  /// The value of refs()[i]: a pointer to the latest value of its bound type, nullptr if unset.
  using ValueOf = std::function<const void*(std::size_t ref)>;
  /// Only after a successful bind().
  bool evaluate(const ValueOf& value_of) const;

  Condition() = default;

 private:
  enum class Op { kTruthy, kIn, kNotIn, kEq, kNe, kLt, kLe, kGt, kGe };
  struct Literal {
    bool unset = false;
    bool is_number = false;
    double number = 0;
    std::string text;
    TrackState state = TrackState::kUninitialised;  // a track state's, after bind()
    int column = 0;                                 // 1-based, in the condition text
  };
  struct Comparison {
    std::size_t ref = 0;
    Op op = Op::kTruthy;
    bool negated = false;
    std::vector<Literal> literals;
    int column = 0;
  };
  enum class ValueKind { kString, kTrackState, kBool, kInt, kDouble, kTimestamp, kOther };

  friend class ConditionParser;
  bool evaluate(const Comparison& c, const void* value) const;

  std::string text_;
  std::vector<Ref> refs_;
  std::vector<std::vector<Comparison>> disjunction_;  // OR of ANDs
  std::vector<ValueKind> kinds_;                      // per ref, after bind()
};

}  // namespace cdff::dfpc
