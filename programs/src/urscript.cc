// The URScript reader (Universal Robots, .script): joint lists [q1..q6] (rad) and poses p[x,y,z,rx,ry,rz] (m, a
// rotation vector in rad) that movej, movel, movep and movec move to, written inline or assigned to a variable, and
// the tool set_tcp sets for the motions that follow it. URScript has no configuration flags and no turns.
//
// The text is read by a hand-written tokenizer (comments, strings, names, numbers, brackets) and a scan of its
// tokens, both linear: a program of 10,000 targets is tens of thousands of tokens, and no pattern is retried.
#include <algorithm>
#include <cstddef>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "robocal/programs/program.h"
#include "robocal/programs/text_scan.h"

namespace robocal::programs {
namespace {

// ---------------------------------------------------------------------------------------------------------------
// Tokens

enum class TokenKind {
  kName,       // a name: [A-Za-z_][A-Za-z0-9_]*
  kNumber,     // a number ScanNumber reads (no sign: a sign is its own token)
  kBadNumber,  // what starts like a number and is not one ("0.1.2", "12abc")
  kString,     // "..." (unterminated: to the end of its line)
  kLineEnd,    // "\n", "\r\n" or "\r": the end of a statement unless inside brackets
  kPunct,      // anything else; "==", "!=", "<=", ">=" as one token so that '=' alone is an assignment
};

struct Token {
  TokenKind kind = TokenKind::kPunct;
  std::size_t begin = 0;
  std::size_t end = 0;
  double value = 0.0;  // kNumber only
};

bool IsNameStart(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }
bool IsDigitChar(char c) { return c >= '0' && c <= '9'; }
bool IsNameChar(char c) { return IsNameStart(c) || IsDigitChar(c); }

// Every token of `text`, comments ('#' to the end of the line) and blanks left out. Linear; never throws.
std::vector<Token> Tokenize(std::string_view text) {
  std::vector<Token> tokens;
  tokens.reserve(text.size() / 3 + 1);
  std::size_t i = 0;
  const std::size_t n = text.size();
  while (i < n) {
    const char c = text[i];
    Token token;
    token.begin = i;
    if (c == ' ' || c == '\t' || c == '\f' || c == '\v') {
      ++i;
      continue;
    }
    if (c == '#') {
      while (i < n && text[i] != '\n' && text[i] != '\r') ++i;
      continue;
    }
    if (c == '\n' || c == '\r') {
      i += (c == '\r' && i + 1 < n && text[i + 1] == '\n') ? 2 : 1;
      token.kind = TokenKind::kLineEnd;
    } else if (c == '"') {
      // A string may hold '#', brackets and quotes escaped with '\'; it does not run past its line.
      ++i;
      while (i < n && text[i] != '"' && text[i] != '\n' && text[i] != '\r') {
        i += (text[i] == '\\' && i + 1 < n && text[i + 1] != '\n' && text[i + 1] != '\r') ? 2 : 1;
      }
      if (i < n && text[i] == '"') ++i;
      token.kind = TokenKind::kString;
    } else if (IsNameStart(c)) {
      while (i < n && IsNameChar(text[i])) ++i;
      token.kind = TokenKind::kName;
    } else if (IsDigitChar(c) || (c == '.' && i + 1 < n && IsDigitChar(text[i + 1]))) {
      if (const std::optional<ScannedNumber> number = ScanNumber(text, i)) {
        i += number->length;
        token.kind = TokenKind::kNumber;
        token.value = number->value;
      } else {
        // The whole glued run is the bad number, so that the error points at it and scanning goes on after it.
        while (i < n && (IsNameChar(text[i]) || text[i] == '.')) ++i;
        token.kind = TokenKind::kBadNumber;
      }
    } else {
      const bool two = i + 1 < n && text[i + 1] == '=' && (c == '=' || c == '!' || c == '<' || c == '>');
      i += two ? 2 : 1;
      token.kind = TokenKind::kPunct;
    }
    token.end = i;
    tokens.push_back(token);
  }
  return tokens;
}

// ---------------------------------------------------------------------------------------------------------------
// One file's tokens with their bracket pairs

class FileScan {
 public:
  FileScan(const ProgramFile& file, int index) : source_(file, index), tokens_(Tokenize(source_.text())) {
    MatchBrackets();
    IndexJunk();
  }

