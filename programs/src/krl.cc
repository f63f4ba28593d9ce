// KUKA KRL reader: the E6POS / POS / FRAME and E6AXIS / AXIS declarations of a program's files (its .dat, or a
// .src's declaration part), the inline aggregates of PTP / LIN / CIRC and their spline forms SPTP / SLIN / SCIRC /
// SPL, the statements that set the tool and base a motion runs in (FDAT_ACT, $TOOL, $BASE, BAS(#TOOL / #BASE),
// the WITH clause of a spline motion), and the S / T bits as robocal's configuration flags and joint ranges.
//
// A KRL statement is one line (the language has no continuation), so the reader scans line by line: a first pass
// over every file collects the targets, the FDAT declarations and the motion and frame statements in program
// order; a second pass resolves the names the motions use and gives each target the frames and the motion of the
// first statement that moves to it. Both passes are linear in the size of the files. A declared value that no
// motion moves to but that the program uses as a frame ($BASE = NAME, an operand of ':') is a frame, not a target.
// docs/programs.md gives the mapping of S and T and what is left out.
#include <algorithm>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "robocal/programs/program.h"
#include "robocal/programs/text_scan.h"

namespace robocal::programs {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr const char* kWholeTargets = "robocal compensates whole targets (a partial aggregate is legal KRL, not read)";

bool IsDigit(char c) { return c >= '0' && c <= '9'; }
bool IsLetter(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); }
// KRL names may carry '$' (system variables such as $TOOL) besides letters, digits and '_'.
bool IsNameStart(char c) { return IsLetter(c) || c == '_' || c == '$'; }
bool IsNameChar(char c) { return IsNameStart(c) || IsDigit(c); }

std::string_view Trim(std::string_view text) {
  while (!text.empty() && (text.front() == ' ' || text.front() == '\t')) text.remove_prefix(1);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\t')) text.remove_suffix(1);
  return text;
}

// The end of the name starting at `pos` (pos itself when none starts there), within [pos, limit).
std::size_t NameEnd(std::string_view text, std::size_t pos, std::size_t limit) {
  if (pos >= limit || !IsNameStart(text[pos])) return pos;
  while (pos < limit && IsNameChar(text[pos])) ++pos;
  return pos;
}

// A non-negative KRL integer literal: decimal digits, or the binary 'B0101' and hexadecimal 'H1F' forms. The
// status and turn of a target are written either way.
std::optional<int> ParseKrlInteger(std::string_view text) {
  text = Trim(text);
  int base = 10;
  if (text.size() >= 3 && text.front() == '\'' && text.back() == '\'') {
    const char kind = text[1];
    if (kind == 'B' || kind == 'b') {
      base = 2;
    } else if (kind == 'H' || kind == 'h') {
      base = 16;
    } else {
      return std::nullopt;
    }
    text = text.substr(2, text.size() - 3);
  }
  // More than 16 bits of a status or turn would mean nothing to the controller; the bound also keeps the
  // value far from overflow.
  if (text.empty() || text.size() > (base == 2 ? 16u : 6u)) return std::nullopt;
  int value = 0;
  for (char c : text) {
    int digit;
    if (IsDigit(c)) {
      digit = c - '0';
    } else if (c >= 'a' && c <= 'f') {
      digit = c - 'a' + 10;
    } else if (c >= 'A' && c <= 'F') {
      digit = c - 'A' + 10;
    } else {
      return std::nullopt;
    }
    if (digit >= base) return std::nullopt;
    value = value * base + digit;
  }
  return value;
}

// One component of an aggregate "{NAME value, ...}": the bytes of its name and of its value (blanks trimmed).
struct Component {
  std::size_t name_begin = 0;
  std::size_t name_end = 0;
  std::size_t value_begin = 0;
  std::size_t value_end = 0;
};

struct Aggregate {
  std::size_t open = 0;   // the '{'
  std::size_t close = 0;  // the '}'
  std::string_view type;  // the "E6POS" of "{E6POS: ...}", empty without one
  std::vector<Component> components;
};

// Why an aggregate could not be read, and where.
struct ScanFailure {
  std::size_t offset = 0;
  std::string reason;
};

