#include "cdff/dfpc/condition.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>

#include <fmt/format.h>

namespace cdff::dfpc {

namespace {

enum class Tok { kWord, kNumber, kQuoted, kLBracket, kRBracket, kComma, kOp, kEnd };

struct Token {
  Tok kind = Tok::kEnd;
  std::string text;
  double number = 0;
  int column = 0;  // 1-based
};

bool isWordChar(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
}

}  // namespace

namespace {

// The location of character `column` (1-based) of a condition written at `where` on one line.
Status conditionError(const std::string& text, const SourceLocation& where, int column,
                      const std::string& what) {
  SourceLocation at = where;
  if (at.column > 0) at.column += column - 1;
  return Status(StatusCode::kInvalidParameter,
                fmt::format("condition '{}': {} (at character {})", text, what, column), at);
}

}  // namespace

class ConditionParser {
 public:
  ConditionParser(const std::string& text, const SourceLocation& where)
      : text_(text), where_(where) {}

  Result<Condition> run() {
    Condition c;
    c.text_ = text_;
    CDFF_RETURN_IF_ERROR(tokenize());
    if (tokens_.front().kind == Tok::kEnd)
      return error(1, "empty condition; expected a comparison");
    for (;;) {
      std::vector<Condition::Comparison> conjunction;
      for (;;) {
        Result<Condition::Comparison> cmp = comparison(c);
        if (!cmp) return cmp.status();
        conjunction.push_back(std::move(cmp).value());
        if (!acceptWord("and")) break;
      }
      c.disjunction_.push_back(std::move(conjunction));
      if (!acceptWord("or")) break;
    }
    if (peek().kind != Tok::kEnd)
      return error(peek().column,
                   fmt::format("unexpected '{}'; expected 'and', 'or' or the end", peek().text));
    return c;
  }

 private:
  Status error(int column, const std::string& what) const {
    return conditionError(text_, where_, column, what);
  }

  Status tokenize() {
    std::size_t i = 0;
    while (i < text_.size()) {
      const char ch = text_[i];
      const int column = static_cast<int>(i) + 1;
      if (std::isspace(static_cast<unsigned char>(ch))) {
        ++i;
      } else if (ch == '[' || ch == ']' || ch == ',') {
        tokens_.push_back({ch == '['   ? Tok::kLBracket
                           : ch == ']' ? Tok::kRBracket
                                       : Tok::kComma,
                           {ch},
                           0,
                           column});
        ++i;
      } else if (ch == '=' || ch == '!' || ch == '<' || ch == '>') {
        std::string op(1, ch);
        if (i + 1 < text_.size() && text_[i + 1] == '=') op += '=';
        if (op == "=" || op == "!")
          return error(column,
                       fmt::format("'{}' is not an operator; expected ==, !=, <, <=, >, >=", op));
        tokens_.push_back({Tok::kOp, op, 0, column});
        i += op.size();
      } else if (ch == '\'' || ch == '"') {
        const std::size_t end = text_.find(ch, i + 1);
        if (end == std::string::npos) return error(column, "unterminated quoted text");
        tokens_.push_back({Tok::kQuoted, text_.substr(i + 1, end - i - 1), 0, column});
        i = end + 1;
      } else if (std::isdigit(static_cast<unsigned char>(ch)) || ch == '-' || ch == '+' ||
                 ch == '.') {
        std::size_t end = i + 1;
        while (end < text_.size() && (isWordChar(text_[end]) || text_[end] == '.' ||
                                      ((text_[end] == '-' || text_[end] == '+') &&
                                       (text_[end - 1] == 'e' || text_[end - 1] == 'E'))))
          ++end;
        const std::string word = text_.substr(i, end - i);
        double value = 0;
        const char* first = word.data() + (word[0] == '+' ? 1 : 0);
        auto [ptr, ec] = std::from_chars(first, word.data() + word.size(), value);
        if (ec != std::errc() || ptr != word.data() + word.size())
          return error(column, fmt::format("'{}' is not a number", word));
        tokens_.push_back({Tok::kNumber, word, value, column});
        i = end;
      } else if (isWordChar(ch)) {
        std::size_t end = i;
        while (end < text_.size() && (isWordChar(text_[end]) || text_[end] == '.')) ++end;
        tokens_.push_back({Tok::kWord, text_.substr(i, end - i), 0, column});
        i = end;
      } else {
        return error(column, fmt::format("unexpected character '{}'", ch));
      }
    }
    tokens_.push_back({Tok::kEnd, "<end>", 0, static_cast<int>(text_.size()) + 1});
    return Status::ok();
  }

  const Token& peek() const { return tokens_[pos_]; }
  const Token& take() { return tokens_[pos_ < tokens_.size() - 1 ? pos_++ : pos_]; }
  bool acceptWord(const char* word) {
    if (peek().kind == Tok::kWord && peek().text == word) {
      ++pos_;
      return true;
    }
    return false;
  }