  const SourceText& source() const { return source_; }
  std::string_view text() const { return source_.text(); }
  int size() const { return static_cast<int>(tokens_.size()); }
  const Token& at(int i) const { return tokens_[i]; }
  std::string_view TextOf(int i) const { return text().substr(tokens_[i].begin, tokens_[i].end - tokens_[i].begin); }
  bool IsPunct(int i, char c) const {
    return i >= 0 && i < size() && tokens_[i].kind == TokenKind::kPunct && tokens_[i].end - tokens_[i].begin == 1 &&
           text()[tokens_[i].begin] == c;
  }
  bool IsName(int i, std::string_view name) const {
    return i >= 0 && i < size() && tokens_[i].kind == TokenKind::kName && TextOf(i) == name;
  }
  // The index of the bracket that closes the one at `i` ('(' or '['), or -1 if none does or one of the other kind
  // does ("p[1, 2)" is no literal and "movel(wp]" no call).
  int Close(int i) const {
    const int close = close_[i];
    if (close < 0) return -1;
    return IsPunct(i, '(') == IsPunct(close, ')') ? close : -1;
  }

  // The first token in [from, to) that is no URScript at all (a NUL or other control byte, '@', '$', ';', a byte of
  // a UTF-8 character outside a string or comment), or -1. Constant time.
  int FirstJunk(int from, int to) const {
    if (from < 0) from = 0;
    if (from >= to || from >= size()) return -1;
    const int junk = next_junk_[from];
    return junk < to ? junk : -1;
  }
  // What a junk token is, for an error: "'@'", or "byte 0x00" for one that does not print.
  std::string DescribeJunk(int i) const {
    const unsigned char c = static_cast<unsigned char>(text()[tokens_[i].begin]);
    if (c > 0x20 && c < 0x7f) return std::string("'") + static_cast<char>(c) + "'";
    static const char kHex[] = "0123456789ABCDEF";
    return std::string("byte 0x") + kHex[c >> 4] + kHex[c & 15];
  }

  // One element of a bracketed list: tokens [first, last) with line ends left out (first < 0: empty), and the
  // ',' or closing bracket that ends it.
  struct Element {
    int first = -1;
    int last = -1;
    int separator = 0;
  };

  // The elements of the bracketed list opened at `open` (whose pair was found: Close(open) >= 0), split at its
  // top-level commas. A list with nothing in it has no element.
  std::vector<Element> Elements(int open) const {
    std::vector<Element> elements;
    const int close = close_[open];
    Element element;
    bool any = false;
    for (int i = open + 1; i < close; ++i) {
      if (tokens_[i].kind == TokenKind::kLineEnd) continue;
      if (IsPunct(i, ',')) {
        element.separator = i;
        elements.push_back(element);
        element = Element();
        any = true;
        continue;
      }
      if (element.first < 0) element.first = i;
      // A nested bracket is one piece of the element: jump to its close (bracket pairs nest, so it is before ours).
      const int skip = close_[i] >= 0 ? close_[i] : i;
      element.last = skip + 1;
      i = skip;
      any = true;
    }
    element.separator = close;
    if (any) elements.push_back(element);
    return elements;
  }

 private:
  // One pass with a stack: any closing bracket closes the innermost open one (text that mixes them up is not
  // URScript, and a lenient pairing keeps the scan linear and bounded).
  void MatchBrackets() {
    close_.assign(tokens_.size(), -1);
    std::vector<int> open;
    for (int i = 0; i < size(); ++i) {
      if (IsPunct(i, '(') || IsPunct(i, '[')) {
        open.push_back(i);
      } else if ((IsPunct(i, ')') || IsPunct(i, ']')) && !open.empty()) {
        close_[open.back()] = i;
        open.pop_back();
      }
    }
  }

  // The punctuation URScript has: operators, brackets, ',', '.', ':' and '='; "==", "!=", "<=", ">=" are one token.
  bool IsJunk(int i) const {
    if (tokens_[i].kind != TokenKind::kPunct) return false;
    if (tokens_[i].end - tokens_[i].begin == 2) return false;
    return std::string_view("+-*/%()[],.:=<>").find(text()[tokens_[i].begin]) == std::string_view::npos;
  }