// The aggregate whose '{' is at `open`, ending before `limit` (the end of the line's code). Values are taken as
// text up to the next ',' or '}' outside strings and nested brackets, so that FDAT's strings and enums read as
// well as numbers do. Never throws; nullopt with `failure` set for text that is not an aggregate.
std::optional<Aggregate> ScanAggregate(std::string_view text, std::size_t open, std::size_t limit,
                                       ScanFailure* failure) {
  Aggregate aggregate;
  aggregate.open = open;
  auto fail = [&](std::size_t at, std::string reason) -> std::optional<Aggregate> {
    failure->offset = at;
    failure->reason = std::move(reason);
    return std::nullopt;
  };
  std::size_t pos = SkipBlanks(text, open + 1);
  if (pos >= limit) return fail(open, "the aggregate has no closing '}'");
  // "{E6POS: X 1, ...}": an aggregate may name its type before a ':'.
  {
    const std::size_t name_end = NameEnd(text, pos, limit);
    const std::size_t after = SkipBlanks(text, name_end);
    if (name_end > pos && after < limit && text[after] == ':') {
      aggregate.type = text.substr(pos, name_end - pos);
      pos = SkipBlanks(text, after + 1);
    }
  }
  if (pos < limit && text[pos] == '}') {
    aggregate.close = pos;
    return aggregate;
  }
  while (true) {
    pos = SkipBlanks(text, pos);
    Component component;
    component.name_begin = pos;
    std::size_t name_end = NameEnd(text, pos, limit);
    if (name_end == pos) return fail(pos, "expected a component's name");
    // Array components of structures ("POINT2[]" in FDAT) keep their brackets in the name.
    if (name_end + 1 < limit && text[name_end] == '[' && text[name_end + 1] == ']') name_end += 2;
    component.name_end = name_end;
    pos = SkipBlanks(text, name_end);
    if (pos == name_end && pos < limit && text[pos] != ',' && text[pos] != '}') {
      return fail(pos, "expected a blank between a component's name and its value");
    }
    component.value_begin = pos;
    int depth = 0;
    bool in_string = false;
    while (pos < limit) {
      const char c = text[pos];
      if (in_string) {
        in_string = c != '"';
      } else if (c == '"') {
        in_string = true;
      } else if (c == '{' || c == '(' || c == '[') {
        ++depth;
      } else if (c == ')' || c == ']' || (c == '}' && depth > 0)) {
        if (depth == 0) return fail(pos, std::string("unbalanced '") + c + "'");
        --depth;
      } else if (depth == 0 && (c == ',' || c == '}')) {
        break;
      }
      ++pos;
    }
    if (pos >= limit) return fail(open, "the aggregate has no closing '}'");
    std::size_t value_end = pos;
    while (value_end > component.value_begin && (text[value_end - 1] == ' ' || text[value_end - 1] == '\t')) {
      --value_end;
    }
    component.value_end = value_end;
    if (value_end == component.value_begin) {
      const std::string_view name = text.substr(component.name_begin, component.name_end - component.name_begin);
      return fail(component.name_begin, "the component " + std::string(name) + " has no value");
    }
    aggregate.components.push_back(component);
    if (text[pos] == '}') {
      aggregate.close = pos;
      return aggregate;
    }
    ++pos;  // the ','
  }
}

// The data types of targets, and which components each has.
enum class TargetType { kE6Pos, kPos, kFrame, kE6Axis, kAxis };

std::optional<TargetType> TargetTypeOf(std::string_view word) {
  if (EqualsNoCase(word, "E6POS")) return TargetType::kE6Pos;
  if (EqualsNoCase(word, "POS")) return TargetType::kPos;
  if (EqualsNoCase(word, "FRAME")) return TargetType::kFrame;
  if (EqualsNoCase(word, "E6AXIS")) return TargetType::kE6Axis;
  if (EqualsNoCase(word, "AXIS")) return TargetType::kAxis;
  return std::nullopt;
}

bool IsJointType(TargetType type) { return type == TargetType::kE6Axis || type == TargetType::kAxis; }

// The slot of a component among the target's values (X Y Z A B C or A1..A6), -1 if it is not one of them.
int ValueSlot(std::string_view name, bool joint) {
  static constexpr std::string_view kCartesian[6] = {"X", "Y", "Z", "A", "B", "C"};
  static constexpr std::string_view kJoint[6] = {"A1", "A2", "A3", "A4", "A5", "A6"};
  for (int i = 0; i < 6; ++i) {
    if (EqualsNoCase(name, joint ? kJoint[i] : kCartesian[i])) return i;
  }
  return -1;
}

// E1..E6: the external axes, kept as written.
bool IsExternalAxis(std::string_view name) {
  return name.size() == 2 && (name[0] == 'E' || name[0] == 'e') && name[1] >= '1' && name[1] <= '6';
}

// What the reader keeps of a target beside ProgramTarget: its status and turn as written.
struct TargetBits {
  std::optional<int> status;
  std::optional<int> turn;
};

// A declared FDAT: the tool and base numbers and the interpolation frame a motion that activates it runs with.
struct Fdat {
  int file = 0;
  std::optional<int> tool_no;
  std::optional<int> base_no;
  std::optional<bool> external_tcp;  // IPO_FRAME #TCP: the robot carries the workpiece past a fixed tool
};

// What a motion names as its target: a declared name, an inline aggregate (already a target), or something the
// reader does not compensate (a system variable, a geometric operation).
struct Reference {
  enum class Kind { kOther, kName, kInline } kind = Kind::kOther;
  std::size_t begin = 0;
  std::size_t end = 0;
  int target = -1;  // kInline: the target it is
};

// A statement that changes the frames of the following motions, or (in a WITH clause) of its own motion.
struct FrameAssignment {
  enum class What { kTool, kBase, kIpoMode, kFdatAct } what = What::kTool;
  std::string_view value;  // the right-hand side, trimmed (for BAS(#TOOL, n): n)
};

struct Event {
  int file = 0;
  bool is_motion = false;
  FrameAssignment assignment;  // !is_motion
  // is_motion:
  Motion motion = Motion::kJoint;
  bool evaluates_configuration = false;  // PTP / SPTP: the controller takes S and T
  int line = 0;
  std::size_t begin = 0;
  std::size_t end = 0;
  std::vector<Reference> references;
  std::vector<FrameAssignment> with;
};

// The frames a motion runs in, as the statements before it set them.
struct FrameState {
  std::string tool;
  std::string base;
  bool tool_set = false;
  bool base_set = false;
  bool external_tcp = false;
};