  Result<Condition::Comparison> comparison(Condition& c) {
    Condition::Comparison cmp;
    cmp.negated = acceptWord("not");
    const Token ref = take();
    cmp.column = ref.column;
    if (ref.kind != Tok::kWord || ref.text == "and" || ref.text == "or" || ref.text == "in")
      return error(
          ref.column,
          fmt::format("expected a reference (instance.port or track_state), got '{}'", ref.text));
    Condition::Ref r;
    const std::size_t dot = ref.text.find('.');
    if (dot == std::string::npos) {
      if (ref.text != "track_state")
        return error(ref.column,
                     fmt::format("'{}' is not a reference; expected instance.port or track_state",
                                 ref.text));
      r.port = "track_state";
    } else {
      r.instance = ref.text.substr(0, dot);
      r.port = ref.text.substr(dot + 1);
      if (r.instance.empty() || r.port.empty() || r.port.find('.') != std::string::npos)
        return error(ref.column,
                     fmt::format("'{}' is not a reference; expected instance.port", ref.text));
    }
    cmp.ref = c.refs_.size();
    for (std::size_t i = 0; i < c.refs_.size(); ++i)
      if (c.refs_[i].text() == r.text()) cmp.ref = i;
    if (cmp.ref == c.refs_.size()) c.refs_.push_back(r);

    const Token& next = peek();
    if (next.kind == Tok::kWord && next.text == "in") {
      ++pos_;
      cmp.op = Condition::Op::kIn;
      CDFF_RETURN_IF_ERROR(literalList(cmp));
    } else if (next.kind == Tok::kWord && next.text == "not" && pos_ + 1 < tokens_.size() &&
               tokens_[pos_ + 1].kind == Tok::kWord && tokens_[pos_ + 1].text == "in") {
      pos_ += 2;
      cmp.op = Condition::Op::kNotIn;
      CDFF_RETURN_IF_ERROR(literalList(cmp));
    } else if (next.kind == Tok::kOp) {
      const std::string op = take().text;
      cmp.op = op == "=="   ? Condition::Op::kEq
               : op == "!=" ? Condition::Op::kNe
               : op == "<"  ? Condition::Op::kLt
               : op == "<=" ? Condition::Op::kLe
               : op == ">"  ? Condition::Op::kGt
                            : Condition::Op::kGe;
      Result<Condition::Literal> lit = literal();
      if (!lit) return lit.status();
      cmp.literals.push_back(std::move(lit).value());
    } else {
      cmp.op = Condition::Op::kTruthy;
    }
    return cmp;
  }

  Status literalList(Condition::Comparison& cmp) {
    const Token open = take();
    if (open.kind != Tok::kLBracket)
      return error(open.column, fmt::format("expected '[' after 'in', got '{}'", open.text));
    for (;;) {
      Result<Condition::Literal> lit = literal();
      if (!lit) return lit.status();
      cmp.literals.push_back(std::move(lit).value());
      const Token sep = take();
      if (sep.kind == Tok::kRBracket) break;
      if (sep.kind != Tok::kComma)
        return error(sep.column, fmt::format("expected ',' or ']', got '{}'", sep.text));
    }
    return Status::ok();
  }

  Result<Condition::Literal> literal() {
    const Token t = take();
    Condition::Literal lit;
    lit.column = t.column;
    lit.text = t.text;
    switch (t.kind) {
      case Tok::kNumber:
        lit.is_number = true;
        lit.number = t.number;
        return lit;
      case Tok::kQuoted:
        return lit;
      case Tok::kWord:
        if (t.text == "unset") lit.unset = true;
        if (t.text == "and" || t.text == "or" || t.text == "in" || t.text == "not")
          return error(t.column, fmt::format("expected a value, got the keyword '{}'", t.text));
        return lit;
      default:
        return error(t.column, fmt::format("expected a value, got '{}'", t.text));
    }
  }