  void IndexJunk() {
    next_junk_.assign(tokens_.size() + 1, size());
    for (int i = size() - 1; i >= 0; --i) next_junk_[i] = IsJunk(i) ? i : next_junk_[i + 1];
  }

  SourceText source_;
  std::vector<Token> tokens_;
  std::vector<int> close_;
  std::vector<int> next_junk_;  // per token: the index of the first junk token at or after it (size(): none)
};

// ---------------------------------------------------------------------------------------------------------------
// Literals: p[...] and [...]

// A place in the program: files in the request's order, then bytes.
struct Place {
  int file = 0;
  std::size_t offset = 0;
  friend bool operator<(const Place& a, const Place& b) {
    return a.file != b.file ? a.file < b.file : a.offset < b.offset;
  }
};

struct Literal {
  bool pose = false;  // p[...] (else a plain list)
  int file = 0;
  std::size_t begin = 0;  // the literal's text, "p" or "[" to "]" included
  std::size_t end = 0;
  // The numbers and their spans: all 6 when the literal is a target and has no error.
  std::vector<double> values;
  std::vector<NumberSpan> spans;
  // A value built at run time (an element with a variable or call in it, `p[x, 0, ...]`): never a target, and
  // silently so.
  bool skipped = false;
  // What keeps a literal of numbers from being a target: a malformed or missing number, a sign apart from its
  // digits, bytes that are no URScript, other than 6 numbers. Reported only if the literal is where a target must
  // be (a motion's target, a variable a motion moves to, a pose assigned to a variable); a list elsewhere (a
  // gravity vector, an inertia) is not the reader's business.
  std::optional<std::size_t> error_offset;
  std::string error;
};

bool IsOperatorWord(std::string_view word) { return word == "not" || word == "and" || word == "or" || word == "xor"; }

// The literal starting at token `first` (the "p" of "p[" or a "["), or nullopt if none starts there or its
// bracket is not closed (the caller decides whether that is an error).
std::optional<Literal> ReadLiteral(const FileScan& scan, int first) {
  Literal literal;
  int open = first;
  if (scan.IsName(first, "p") && scan.IsPunct(first + 1, '[')) {
    literal.pose = true;
    open = first + 1;
  } else if (!scan.IsPunct(first, '[')) {
    return std::nullopt;
  }
  const int close = scan.Close(open);
  if (close < 0) return std::nullopt;
  literal.file = scan.source().file_index();
  literal.begin = scan.at(first).begin;
  literal.end = scan.at(close).end;
  const char* what = literal.pose ? "pose" : "joint list";
  // Bytes that are no URScript (a NUL, '@', ...) make the text no program the controller runs, whatever the
  // literal holds: an error wherever the literal is a target, even next to a variable.
  if (const int junk = scan.FirstJunk(open + 1, close); junk >= 0) {
    literal.error_offset = scan.at(junk).begin;
    literal.error = "unexpected " + scan.DescribeJunk(junk) + " in the " + what;
    return literal;
  }
  const std::vector<FileScan::Element> elements = scan.Elements(open);
  // Two numbers with nothing between them ("0.4 0.1": a ',' lost) are no expression either.
  for (const FileScan::Element& e : elements) {
    int previous = -1;
    for (int i = e.first; e.first >= 0 && i < e.last; ++i) {
      const TokenKind kind = scan.at(i).kind;
      if (kind == TokenKind::kLineEnd) continue;
      const bool number = kind == TokenKind::kNumber || kind == TokenKind::kBadNumber;
      const bool name = kind == TokenKind::kName && !IsOperatorWord(scan.TextOf(i));
      if (previous >= 0 && (number || name)) {
        const TokenKind before = scan.at(previous).kind;
        if ((before == TokenKind::kNumber || before == TokenKind::kBadNumber) ||
            (number && before == TokenKind::kName && !IsOperatorWord(scan.TextOf(previous)))) {
          literal.error_offset = scan.at(i).begin;
          literal.error = "a ',' is missing between '" + std::string(scan.TextOf(previous)) + "' and '" +
                          std::string(scan.TextOf(i)) + "' in the " + what;
          return literal;
        }
      }
      previous = i;
    }
  }
  // An element that is an expression makes the literal a value built at run time, not a target, whatever else it
  // holds; so malformed numbers are only reported for literals made of numbers alone.
  for (const FileScan::Element& e : elements) {
    if (e.first < 0) continue;  // empty: malformed, below
    const bool sign = scan.IsPunct(e.first, '-') || scan.IsPunct(e.first, '+');
    const int number = sign ? e.first + 1 : e.first;
    const bool numeric = number + 1 == e.last &&
                         (scan.at(number).kind == TokenKind::kNumber || scan.at(number).kind == TokenKind::kBadNumber);
    if (!numeric) {
      literal.skipped = true;
      return literal;
    }
  }
  for (const FileScan::Element& e : elements) {
    if (literal.error_offset) break;
    if (e.first < 0) {
      // Point at the comma or bracket where the number is missing.
      literal.error_offset = scan.at(e.separator).begin;
      literal.error = std::string("a number is missing in the ") + what;
      break;
    }
    const bool sign = scan.IsPunct(e.first, '-') || scan.IsPunct(e.first, '+');
    const int number = sign ? e.first + 1 : e.first;
    const Token& token = scan.at(number);
    const std::size_t begin = scan.at(e.first).begin;
    const std::string written(scan.text().substr(begin, token.end - begin));
    if (token.kind == TokenKind::kBadNumber) {
      literal.error_offset = token.begin;
      literal.error = "malformed number '" + std::string(scan.TextOf(number)) + "' in the " + what;
    } else if (sign && scan.at(e.first).end != token.begin) {
      // The number is rewritten as one span, so its sign must be part of it.
      literal.error_offset = begin;
      literal.error = "the sign of '" + written + "' in the " + what + " is apart from its digits";
    } else {
      literal.values.push_back(scan.IsPunct(e.first, '-') ? -token.value : token.value);
      literal.spans.push_back(NumberSpan{literal.file, begin, token.end - begin});
    }
  }
  if (!literal.error_offset && elements.size() != 6) {
    // URScript's poses are 6 values, and a UR arm has 6 joints: the controller rejects any other count where a
    // target must be. (Elsewhere, as a gravity vector or an index list, the literal is simply not a target.)
    literal.error_offset = literal.begin;
    literal.error = literal.pose ? "a pose p[...] has 6 values, this one " + std::to_string(elements.size())
                                 : "a joint list [...] has 6 values (a UR arm has 6 joints), this one " +
                                       std::to_string(elements.size());
  }
  return literal;
}

// ---------------------------------------------------------------------------------------------------------------
// What the scan collects

// One assignment `NAME = ...` (also `global NAME = ...`, `local NAME = ...`): a literal, or anything else (an
// expression, which hides an earlier literal from the motions after it).
struct Assignment {
  std::string name;
  Place place;                     // the name's first byte
  std::optional<Literal> literal;  // nullopt: an expression
  int target = -1;                 // index into Reader::targets_ once it is one
};

// What a motion argument names.
struct Reference {
  std::size_t begin = 0;  // the bytes that name the target in the statement
  std::size_t end = 0;
  std::optional<std::string> variable;  // a variable's name, or
  std::optional<Literal> literal;       // an inline literal
};

struct MotionCall {
  Motion motion = Motion::kJoint;
  Place place;  // the motion's name
  int line = 0;
  std::size_t begin = 0;  // the statement's lines
  std::size_t end = 0;
  std::size_t own_begin = 0;  // the call alone: its name to its ')'
  std::size_t own_end = 0;
  std::vector<Reference> references;  // 1, or 2 for movec (via, then end)
};

struct ToolChange {
  Place place;
  std::string tool;  // set_tcp's argument without blanks
};

// The name of a motion function and its kind; the names of its target arguments, in order.
struct MotionFunction {
  std::string_view name;
  Motion motion;
  std::vector<std::string_view> arguments;
};

const std::vector<MotionFunction>& MotionFunctions() {
  static const std::vector<MotionFunction> table = {
      {"movej", Motion::kJoint, {"q"}},
      {"movel", Motion::kLinear, {"pose"}},
      {"movep", Motion::kLinear, {"pose"}},
      {"movec", Motion::kCircular, {"pose_via", "pose_to"}},
  };
  return table;
}

class Reader {
 public:
  explicit Reader(const std::vector<ProgramFile>& files) {
    scans_.reserve(files.size());
    for (std::size_t f = 0; f < files.size(); ++f) scans_.emplace_back(files[f], static_cast<int>(f));
  }