class KrlReader {
 public:
  explicit KrlReader(const std::vector<ProgramFile>& files) {
    sources_.reserve(files.size());
    for (std::size_t i = 0; i < files.size(); ++i) {
      sources_.emplace_back(files[i], static_cast<int>(i));
      const std::string& name = files[i].name;
      const std::size_t slash = name.find_last_of("/\\");
      const std::size_t start = slash == std::string::npos ? 0 : slash + 1;
      const std::size_t dot = name.rfind('.');
      const std::size_t stop = (dot == std::string::npos || dot < start) ? name.size() : dot;
      stems_.push_back(LowerCase(std::string_view(name).substr(start, stop - start)));
    }
  }

  ParsedProgram Read() {
    for (std::size_t f = 0; f < sources_.size(); ++f) ReadFile(static_cast<int>(f));
    ResolveMotions();
    DropFrames();
    return std::move(program_);
  }

 private:
  void ReadFile(int f) {
    const SourceText& source = sources_[f];
    const std::string_view text = source.text();
    for (int line = 1; line <= source.line_count(); ++line) {
      const std::size_t begin = source.LineStart(line);
      const std::size_t line_end = begin + source.Line(line).size();
      // The code ends at the first ';' outside a string: the rest is a comment (folds included).
      std::size_t code_end = line_end;
      bool in_string = false;
      for (std::size_t i = begin; i < line_end; ++i) {
        if (text[i] == '"') {
          in_string = !in_string;
        } else if (text[i] == ';' && !in_string) {
          code_end = i;
          break;
        }
      }
      ReadStatement(f, line, begin, code_end, line_end);
    }
  }

  void ReadStatement(int f, int line, std::size_t begin, std::size_t code_end, std::size_t line_end) {
    const std::string_view text = sources_[f].text();
    const std::size_t first = SkipBlanks(text, begin);
    if (first >= code_end) return;
    const std::size_t word_end = NameEnd(text, first, code_end);
    const std::string_view word = text.substr(first, word_end - first);
    if (word.empty()) return;
    static constexpr struct {
      std::string_view word;
      Motion motion;
      bool evaluates_configuration;
      int references;
    } kMotions[] = {{"PTP", Motion::kJoint, true, 1},      {"SPTP", Motion::kJoint, true, 1},
                    {"LIN", Motion::kLinear, false, 1},    {"SLIN", Motion::kLinear, false, 1},
                    {"SPL", Motion::kLinear, false, 1},    {"CIRC", Motion::kCircular, false, 2},
                    {"SCIRC", Motion::kCircular, false, 2}};
    for (const auto& m : kMotions) {
      if (EqualsNoCase(word, m.word)) {
        ReadMotion(f, line, begin, word_end, code_end, line_end, m.motion, m.evaluates_configuration, m.references);
        return;
      }
    }
    if (EqualsNoCase(word, "BAS")) {
      ReadBas(f, word_end, code_end);
      return;
    }
    // A frame assignment: $TOOL = ..., $BASE = ..., $IPO_MODE = ..., FDAT_ACT = ...
    const std::size_t after = SkipBlanks(text, word_end);
    if (after < code_end && text[after] == '=') {
      static constexpr struct {
        std::string_view word;
        FrameAssignment::What what;
      } kAssignments[] = {{"$TOOL", FrameAssignment::What::kTool},
                          {"$BASE", FrameAssignment::What::kBase},
                          {"$IPO_MODE", FrameAssignment::What::kIpoMode},
                          {"FDAT_ACT", FrameAssignment::What::kFdatAct}};
      for (const auto& a : kAssignments) {
        if (EqualsNoCase(word, a.word)) {
          Event event;
          event.file = f;
          event.assignment = {a.what, Trim(text.substr(after + 1, code_end - after - 1))};
          NoteFrameUse(event.assignment);
          events_.push_back(std::move(event));
          return;
        }
      }
      return;
    }
    ReadDeclaration(f, first, code_end);
  }

  // "[DECL] [GLOBAL] [CONST] TYPE NAME = {...}" for the target types and FDAT; anything else is not read.
  void ReadDeclaration(int f, std::size_t pos, std::size_t code_end) {
    const SourceText& source = sources_[f];
    const std::string_view text = source.text();
    bool decl = false;
    std::string_view type;
    while (pos < code_end) {
      const std::size_t end = NameEnd(text, pos, code_end);
      const std::string_view word = text.substr(pos, end - pos);
      if (word.empty()) return;
      pos = SkipBlanks(text, end);
      if (EqualsNoCase(word, "DECL")) {
        decl = true;
      } else if (!EqualsNoCase(word, "GLOBAL") && !EqualsNoCase(word, "CONST")) {
        type = word;
        break;
      }
    }
    const std::optional<TargetType> target_type = TargetTypeOf(type);
    const bool fdat = EqualsNoCase(type, "FDAT");
    if (!target_type && !fdat) return;
    // Without DECL the line must still read "TYPE NAME =": an assignment "X = ..." is not a declaration.
    const std::size_t name_begin = pos;
    const std::size_t name_end = NameEnd(text, pos, code_end);
    if (name_end == name_begin) return;
    pos = SkipBlanks(text, name_end);
    // Arrays ("DECL E6POS P[10]") and declarations without a value are not targets robocal reads.
    if (pos >= code_end || text[pos] != '=') return;
    pos = SkipBlanks(text, pos + 1);
    const std::string_view name = text.substr(name_begin, name_end - name_begin);
    if (pos >= code_end || text[pos] != '{') {
      if (target_type && decl) source.Fail(pos, std::string(name) + " is not an aggregate {...}");
      return;
    }
    ScanFailure failure;
    const std::optional<Aggregate> aggregate = ScanAggregate(text, pos, code_end, &failure);
    if (fdat) {
      // A malformed FDAT names no frames; the motions using it keep the frames they have.
      if (aggregate) AddFdat(f, name, *aggregate);
      return;
    }
    if (!aggregate) source.Fail(failure.offset, std::string(name) + ": " + failure.reason);
    const int index = AddTarget(f, *aggregate, *target_type, std::string(name));
    declared_[LowerCase(name)].push_back(index);
  }