  const std::string& text_;
  const SourceLocation& where_;
  std::vector<Token> tokens_;
  std::size_t pos_ = 0;
};

Result<Condition> Condition::parse(const std::string& text, const SourceLocation& where) {
  return ConditionParser(text, where).run();
}

Status Condition::bind(const std::vector<TypeId>& types, const SourceLocation& where) {
  auto fail = [&](int column, const std::string& what) {
    return conditionError(text_, where, column, what);
  };
  kinds_.clear();
  for (const TypeId& t : types) {
    if (t == TypeId::of<TrackState>())
      kinds_.push_back(ValueKind::kTrackState);
    else if (t == TypeId::of<std::string>())
      kinds_.push_back(ValueKind::kString);
    else if (t == TypeId::of<bool>())
      kinds_.push_back(ValueKind::kBool);
    else if (t == TypeId::of<int>())
      kinds_.push_back(ValueKind::kInt);
    else if (t == TypeId::of<double>())
      kinds_.push_back(ValueKind::kDouble);
    else if (t == TypeId::of<Timestamp>())
      kinds_.push_back(ValueKind::kTimestamp);
    else
      kinds_.push_back(ValueKind::kOther);
  }
  for (auto& conjunction : disjunction_) {
    for (Comparison& c : conjunction) {
      const ValueKind kind = kinds_[c.ref];
      const std::string& name = refs_[c.ref].text();
      const bool ordered = c.op == Op::kLt || c.op == Op::kLe || c.op == Op::kGt || c.op == Op::kGe;
      if (kind == ValueKind::kOther) {
        const bool only_unset = std::all_of(c.literals.begin(), c.literals.end(),
                                            [](const Literal& l) { return l.unset; });
        if (c.op == Op::kTruthy || ordered || !only_unset)
          return fail(c.column, fmt::format("'{}' is a {}; it can only be compared with unset "
                                            "(== unset, != unset)",
                                            name, types[c.ref].name()));
        continue;
      }
      if (c.op == Op::kTruthy && kind != ValueKind::kBool)
        return fail(c.column, fmt::format("'{}' is a {}, not a Bool; compare it with a value", name,
                                          types[c.ref].name()));
      if (ordered && (kind == ValueKind::kString || kind == ValueKind::kBool ||
                      kind == ValueKind::kTrackState))
        return fail(c.column, fmt::format("'{}' is a {}; <, <=, >, >= need a number", name,
                                          types[c.ref].name()));
      for (Literal& lit : c.literals) {
        if (lit.unset) {
          if (ordered) return fail(lit.column, "'unset' cannot be ordered; use == or !=");
          continue;
        }
        switch (kind) {
          case ValueKind::kString:
            if (lit.is_number) lit.is_number = false;  // 3 is the text "3" for a String
            break;
          case ValueKind::kTrackState: {
            const std::optional<TrackState> state = parseTrackState(lit.text);
            if (!state)
              return fail(lit.column,
                          fmt::format("'{}' is a track state; expected one of {{UNINITIALISED, "
                                      "ACQUIRING, TRACKING, DEGRADED, LOST}} or unset, got '{}'",
                                      name, lit.text));
            lit.state = *state;
            break;
          }
          case ValueKind::kBool:
            if (lit.text != "true" && lit.text != "false")
              return fail(lit.column, fmt::format("'{}' is a Bool; expected true, false or unset, "
                                                  "got '{}'",
                                                  name, lit.text));
            break;
          default:
            if (!lit.is_number)
              return fail(lit.column, fmt::format("'{}' is a {}; expected a number or unset, got "
                                                  "'{}'",
                                                  name, types[c.ref].name(), lit.text));
        }
      }
    }
  }
  return Status::ok();
}

bool Condition::evaluate(const Comparison& c, const void* value) const {
  const ValueKind kind = kinds_[c.ref];
  auto equals = [&](const Literal& lit) -> bool {
    if (lit.unset || !value) return lit.unset && !value;
    switch (kind) {
      case ValueKind::kString:
        return *static_cast<const std::string*>(value) == lit.text;
      case ValueKind::kTrackState:
        return *static_cast<const TrackState*>(value) == lit.state;
      case ValueKind::kBool:
        return *static_cast<const bool*>(value) == (lit.text == "true");
      case ValueKind::kInt:
        return *static_cast<const int*>(value) == lit.number;
      case ValueKind::kDouble:
        return *static_cast<const double*>(value) == lit.number;
      case ValueKind::kTimestamp:
        return static_cast<double>(*static_cast<const Timestamp*>(value)) == lit.number;
      case ValueKind::kOther:
        return false;  // bind() allows only `unset` literals
    }
    return false;
  };
  auto number = [&]() -> double {
    switch (kind) {
      case ValueKind::kInt:
        return *static_cast<const int*>(value);
      case ValueKind::kDouble:
        return *static_cast<const double*>(value);
      case ValueKind::kTimestamp:
        return static_cast<double>(*static_cast<const Timestamp*>(value));
      default:
        return std::nan("");
    }
  };
  bool result = false;
  switch (c.op) {
    case Op::kTruthy:
      result = value && *static_cast<const bool*>(value);
      break;
    case Op::kIn:
    case Op::kNotIn: {
      bool found = false;
      for (const Literal& lit : c.literals) found = found || equals(lit);
      result = c.op == Op::kIn ? found : !found;
      break;
    }
    case Op::kEq:
      result = equals(c.literals[0]);
      break;
    case Op::kNe:
      result = !equals(c.literals[0]);
      break;
    case Op::kLt:
      result = value && number() < c.literals[0].number;
      break;
    case Op::kLe:
      result = value && number() <= c.literals[0].number;
      break;
    case Op::kGt:
      result = value && number() > c.literals[0].number;
      break;
    case Op::kGe:
      result = value && number() >= c.literals[0].number;
      break;
  }
  return c.negated ? !result : result;
}

bool Condition::evaluate(const ValueOf& value_of) const {
  for (const auto& conjunction : disjunction_) {
    bool all = true;
    for (const Comparison& c : conjunction) {
      if (!evaluate(c, value_of(c.ref))) {
        all = false;
        break;
      }
    }
    if (all) return true;
  }
  return false;
}

}  // namespace cdff::dfpc