  ParsedProgram Read() {
    for (const FileScan& scan : scans_) ScanFile(scan);
    for (const Assignment& a : assignments_) by_name_[a.name].push_back(&a - assignments_.data());
    ResolveMotions();
    AddUnusedPoses();
    return Finish();
  }

 private:
  struct PendingTarget {
    const Literal* literal = nullptr;
    std::optional<std::string> name;
    TargetKind kind = TargetKind::kJoint;
    int first_motion = -1;  // index into program_.motions
    Motion motion = Motion::kNone;
  };

  void ScanFile(const FileScan& scan) {
    const int file = scan.source().file_index();
    for (int i = 0; i < scan.size(); ++i) {
      if (scan.at(i).kind != TokenKind::kName) continue;
      const std::string_view word = scan.TextOf(i);
      // A name right after '.' is a member (struct.field), not a call or a variable of the program.
      if (i > 0 && scan.IsPunct(i - 1, '.')) continue;
      const bool call = scan.IsPunct(i + 1, '(');
      const bool defined = i > 0 && scan.IsName(i - 1, "def");
      if (call && !defined) {
        for (const MotionFunction& function : MotionFunctions()) {
          if (word == function.name) ScanMotion(scan, i, function);
        }
        if (word == "set_tcp") ScanSetTcp(scan, i);
        continue;
      }
      if (scan.IsPunct(i + 1, '=') && AtStatementStart(scan, i)) {
        Assignment assignment;
        assignment.name = std::string(word);
        assignment.place = Place{file, scan.at(i).begin};
        assignment.literal = AssignedLiteral(scan, i + 2);
        assignments_.push_back(std::move(assignment));
      }
    }
  }