  void AddFdat(int f, std::string_view name, const Aggregate& aggregate) {
    const std::string_view text = sources_[f].text();
    Fdat fdat;
    fdat.file = f;
    for (const Component& c : aggregate.components) {
      const std::string_view key = text.substr(c.name_begin, c.name_end - c.name_begin);
      const std::string_view value = text.substr(c.value_begin, c.value_end - c.value_begin);
      if (EqualsNoCase(key, "TOOL_NO")) {
        fdat.tool_no = ParseKrlInteger(value);
      } else if (EqualsNoCase(key, "BASE_NO")) {
        fdat.base_no = ParseKrlInteger(value);
      } else if (EqualsNoCase(key, "IPO_FRAME")) {
        fdat.external_tcp = EqualsNoCase(value, "#TCP");
      }
    }
    fdats_[LowerCase(name)].push_back(fdat);
  }

  // Reads a target's aggregate into a new target; `name` empty for an inline target. Throws for a component the
  // type does not have, a value that is not a number, or a missing robot component.
  int AddTarget(int f, const Aggregate& aggregate, TargetType type, std::string name) {
    const SourceText& source = sources_[f];
    const std::string_view text = source.text();
    const std::string what = name.empty() ? "the inline target" : name;
    const bool joint = IsJointType(type);
    const bool external = type == TargetType::kE6Pos || type == TargetType::kE6Axis;
    const bool flags = type == TargetType::kE6Pos || type == TargetType::kPos;

    ProgramTarget target;
    target.file = f;
    target.kind = joint ? TargetKind::kJoint : TargetKind::kCartesian;
    if (!name.empty()) target.name = std::move(name);
    target.values.assign(6, 0.0);
    target.spans.assign(6, NumberSpan{});
    bool seen[6] = {false, false, false, false, false, false};
    TargetBits bits;
    std::vector<std::string_view> seen_other;
    for (const Component& c : aggregate.components) {
      const std::string_view key = text.substr(c.name_begin, c.name_end - c.name_begin);
      const std::string_view value = text.substr(c.value_begin, c.value_end - c.value_begin);
      const int slot = ValueSlot(key, joint);
      if (slot >= 0) {
        if (seen[slot]) source.Fail(c.name_begin, what + " gives " + std::string(key) + " twice");
        const std::optional<ScannedNumber> number = ScanNumber(text, c.value_begin);
        if (!number || number->offset + number->length != c.value_end) {
          source.Fail(c.value_begin, what + ": " + std::string(key) + " is not a number");
        }
        seen[slot] = true;
        target.values[slot] = number->value;
        target.spans[slot] = NumberSpan{f, number->offset, number->length};
        continue;
      }
      const bool is_status = !joint && flags && EqualsNoCase(key, "S");
      const bool is_turn = !joint && flags && EqualsNoCase(key, "T");
      const bool is_external = external && IsExternalAxis(key);
      if (!is_status && !is_turn && !is_external) {
        source.Fail(c.name_begin, what + " has a component " + std::string(key) + " that its type has not");
      }
      for (std::string_view other : seen_other) {
        if (EqualsNoCase(other, key)) source.Fail(c.name_begin, what + " gives " + std::string(key) + " twice");
      }
      seen_other.push_back(key);
      if (is_external) {
        const std::optional<ScannedNumber> number = ScanNumber(text, c.value_begin);
        if (!number || number->offset + number->length != c.value_end) {
          source.Fail(c.value_begin, what + ": " + std::string(key) + " is not a number");
        }
        continue;
      }
      const std::optional<int> integer = ParseKrlInteger(value);
      if (!integer) {
        source.Fail(c.value_begin, what + ": " + std::string(key) +
                                       " is not an integer (decimal, 'B...' binary or 'H...' hexadecimal)");
      }
      (is_status ? bits.status : bits.turn) = *integer;
    }
    for (int i = 0; i < 6; ++i) {
      if (!seen[i]) {
        static constexpr std::string_view kCartesian[6] = {"X", "Y", "Z", "A", "B", "C"};
        const std::string missing = joint ? "A" + std::to_string(i + 1) : std::string(kCartesian[i]);
        source.Fail(aggregate.open, what + " has no " + missing + ": " + kWholeTargets);
      }
    }
    std::size_t first = target.spans[0].offset;
    for (const NumberSpan& span : target.spans) first = std::min(first, span.offset);
    target.line = source.LineOf(first);
    target.column = source.ColumnOf(first);
    if (bits.status) {
      // KSS status bits: bit 0 the wrist point in the overhead area (x < 0 in the A1 frame), bit 1 A3 at or
      // beyond its stretched angle (the wrist in front of the line through A2 and A3), bit 2 A5 <= 0.
      // robocal's elbow is geometric: "up" is towards joint 1's axis direction, seen with the wrist outward from
      // axis 1. KUKA's A1 turns about the base's -z, so on a model with KUKA's directions the usual posture with
      // bit 1 set (home, A2 -90, A3 +90) is robocal's "down"; in the overhead area the arm plane is seen from its
      // other side, so there bit 1 clear is "down".
      target.configuration.shoulder = (*bits.status & 1) ? -1 : 1;
      target.configuration.elbow = ((*bits.status & 2) ? -1 : 1) * target.configuration.shoulder;
      target.configuration.wrist = (*bits.status & 4) ? -1 : 1;
    }
    program_.targets.push_back(std::move(target));
    bits_.push_back(bits);
    return static_cast<int>(program_.targets.size()) - 1;
  }