  // Whether the name at `i` begins a statement (so `name =` assigns, unlike `a=1.2` inside a call's arguments).
  static bool AtStatementStart(const FileScan& scan, int i) {
    if (i == 0) return true;
    const int before = i - 1;
    return scan.at(before).kind == TokenKind::kLineEnd || scan.IsName(before, "global") ||
           scan.IsName(before, "local") || scan.IsPunct(before, ':');
  }

  // The literal assigned by the statement whose value starts at token `first`, when the value is a literal alone
  // (up to the end of the line or of the file); nullopt for any other value.
  static std::optional<Literal> AssignedLiteral(const FileScan& scan, int first) {
    if (first >= scan.size()) return std::nullopt;
    const bool pose = scan.IsName(first, "p") && scan.IsPunct(first + 1, '[');
    if (!pose && !scan.IsPunct(first, '[')) return std::nullopt;
    const int open = pose ? first + 1 : first;
    const int close = scan.Close(open);
    if (close < 0) {
      if (pose) scan.source().Fail(scan.at(first).begin, "the pose's '[' is not closed");
      return std::nullopt;
    }
    int line_end = close + 1;
    while (line_end < scan.size() && scan.at(line_end).kind != TokenKind::kLineEnd) ++line_end;
    std::optional<Literal> literal = ReadLiteral(scan, first);
    if (line_end == close + 1) return literal;
    // Something after the literal makes the value an expression (`p[...] + x`), unless it is bytes that are no
    // URScript (`p[...]\0`): then the literal is a target written wrongly.
    const int junk = scan.FirstJunk(close + 1, line_end);
    if (junk < 0) return std::nullopt;
    if (literal && !literal->error_offset) {
      literal->skipped = false;
      literal->error_offset = scan.at(junk).begin;
      literal->error = "unexpected " + scan.DescribeJunk(junk) + " after the " + (pose ? "pose" : "joint list");
    }
    return literal;
  }

  void ScanSetTcp(const FileScan& scan, int i) {
    const int close = scan.Close(i + 1);
    if (close < 0) scan.source().Fail(scan.at(i + 1).begin, "set_tcp's '(' is not closed");
    const std::vector<FileScan::Element> arguments = scan.Elements(i + 1);
    if (arguments.empty() || arguments[0].first < 0) return;
    const int a = arguments[0].first, b = arguments[0].last;
    // The tool's name: the argument's tokens, so without blanks, line ends and comments.
    std::string tool;
    for (int k = a; k < b; ++k) {
      if (scan.at(k).kind != TokenKind::kLineEnd) tool += scan.TextOf(k);
    }
    tools_.push_back(ToolChange{Place{scan.source().file_index(), scan.at(i).begin}, tool});
    // A variable set_tcp takes is a tool offset: its poses are not targets.
    if (b == a + 1 && scan.at(a).kind == TokenKind::kName) tool_variables_.emplace_back(scan.TextOf(a));
  }

  void ScanMotion(const FileScan& scan, int i, const MotionFunction& function) {
    const int open = i + 1;
    const int close = scan.Close(open);
    if (close < 0) scan.source().Fail(scan.at(open).begin, std::string(function.name) + "'s '(' is not closed");
    // The target arguments: positional first, then by keyword (`movel(pose=wp1, a=1.2)`).
    std::vector<std::pair<int, int>> slots(function.arguments.size(), {-1, -1});
    std::size_t position = 0;
    for (const FileScan::Element& e : scan.Elements(open)) {
      const int a = e.first, b = e.last;
      if (a < 0) continue;
      if (b - a >= 2 && scan.at(a).kind == TokenKind::kName && scan.IsPunct(a + 1, '=')) {
        const std::string_view keyword = scan.TextOf(a);
        for (std::size_t k = 0; k < slots.size(); ++k) {
          if (keyword == function.arguments[k]) slots[k] = {a + 2, b};
        }
        continue;
      }
      if (position < slots.size()) slots[position] = {a, b};
      ++position;
    }
    // Bytes that are no URScript anywhere in the call's arguments (outside a literal target, which names them
    // itself): the controller would not run the statement.
    const int junk = scan.FirstJunk(open + 1, close);
    MotionCall call;
    call.motion = function.motion;
    call.place = Place{scan.source().file_index(), scan.at(i).begin};
    const SourceText& source = scan.source();
    call.line = source.LineOf(scan.at(i).begin);
    call.begin = source.LineStart(call.line);
    const int last_line = source.LineOf(scan.at(close).begin);
    call.end = source.LineStart(last_line) + source.Line(last_line).size();
    call.own_begin = scan.at(i).begin;
    call.own_end = scan.at(close).begin + 1;
    // A motion to a computed value (or a movec missing an argument) is not read; a movec with one literal and
    // one computed point keeps its literal as a target (TargetOf).
    bool complete = true;
    for (const auto& [a, b] : slots) {
      std::optional<Reference> reference = ReferenceOf(scan, a, b);
      if (!reference) {
        complete = false;
        continue;
      }
      call.references.push_back(std::move(*reference));
    }
    if (junk >= 0) {
      const std::size_t at = scan.at(junk).begin;
      const bool in_literal = std::any_of(call.references.begin(), call.references.end(),
                                          [&](const Reference& r) { return r.literal && r.begin <= at && at < r.end; });
      if (!in_literal) {
        errors_.emplace_back(Place{scan.source().file_index(), at}, "unexpected " + scan.DescribeJunk(junk) + " in " +
                                                                        std::string(function.name) + "'s arguments");
      }
    }
    if (!complete) call.references.push_back(Reference());  // a reference to nothing: TargetOf gives -1
    if (!call.references.empty()) motions_.push_back(std::move(call));
  }

  // What the argument [a, b) names: a variable, a literal, or either one as get_inverse_kin's pose (the form a
  // UR controller writes for MoveJ waypoints: movej(get_inverse_kin(Waypoint_1_p, qnear=Waypoint_1_q), ...)).
  static std::optional<Reference> ReferenceOf(const FileScan& scan, int a, int b) {
    if (a < 0 || a >= b) return std::nullopt;
    if (scan.IsName(a, "get_inverse_kin") && scan.IsPunct(a + 1, '(') && scan.Close(a + 1) == b - 1) {
      const std::vector<FileScan::Element> inner = scan.Elements(a + 1);
      if (inner.empty()) return std::nullopt;
      return ReferenceOf(scan, inner[0].first, inner[0].last);
    }
    Reference reference;
    if (b == a + 1 && scan.at(a).kind == TokenKind::kName) {
      reference.variable = std::string(scan.TextOf(a));
      reference.begin = scan.at(a).begin;
      reference.end = scan.at(a).end;
      return reference;
    }
    const int open = scan.IsName(a, "p") ? a + 1 : a;
    if (!scan.IsPunct(open, '[') || scan.Close(open) != b - 1) return std::nullopt;
    reference.literal = ReadLiteral(scan, a);
    if (!reference.literal) return std::nullopt;
    reference.begin = reference.literal->begin;
    reference.end = reference.literal->end;
    return reference;
  }