  // The target an inline aggregate in a motion is: its type from a "{E6POS: ...}" prefix, else from its
  // components (A1..A6 make a joint target).
  int AddInlineTarget(int f, const Aggregate& aggregate) {
    const std::string_view text = sources_[f].text();
    std::optional<TargetType> type = TargetTypeOf(aggregate.type);
    if (!aggregate.type.empty() && !type) {
      sources_[f].Fail(aggregate.open, "the inline target's type " + std::string(aggregate.type) +
                                           " is not E6POS, POS, FRAME, E6AXIS or AXIS");
    }
    if (!type) {
      type = TargetType::kE6Pos;
      for (const Component& c : aggregate.components) {
        if (ValueSlot(text.substr(c.name_begin, c.name_end - c.name_begin), true) >= 0) type = TargetType::kE6Axis;
      }
    }
    return AddTarget(f, aggregate, *type, "");
  }

  // "PTP ref ...", "CIRC via, end ...", with an optional "WITH $TOOL = ..., $BASE = ..." clause.
  void ReadMotion(int f, int line, std::size_t begin, std::size_t pos, std::size_t code_end, std::size_t line_end,
                  Motion motion, bool evaluates_configuration, int count) {
    const SourceText& source = sources_[f];
    const std::string_view text = source.text();
    Event event;
    event.file = f;
    event.is_motion = true;
    event.motion = motion;
    event.evaluates_configuration = evaluates_configuration;
    event.line = line;
    event.begin = begin;
    event.end = line_end;
    // The aggregates are read first and become targets only once the whole statement reads as a motion.
    std::vector<std::optional<Aggregate>> aggregates;
    for (int r = 0; r < count; ++r) {
      pos = SkipBlanks(text, pos);
      if (r > 0) {
        if (pos >= code_end || text[pos] != ',') return;  // not the two points of a circle: nothing to read
        pos = SkipBlanks(text, pos + 1);
      }
      Reference reference;
      reference.begin = pos;
      std::optional<Aggregate> aggregate;
      if (pos < code_end && text[pos] == '{') {
        ScanFailure failure;
        aggregate = ScanAggregate(text, pos, code_end, &failure);
        if (!aggregate) source.Fail(failure.offset, "the inline target: " + failure.reason);
        reference.end = aggregate->close + 1;
        reference.kind = Reference::Kind::kInline;
      } else {
        std::size_t end = NameEnd(text, pos, code_end);
        if (end == pos) return;  // an expression the reader does not follow
        reference.kind = Reference::Kind::kName;
        if (end < code_end && text[end] == '[') {
          // An array element names no target robocal reads; still step over it to find what follows.
          const std::size_t close = text.find(']', end);
          if (close == std::string_view::npos || close >= code_end) return;
          end = close + 1;
          reference.kind = Reference::Kind::kOther;
        }
        reference.end = end;
      }
      pos = SkipBlanks(text, reference.end);
      // "BASE_DATA[1]:XP1", "XP1:{X 10}": a geometric operation computes a new target from the written ones,
      // which are frames to it.
      while (pos < code_end && text[pos] == ':') {
        if (reference.kind == Reference::Kind::kName) {
          NoteFrameUse(text.substr(reference.begin, reference.end - reference.begin));
        }
        reference.kind = Reference::Kind::kOther;
        pos = SkipBlanks(text, pos + 1);
        const std::size_t operand = pos;
        if (pos < code_end && text[pos] == '{') {
          const std::size_t close = text.find('}', pos);
          if (close == std::string_view::npos || close >= code_end) return;
          pos = close + 1;
        } else {
          pos = NameEnd(text, pos, code_end);
          if (pos == operand) return;
          NoteFrameUse(text.substr(operand, pos - operand));
          if (pos < code_end && text[pos] == '[') {
            const std::size_t close = text.find(']', pos);
            if (close == std::string_view::npos || close >= code_end) return;
            pos = close + 1;
          }
        }
        reference.end = pos;
        pos = SkipBlanks(text, pos);
      }
      event.references.push_back(reference);
      aggregates.push_back(std::move(aggregate));
    }
    for (std::size_t r = 0; r < event.references.size(); ++r) {
      if (event.references[r].kind == Reference::Kind::kInline) {
        event.references[r].target = AddInlineTarget(f, *aggregates[r]);
      }
    }
    ReadWith(f, pos, code_end, &event.with);
    events_.push_back(std::move(event));
  }