  bool IsToolVariable(const std::string& name) const {
    return std::find(tool_variables_.begin(), tool_variables_.end(), name) != tool_variables_.end();
  }

  // The assignment a motion at `place` reads `name` from: the last one before it in program order, else (a
  // function defined above the assignments it uses) the first one after it.
  const Assignment* AssignmentFor(const std::string& name, const Place& place) const {
    const auto it = by_name_.find(name);
    if (it == by_name_.end()) return nullptr;
    const std::vector<std::size_t>& list = it->second;  // in program order
    const auto after = std::upper_bound(list.begin(), list.end(), place,
                                        [&](const Place& p, std::size_t k) { return p < assignments_[k].place; });
    return &assignments_[after == list.begin() ? list.front() : *(after - 1)];
  }

  // A literal that becomes a target: a malformed one is the program's error.
  void CheckTarget(const Literal& literal) {
    if (literal.error_offset) {
      errors_.emplace_back(Place{literal.file, *literal.error_offset}, literal.error);
    }
  }

  // The target a motion's reference moves to (its index in pending_), made a target on first use; -1 if it names
  // no literal (a computed value, a variable never assigned one, a tool).
  int TargetOf(const MotionCall& call, const Reference& reference) {
    if (!reference.literal && !reference.variable) return -1;
    if (reference.literal) {
      if (reference.literal->skipped) return -1;
      CheckTarget(*reference.literal);
      return AddTarget(&*reference.literal, std::nullopt);
    }
    const Assignment* found = AssignmentFor(*reference.variable, call.place);
    if (!found || !found->literal || found->literal->skipped || IsToolVariable(found->name)) return -1;
    Assignment& assignment = assignments_[found - assignments_.data()];
    if (assignment.target < 0) {
      CheckTarget(*assignment.literal);
      assignment.target = AddTarget(&*assignment.literal, assignment.name);
    }
    return assignment.target;
  }

  void ResolveMotions() {
    for (const MotionCall& call : motions_) {
      std::vector<int> targets;
      for (const Reference& reference : call.references) targets.push_back(TargetOf(call, reference));
      // A movec is its via point and its end together; with one of them computed it is not a motion the engine
      // can follow, and its literal target stays a target that no motion is known to move to.
      if (std::find(targets.begin(), targets.end(), -1) != targets.end()) continue;
      for (std::size_t k = 0; k < targets.size(); ++k) {
        MotionStatement statement;
        statement.target = targets[k];
        statement.motion = call.motion;
        statement.file = call.place.file;
        statement.line = call.line;
        statement.begin = call.begin;
        statement.end = call.end;
        statement.own_begin = call.own_begin;
        statement.own_end = call.own_end;
        statement.reference_begin = call.references[k].begin;
        statement.reference_end = call.references[k].end;
        PendingTarget& pending = pending_[targets[k]];
        if (pending.first_motion < 0) {
          pending.first_motion = static_cast<int>(program_.motions.size());
          pending.motion = call.motion;
        }
        program_.motions.push_back(statement);
        motion_places_.push_back(call.place);
      }
    }
  }

  // Poses assigned to variables are targets even when no motion the reader sees uses them (a pose may be moved to
  // through an expression or by a program that includes this one); joint lists are not, since a list of 6
  // numbers is as often something else (qnear for get_inverse_kin, a payload's inertia).
  void AddUnusedPoses() {
    for (Assignment& a : assignments_) {
      if (a.target >= 0 || !a.literal || !a.literal->pose || a.literal->skipped || IsToolVariable(a.name)) continue;
      CheckTarget(*a.literal);
      a.target = AddTarget(&*a.literal, a.name);
    }
  }

  int AddTarget(const Literal* literal, std::optional<std::string> name) {
    PendingTarget pending;
    pending.literal = literal;
    pending.name = std::move(name);
    pending.kind = literal->pose ? TargetKind::kCartesian : TargetKind::kJoint;
    pending_.push_back(std::move(pending));
    return static_cast<int>(pending_.size()) - 1;
  }