  // The WITH clause of a spline motion: its $TOOL / $BASE / $IPO_MODE hold for this motion alone.
  void ReadWith(int f, std::size_t pos, std::size_t code_end, std::vector<FrameAssignment>* with) {
    const std::string_view text = sources_[f].text();
    // Step over the motion's other parameters (C_PTP, CA 90.0, ...) to the WITH keyword.
    while (pos < code_end && !WordAt(text, pos, "WITH")) {
      if (text[pos] == '"') {
        const std::size_t close = text.find('"', pos + 1);
        if (close == std::string_view::npos || close >= code_end) return;
        pos = close + 1;
      } else if (IsNameChar(text[pos])) {
        while (pos < code_end && IsNameChar(text[pos])) ++pos;  // a whole word: WITH only where a word starts
      } else {
        ++pos;
      }
    }
    if (pos >= code_end) return;
    pos += 4;
    // Assignments separated by commas outside brackets and strings.
    while (pos < code_end) {
      std::size_t end = pos;
      int depth = 0;
      bool in_string = false;
      while (end < code_end) {
        const char c = text[end];
        if (in_string) {
          in_string = c != '"';
        } else if (c == '"') {
          in_string = true;
        } else if (c == '(' || c == '[' || c == '{') {
          ++depth;
        } else if ((c == ')' || c == ']' || c == '}') && depth > 0) {
          --depth;
        } else if (c == ',' && depth == 0) {
          break;
        }
        ++end;
      }
      const std::string_view item = Trim(text.substr(pos, end - pos));
      const std::size_t equals = item.find('=');
      if (equals != std::string_view::npos) {
        const std::string_view lhs = Trim(item.substr(0, equals));
        const std::string_view rhs = Trim(item.substr(equals + 1));
        if (EqualsNoCase(lhs, "$TOOL")) with->push_back({FrameAssignment::What::kTool, rhs});
        if (EqualsNoCase(lhs, "$BASE")) with->push_back({FrameAssignment::What::kBase, rhs});
        if (EqualsNoCase(lhs, "$IPO_MODE")) with->push_back({FrameAssignment::What::kIpoMode, rhs});
        if (EqualsNoCase(lhs, "$TOOL") || EqualsNoCase(lhs, "$BASE")) NoteFrameUse(rhs);
      }
      pos = end + 1;
    }
  }

  // BAS(#TOOL, n) and BAS(#BASE, n), the technology package's way of selecting frames.
  void ReadBas(int f, std::size_t pos, std::size_t code_end) {
    const std::string_view text = sources_[f].text();
    pos = SkipBlanks(text, pos);
    if (pos >= code_end || text[pos] != '(') return;
    const std::size_t close = text.find(')', pos);
    if (close == std::string_view::npos || close >= code_end) return;
    const std::string_view arguments = text.substr(pos + 1, close - pos - 1);
    const std::size_t comma = arguments.find(',');
    if (comma == std::string_view::npos) return;
    const std::string_view which = Trim(arguments.substr(0, comma));
    const std::string_view number = Trim(arguments.substr(comma + 1));
    Event event;
    event.file = f;
    if (EqualsNoCase(which, "#TOOL")) {
      event.assignment = {FrameAssignment::What::kTool, number};
    } else if (EqualsNoCase(which, "#BASE")) {
      event.assignment = {FrameAssignment::What::kBase, number};
    } else {
      return;
    }
    events_.push_back(std::move(event));
  }

  // The declaration of `key` (lower case) a statement of file `f` sees: its own file's, then its module's (the
  // .dat of the same name), then the first in the request's order (GLOBAL data).
  template <typename Item, typename FileOf>
  const Item* Visible(const std::unordered_map<std::string, std::vector<Item>>& map, const std::string& key, int f,
                      FileOf file_of) const {
    const auto it = map.find(key);
    if (it == map.end() || it->second.empty()) return nullptr;
    for (const Item& item : it->second) {
      if (file_of(item) == f) return &item;
    }
    for (const Item& item : it->second) {
      if (stems_[file_of(item)] == stems_[f]) return &item;
    }
    return &it->second.front();
  }

  const Fdat* FdatNamed(std::string_view name, int f) const {
    return Visible(fdats_, LowerCase(Trim(name)), f, [](const Fdat& d) { return d.file; });
  }

  // "F.TOOL_NO" / "F.BASE_NO" of an FDAT, or an integer literal.
  std::optional<int> FrameNumber(std::string_view text, int f) const {
    text = Trim(text);
    if (const std::optional<int> n = ParseKrlInteger(text)) return n;
    const std::size_t dot = text.find('.');
    if (dot == std::string_view::npos) return std::nullopt;
    const Fdat* fdat = FdatNamed(text.substr(0, dot), f);
    if (!fdat) return std::nullopt;
    const std::string_view field = Trim(text.substr(dot + 1));
    if (EqualsNoCase(field, "TOOL_NO")) return fdat->tool_no;
    if (EqualsNoCase(field, "BASE_NO")) return fdat->base_no;
    return std::nullopt;
  }

  // `value` as "NAME[inner]" or "NAME(inner)": NAME and inner, or false.
  static bool SplitCall(std::string_view value, std::string_view* name, std::string_view* inner) {
    const std::size_t end = NameEnd(value, 0, value.size());
    if (end == 0) return false;
    const std::size_t open = SkipBlanks(value, end);
    if (open >= value.size() || (value[open] != '[' && value[open] != '(')) return false;
    const char close = value[open] == '[' ? ']' : ')';
    if (value.back() != close || value.size() < open + 2) return false;
    *name = value.substr(0, end);
    *inner = value.substr(open + 1, value.size() - open - 2);
    return true;
  }