  // The tool in effect at `place`: the argument of the last set_tcp before it ("" before any).
  std::string ToolAt(const Place& place) const {
    const auto after = std::upper_bound(tools_.begin(), tools_.end(), place,
                                        [](const Place& p, const ToolChange& t) { return p < t.place; });
    return after == tools_.begin() ? std::string() : (after - 1)->tool;
  }

  ParsedProgram Finish() {
    if (!errors_.empty()) {
      const auto first = std::min_element(errors_.begin(), errors_.end(),
                                          [](const auto& x, const auto& y) { return x.first < y.first; });
      scans_[first->first.file].source().Fail(first->first.offset, first->second);
    }
    // Targets in the order of their text; motions point at them by their new index.
    std::vector<int> order(pending_.size());
    for (std::size_t k = 0; k < order.size(); ++k) order[k] = static_cast<int>(k);
    std::sort(order.begin(), order.end(), [&](int x, int y) {
      return Place{pending_[x].literal->file, pending_[x].literal->begin} <
             Place{pending_[y].literal->file, pending_[y].literal->begin};
    });
    std::vector<int> new_index(pending_.size());
    for (std::size_t k = 0; k < order.size(); ++k) new_index[order[k]] = static_cast<int>(k);
    for (MotionStatement& statement : program_.motions) statement.target = new_index[statement.target];
    for (int k : order) {
      const PendingTarget& pending = pending_[k];
      const Literal& literal = *pending.literal;
      const SourceText& source = scans_[literal.file].source();
      ProgramTarget target;
      target.file = literal.file;
      target.line = source.LineOf(literal.spans.front().offset);
      target.column = source.ColumnOf(literal.spans.front().offset);
      target.name = pending.name;
      target.kind = pending.kind;
      target.motion = pending.motion;
      target.values = literal.values;
      target.spans = literal.spans;
      target.configuration_applies = false;  // URScript has no configuration flags
      // The tool of the motion that moves to it; a pose no motion uses is in the tool in effect where it is.
      target.tool =
          ToolAt(pending.first_motion >= 0 ? motion_places_[pending.first_motion] : Place{literal.file, literal.begin});
      program_.targets.push_back(std::move(target));
    }
    return std::move(program_);
  }

  std::vector<FileScan> scans_;
  std::vector<Assignment> assignments_;
  std::map<std::string, std::vector<std::size_t>, std::less<>> by_name_;
  std::vector<MotionCall> motions_;
  std::vector<ToolChange> tools_;
  std::vector<std::string> tool_variables_;
  std::vector<PendingTarget> pending_;
  std::vector<Place> motion_places_;  // per entry of program_.motions
  std::vector<std::pair<Place, std::string>> errors_;
  ParsedProgram program_;
};

ParsedProgram ReadUrscript(const std::vector<ProgramFile>& files) { return Reader(files).Read(); }

// An inserted waypoint: p[x, y, z, rx, ry, rz] in m and rad. URScript poses carry nothing else to copy.
std::string UrscriptInlineTarget(const ProgramTarget& like, const std::vector<ProgramFile>& /*files*/,
                                 const std::vector<double>& values) {
  if (like.kind != TargetKind::kCartesian) return "";
  if (values.size() != 6) {
    throw std::invalid_argument("a URScript pose has 6 values, got " + std::to_string(values.size()));
  }
  std::string text = "p[";
  for (std::size_t k = 0; k < 6; ++k) {
    if (k > 0) text += ", ";
    text += FormatInserted(values[k], k < 3 ? NumberUnit::kM : NumberUnit::kRad);
  }
  return text + "]";
}

}  // namespace

const DialectSyntax& UrscriptSyntax() {
  static const DialectSyntax syntax{
      .dialect = Dialect::kUrscript,
      .name = "urscript",
      .extensions = {".script"},
      .rotation = RotationConvention::kRotationVectorRad,
      .mm_per_length_unit = 1000.0,
      .joints_in_rad = true,
      .read = &ReadUrscript,
      .inline_target = &UrscriptInlineTarget,
  };
  return syntax;
}

}  // namespace robocal::programs