  // The tool a $TOOL value selects: "n" for TOOL_DATA[n] (n an integer or an FDAT's TOOL_NO), STOOL2(FDAT) of
  // the spline inline forms, "0" for $NULLFRAME (the flange), else the expression as written (the request then
  // has to name it).
  std::string ToolOf(std::string_view value, int f) const {
    value = Trim(value);
    if (EqualsNoCase(value, "$NULLFRAME")) return "0";
    if (const std::optional<int> n = ParseKrlInteger(value)) return std::to_string(*n);
    std::string_view name, inner;
    if (SplitCall(value, &name, &inner)) {
      std::optional<int> n;
      if (EqualsNoCase(name, "TOOL_DATA")) n = FrameNumber(inner, f);
      if (EqualsNoCase(name, "STOOL2") || EqualsNoCase(name, "STOOL")) {
        if (const Fdat* fdat = FdatNamed(inner, f)) n = fdat->tool_no;
      }
      if (n) return std::to_string(*n);
    }
    return std::string(value);
  }

  // The base a $BASE value selects: "" for base 0 and $NULLFRAME (the robot's base), "n" for BASE_DATA[n] and
  // SBASE(FDAT.BASE_NO), else the expression as written.
  std::string BaseOf(std::string_view value, int f) const {
    value = Trim(value);
    if (EqualsNoCase(value, "$NULLFRAME")) return "";
    std::optional<int> n = ParseKrlInteger(value);
    std::string_view name, inner;
    if (!n && SplitCall(value, &name, &inner) && (EqualsNoCase(name, "BASE_DATA") || EqualsNoCase(name, "SBASE"))) {
      n = FrameNumber(inner, f);
    }
    if (n) return *n == 0 ? "" : std::to_string(*n);
    return std::string(value);
  }

  // Whether an $IPO_MODE value is the external TCP; nullopt when the reader cannot tell.
  std::optional<bool> ExternalTcpOf(std::string_view value, int f) const {
    value = Trim(value);
    if (EqualsNoCase(value, "#TCP")) return true;
    if (EqualsNoCase(value, "#BASE")) return false;
    std::string_view name, inner;
    if (SplitCall(value, &name, &inner) && EqualsNoCase(name, "SIPO_MODE")) {
      const std::size_t dot = inner.find('.');
      if (const Fdat* fdat = FdatNamed(inner.substr(0, dot), f)) return fdat->external_tcp;
    }
    return std::nullopt;
  }

  void ApplyFdat(const Fdat& fdat, FrameState* state) const {
    if (fdat.tool_no) {
      state->tool = std::to_string(*fdat.tool_no);
      state->tool_set = true;
    }
    if (fdat.base_no) {
      state->base = *fdat.base_no == 0 ? "" : std::to_string(*fdat.base_no);
      state->base_set = true;
    }
    if (fdat.external_tcp) state->external_tcp = *fdat.external_tcp;
  }

  void Apply(const FrameAssignment& assignment, int f, FrameState* state) const {
    switch (assignment.what) {
      case FrameAssignment::What::kTool:
        state->tool = ToolOf(assignment.value, f);
        state->tool_set = true;
        break;
      case FrameAssignment::What::kBase:
        state->base = BaseOf(assignment.value, f);
        state->base_set = true;
        break;
      case FrameAssignment::What::kIpoMode:
        if (const std::optional<bool> tcp = ExternalTcpOf(assignment.value, f)) state->external_tcp = *tcp;
        break;
      case FrameAssignment::What::kFdatAct:
        if (const Fdat* fdat = FdatNamed(assignment.value, f)) ApplyFdat(*fdat, state);
        break;
    }
  }

  // A name used as a frame: "$BASE = fFixture", or an operand of the geometric operator ':'.
  void NoteFrameUse(std::string_view name) {
    name = Trim(name);
    if (!name.empty() && NameEnd(name, 0, name.size()) == name.size()) frame_uses_.insert(LowerCase(name));
  }
  void NoteFrameUse(const FrameAssignment& assignment) {
    if (assignment.what == FrameAssignment::What::kTool || assignment.what == FrameAssignment::What::kBase) {
      NoteFrameUse(assignment.value);
    }
  }

  // A declared value that no motion moves to and that the program uses as a frame is a frame, not a target:
  // compensating it would move every point programmed in it.
  void DropFrames() {
    if (frame_uses_.empty()) return;
    std::vector<int> new_index(program_.targets.size(), -1);
    std::vector<ProgramTarget> kept;
    kept.reserve(program_.targets.size());
    for (std::size_t i = 0; i < program_.targets.size(); ++i) {
      ProgramTarget& t = program_.targets[i];
      if (t.name && t.motion == Motion::kNone && frame_uses_.count(LowerCase(*t.name))) continue;
      new_index[i] = static_cast<int>(kept.size());
      kept.push_back(std::move(t));
    }
    program_.targets = std::move(kept);
    for (MotionStatement& m : program_.motions) m.target = new_index[m.target];
  }

  // The second pass: the motions in program order, each with the frames the statements before it set.
  void ResolveMotions() {
    FrameState state;
    for (const Event& event : events_) {
      if (!event.is_motion) {
        Apply(event.assignment, event.file, &state);
        continue;
      }
      FrameState frames = state;
      for (const FrameAssignment& with : event.with) Apply(with, event.file, &frames);
      const SourceText& source = sources_[event.file];
      for (const Reference& reference : event.references) {
        int index = reference.target;
        FrameState own = frames;
        if (reference.kind == Reference::Kind::kName) {
          const std::string_view name = source.text().substr(reference.begin, reference.end - reference.begin);
          const int* declared =
              Visible(declared_, LowerCase(name), event.file, [&](int t) { return program_.targets[t].file; });
          if (!declared) continue;  // declared outside the request's files ($config.dat's XHOME): not read
          index = *declared;
          // The inline forms pair point XP1 with its FDAT FP1; a program whose frame statements were left out
          // still names its frames that way.
          if ((!own.tool_set || !own.base_set) && name.size() > 1 && (name[0] == 'X' || name[0] == 'x')) {
            if (const Fdat* fdat = FdatNamed("F" + std::string(name.substr(1)), event.file)) {
              FrameState convention;
              ApplyFdat(*fdat, &convention);
              if (!own.tool_set && convention.tool_set) own.tool = convention.tool;
              if (!own.base_set && convention.base_set) own.base = convention.base;
              if (convention.external_tcp) own.external_tcp = true;
            }
          }
        }
        if (index < 0) continue;
        if (own.external_tcp) {
          source.Fail(reference.begin,
                      "the motion runs with an external TCP (IPO_FRAME #TCP), which robocal does not compensate");
        }
        MotionStatement statement;
        statement.target = index;
        statement.motion = event.motion;
        statement.file = event.file;
        statement.line = event.line;
        statement.begin = event.begin;
        statement.end = event.end;
        statement.reference_begin = reference.begin;
        statement.reference_end = reference.end;
        program_.motions.push_back(statement);
        ProgramTarget& target = program_.targets[index];
        if (target.motion != Motion::kNone) continue;
        target.motion = event.motion;
        target.tool = own.tool;
        target.base = own.base;
        const TargetBits& bits = bits_[index];
        // KRL takes S and T for PTP only; the via point of a circle never (it is a CIRC).
        if (target.kind == TargetKind::kCartesian && event.evaluates_configuration && bits.status) {
          target.configuration_applies = true;
          if (bits.turn) {
            for (int joint = 0; joint < 6; ++joint) {
              const bool negative = (*bits.turn >> joint) & 1;
              target.turns.push_back(negative ? JointRange{joint, -kInfinity, 0.0} : JointRange{joint, 0.0, kInfinity});
            }
          }
        }
      }
    }
  }

  std::vector<SourceText> sources_;
  std::vector<std::string> stems_;  // lower-case file names without directory and extension
  ParsedProgram program_;
  std::vector<TargetBits> bits_;  // per target
  std::unordered_map<std::string, std::vector<int>> declared_;
  std::unordered_map<std::string, std::vector<Fdat>> fdats_;
  std::vector<Event> events_;
  std::unordered_set<std::string> frame_uses_;  // lower-case names the program uses as frames
};

ParsedProgram ReadKrl(const std::vector<ProgramFile>& files) { return KrlReader(files).Read(); }

// The inserted target: X Y Z A B C as given, then the status, turn and external axes of `like` as written.
std::string KrlInlineTarget(const ProgramTarget& like, const std::vector<ProgramFile>& files,
                            const std::vector<double>& values) {
  if (like.kind != TargetKind::kCartesian || values.size() < 6) return "";
  static constexpr const char* kNames[6] = {"X", "Y", "Z", "A", "B", "C"};
  std::string out = "{";
  for (int i = 0; i < 6; ++i) {
    if (i > 0) out += ',';
    out += kNames[i];
    out += ' ';
    out += FormatInserted(values[i], i < 3 ? NumberUnit::kMm : NumberUnit::kDeg);
  }
  // `like`'s aggregate: the '{' before its first number on the same line.
  if (like.file >= 0 && static_cast<std::size_t>(like.file) < files.size() && !like.spans.empty()) {
    const std::string_view text = files[like.file].text;
    std::size_t at = like.spans[0].offset;
    for (const NumberSpan& span : like.spans) at = std::min(at, span.offset);
    if (at < text.size()) {
      std::size_t open = at;
      while (open > 0 && text[open] != '{' && text[open] != '\n' && text[open] != '\r') --open;
      std::size_t limit = at;
      while (limit < text.size() && text[limit] != '\n' && text[limit] != '\r') ++limit;
      ScanFailure failure;
      if (text[open] == '{') {
        if (const std::optional<Aggregate> aggregate = ScanAggregate(text, open, limit, &failure)) {
          for (const Component& c : aggregate->components) {
            const std::string_view key = text.substr(c.name_begin, c.name_end - c.name_begin);
            if (EqualsNoCase(key, "S") || EqualsNoCase(key, "T") || IsExternalAxis(key)) {
              out += ',';
              out += key;
              out += ' ';
              out += text.substr(c.value_begin, c.value_end - c.value_begin);
            }
          }
        }
      }
    }
  }
  out += '}';
  return out;
}

}  // namespace

const DialectSyntax& KrlSyntax() {
  static const DialectSyntax syntax{.dialect = Dialect::kKrl,
                                    .name = "krl",
                                    .extensions = {".src", ".dat"},
                                    .rotation = RotationConvention::kZyxIntrinsicDeg,
                                    .mm_per_length_unit = 1.0,
                                    .joints_in_rad = false,
                                    .read = &ReadKrl,
                                    .inline_target = &KrlInlineTarget};
  return syntax;
}

}  // namespace robocal::programs
