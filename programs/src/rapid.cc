// ABB RAPID reader: robtarget and jointtarget declarations (CONST, PERS, VAR, arrays included) and the inline
// targets of the motion instructions (MoveJ, MoveL, MoveC, MoveAbsJ and their DO / AO / GO / Sync / Trigg
// variants), with the motions in text order and the ConfJ / ConfL monitoring that decides whether a target's
// configuration data apply. One linear pass per file over the text; names are resolved once all files are read,
// since a module may move to a target another module declares. docs/programs.md ("ABB RAPID") gives the mapping
// of confdata onto robocal's flags and turns.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "robocal/programs/program.h"
#include "robocal/programs/text_scan.h"

// The reader's own names live in their namespace: a unity build puts the dialects' files in one translation unit.
namespace robocal::programs::rapid {
namespace {

constexpr double kQuadrantRad = std::numbers::pi / 2.0;
// RAPID declares at most 3 array dimensions.
constexpr int kMaxDimensions = 3;

bool IsLetter(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); }
bool IsDigit(char c) { return c >= '0' && c <= '9'; }
bool IsIdentifierChar(char c) { return IsLetter(c) || IsDigit(c) || c == '_'; }

std::size_t IdentifierEnd(std::string_view text, std::size_t pos) {
  while (pos < text.size() && IsIdentifierChar(text[pos])) ++pos;
  return pos;
}

// Past a '!' comment: to its line end (not included).
std::size_t CommentEnd(std::string_view text, std::size_t pos) {
  while (pos < text.size() && text[pos] != '\n' && text[pos] != '\r') ++pos;
  return pos;
}

// Past a string starting at its '"' ("" is a quote inside it). A string does not span lines in RAPID, so an
// unterminated one ends at its line end rather than swallowing the rest of the file.
std::size_t StringEnd(std::string_view text, std::size_t pos) {
  ++pos;
  while (pos < text.size() && text[pos] != '\n' && text[pos] != '\r') {
    if (text[pos] == '"') {
      if (pos + 1 < text.size() && text[pos + 1] == '"') {
        pos += 2;
        continue;
      }
      return pos + 1;
    }
    ++pos;
  }
  return pos;
}

// The first byte at or after `pos` that is neither white space nor inside a comment.
std::size_t SkipSpace(std::string_view text, std::size_t pos) {
  while (true) {
    pos = SkipWhitespace(text, pos);
    if (pos < text.size() && text[pos] == '!') {
      pos = CommentEnd(text, pos);
    } else {
      return pos;
    }
  }
}

// A name as RAPID compares it (case-insensitive), without blanks ("path{ 2 }" is "path{2}").
std::string NameKey(std::string_view name) {
  std::string key;
  key.reserve(name.size());
  for (char c : name) {
    if (c != ' ' && c != '\t' && c != '\r' && c != '\n') key.push_back(c);
  }
  return LowerCase(key);
}

// Reads the aggregates of one text. Errors name `source` when given; without it (inline_target reading a target
// the reader found before) a failure is the caller's mistake.
class Aggregates {
 public:
  Aggregates(std::string_view text, const SourceText* source) : text_(text), source_(source) {}

  [[noreturn]] void Fail(std::size_t pos, const std::string& reason) const {
    if (source_ != nullptr) source_->Fail(pos, reason);
    throw std::invalid_argument("not a RAPID target: " + reason);
  }

  void Expect(std::size_t pos, char c, const std::string& what) const {
    if (pos >= text_.size() || text_[pos] != c) Fail(pos, std::string("expected '") + c + "' " + what);
  }

  // "[n, n, ...]" with exactly `count` numbers at `pos` (after blanks and comments); returns the position after
  // its ']'. `what` names the component for errors ("the position of a robtarget").
  std::size_t List(std::size_t pos, int count, const std::string& what, std::vector<ScannedNumber>* numbers) const {
    pos = SkipSpace(text_, pos);
    Expect(pos, '[', "to open " + what);
    pos = SkipSpace(text_, pos + 1);
    for (int i = 0; i < count; ++i) {
      const std::optional<ScannedNumber> number = ScanNumber(text_, pos);
      if (!number) Fail(pos, "expected a number in " + what);
      numbers->push_back(*number);
      pos = SkipSpace(text_, pos + number->length);
      if (i + 1 < count) {
        if (pos < text_.size() && text_[pos] == ']') {
          Fail(pos, what + " has " + std::to_string(i + 1) + " values, expected " + std::to_string(count));
        }
        Expect(pos, ',', "between the values of " + what);
        pos = SkipSpace(text_, pos + 1);
      }
    }
    if (pos < text_.size() && text_[pos] == ',')
      Fail(pos, what + " has more than " + std::to_string(count) + " values");
    Expect(pos, ']', "to close " + what);
    return pos + 1;
  }

  std::size_t Comma(std::size_t pos, const std::string& what) const {
    pos = SkipSpace(text_, pos);
    Expect(pos, ',', what);
    return pos + 1;
  }

 private:
  std::string_view text_;
  const SourceText* source_;
};

// One target literal: its kind, numbers (robtarget: 3 + 4 + confdata 4 + extax 6; jointtarget: 6 + extax 6) and
// its bytes [begin, end).
struct Literal {
  TargetKind kind = TargetKind::kCartesian;
  std::vector<ScannedNumber> numbers;
  std::size_t begin = 0;
  std::size_t end = 0;
};

// The literal at `pos` (its '['): "[[x,y,z],[q1,q2,q3,q4],[cf1,cf4,cf6,cfx],[eax_a..eax_f]]" or
// "[[j1..j6],[eax_a..eax_f]]".
Literal ReadLiteral(const Aggregates& in, std::string_view text, std::size_t pos, TargetKind kind) {
  Literal literal;
  literal.kind = kind;
  literal.begin = pos;
  in.Expect(pos, '[', kind == TargetKind::kCartesian ? "to open a robtarget" : "to open a jointtarget");
  ++pos;
  literal.numbers.reserve(17);
  if (kind == TargetKind::kCartesian) {
    pos = in.List(pos, 3, "the position of a robtarget", &literal.numbers);
    pos = in.List(in.Comma(pos, "after a robtarget's position"), 4, "the orientation of a robtarget", &literal.numbers);
    pos = in.List(in.Comma(pos, "after a robtarget's orientation"), 4, "the confdata of a robtarget", &literal.numbers);
    pos =
        in.List(in.Comma(pos, "after a robtarget's confdata"), 6, "the external axes of a robtarget", &literal.numbers);
  } else {
    pos = in.List(pos, 6, "the robot axes of a jointtarget", &literal.numbers);
    pos = in.List(in.Comma(pos, "after a jointtarget's robot axes"), 6, "the external axes of a jointtarget",
                  &literal.numbers);
  }
  pos = SkipSpace(text, pos);
  in.Expect(pos, ']', kind == TargetKind::kCartesian ? "to close a robtarget" : "to close a jointtarget");
  literal.end = pos + 1;
  return literal;
}

// confdata's integers: a confdata value written with decimals or beyond int range is not one (the negated test
// also refuses NaN).
int ConfValue(const Aggregates& in, const ScannedNumber& number) {
  constexpr double kLow = std::numeric_limits<int>::min();
  constexpr double kHigh = std::numeric_limits<int>::max();
  if (!(number.value >= kLow && number.value <= kHigh) || number.value != std::floor(number.value)) {
    in.Fail(number.offset, "a confdata value must be an integer within +-2^31");
  }
  return static_cast<int>(number.value);
}

// The target a literal is: values and spans, and for a robtarget its flags (cfx) and turns (cf1, cf4, cf6).
ProgramTarget TargetOf(const SourceText& source, const Aggregates& in, const Literal& literal) {
  ProgramTarget target;
  target.file = source.file_index();
  target.kind = literal.kind;
  const int count = literal.kind == TargetKind::kCartesian ? 7 : 6;
  for (int i = 0; i < count; ++i) {
    const ScannedNumber& n = literal.numbers[i];
    target.values.push_back(n.value);
    target.spans.push_back({source.file_index(), n.offset, n.length});
  }
  target.line = source.LineOf(literal.numbers[0].offset);
  target.column = source.ColumnOf(literal.numbers[0].offset);
  if (literal.kind == TargetKind::kCartesian) {
    const int cf1 = ConfValue(in, literal.numbers[7]);
    const int cf4 = ConfValue(in, literal.numbers[8]);
    const int cf6 = ConfValue(in, literal.numbers[9]);
    const int cfx = ConfValue(in, literal.numbers[10]);
    // The quadrant n of an axis is [n * 90, (n + 1) * 90) deg (quadrant -1 is -90..0 deg).
    // (In double: cf + 1 overflows int at INT_MAX.)
    target.turns = {{0, cf1 * kQuadrantRad, (cf1 + 1.0) * kQuadrantRad},
                    {3, cf4 * kQuadrantRad, (cf4 + 1.0) * kQuadrantRad},
                    {5, cf6 * kQuadrantRad, (cf6 + 1.0) * kQuadrantRad}};
    // cfx 0..7 of ABB's serial 6-axis robots: bit 2 the wrist centre behind axis 1, bit 1 behind the lower arm,
    // bit 0 axis 5 negative. "In front of the lower arm" is measured in the lower arm's own frame, while
    // robocal's elbow is "above the shoulder-wrist line, seen with the wrist outward"; both agree while the wrist
    // is in front of axis 1 and are opposite behind it (the arm plane is seen from its other side).
    if (cfx >= 0 && cfx <= 7) {
      const int shoulder = (cfx & 4) ? -1 : 1;
      const int lower_arm = (cfx & 2) ? -1 : 1;
      target.configuration.shoulder = shoulder;
      target.configuration.elbow = lower_arm * shoulder;
      target.configuration.wrist = (cfx & 1) ? -1 : 1;
    }
    // Other cfx values (other robot families) name no flag robocal knows: left free.
  }
  return target;
}

// The motion instructions read, with the positional argument that holds the tool (0-based, counting the target
// arguments) and which ConfJ / ConfL monitoring governs them.
enum class Monitor { kNone, kJoint, kLinear };
struct Instruction {
  const char* name;
  Motion motion;
  int points;      // target arguments: 1, or 2 for a circle (via point, end point)
  int tool_index;  // positional argument holding the tool
  TargetKind kind;
  Monitor monitor;
};

constexpr Instruction kInstructions[] = {
    {"MoveJ", Motion::kJoint, 1, 3, TargetKind::kCartesian, Monitor::kJoint},
    {"MoveL", Motion::kLinear, 1, 3, TargetKind::kCartesian, Monitor::kLinear},
    {"MoveC", Motion::kCircular, 2, 4, TargetKind::kCartesian, Monitor::kLinear},
    {"MoveAbsJ", Motion::kJoint, 1, 3, TargetKind::kJoint, Monitor::kNone},
    // Set an output / call a procedure at the target: ToPoint, Speed, Zone, Tool, then their own arguments.
    {"MoveJDO", Motion::kJoint, 1, 3, TargetKind::kCartesian, Monitor::kJoint},
    {"MoveLDO", Motion::kLinear, 1, 3, TargetKind::kCartesian, Monitor::kLinear},
    {"MoveCDO", Motion::kCircular, 2, 4, TargetKind::kCartesian, Monitor::kLinear},
    {"MoveJAO", Motion::kJoint, 1, 3, TargetKind::kCartesian, Monitor::kJoint},
    {"MoveLAO", Motion::kLinear, 1, 3, TargetKind::kCartesian, Monitor::kLinear},
    {"MoveCAO", Motion::kCircular, 2, 4, TargetKind::kCartesian, Monitor::kLinear},
    {"MoveJGO", Motion::kJoint, 1, 3, TargetKind::kCartesian, Monitor::kJoint},
    {"MoveLGO", Motion::kLinear, 1, 3, TargetKind::kCartesian, Monitor::kLinear},
    {"MoveCGO", Motion::kCircular, 2, 4, TargetKind::kCartesian, Monitor::kLinear},
    {"MoveJSync", Motion::kJoint, 1, 3, TargetKind::kCartesian, Monitor::kJoint},
    {"MoveLSync", Motion::kLinear, 1, 3, TargetKind::kCartesian, Monitor::kLinear},
    {"MoveCSync", Motion::kCircular, 2, 4, TargetKind::kCartesian, Monitor::kLinear},
    // Triggered moves: ToPoint, Speed, Trigg_1, Zone, Tool (\T2.. are optional arguments).
    {"TriggJ", Motion::kJoint, 1, 4, TargetKind::kCartesian, Monitor::kJoint},
    {"TriggL", Motion::kLinear, 1, 4, TargetKind::kCartesian, Monitor::kLinear},
    {"TriggC", Motion::kCircular, 2, 5, TargetKind::kCartesian, Monitor::kLinear},
};

const Instruction* InstructionNamed(std::string_view word) {
  if (word.size() < 5) return nullptr;
  for (const Instruction& instruction : kInstructions) {
    if (EqualsNoCase(word, instruction.name)) return &instruction;
  }
  return nullptr;
}

// One argument of an instruction: a positional one, or an optional one ("\WObj:=wobj1", "\Conc"), as the bytes
// [begin, end) without surrounding blanks and comments (optional ones without their '\').
struct Argument {
  bool optional = false;
  std::size_t begin = 0;
  std::size_t end = 0;
};

// A motion whose target is known by name only until every file is read.
struct PendingMotion {
  MotionStatement statement;
  int target = -1;  // inline: its index; else resolved from `key`
  std::string key;
  std::string name;                // lower-case name of a reference; empty for an inline target
  std::vector<long long> indexes;  // its constant indexes
  TargetKind kind = TargetKind::kCartesian;
  bool configuration_monitored = true;
  std::string tool;
  std::string base;
};

struct Declared {
  int file = 0;
  int target = 0;
};

// An index beyond any array dimension (they are at most 1e9): larger written indexes are clamped to it.
constexpr long long kHugeIndex = 1'000'000'000'000LL;

// A plain reference: a name, or an array element with constant indexes ("path{2}", "grid{ 2, +1 }", "p{-1}").
// Function calls (Offs, RelTool, CRobT), record components and computed indexes are not.
struct Reference {
  std::string base;                // lower case
  std::vector<long long> indexes;  // empty: no braces
  // The key of the element as declarations are keyed (NameKey of "name{i,j}", indexes without sign or zeros).
  std::string Key() const {
    std::string key = base;
    if (!indexes.empty()) {
      key += '{';
      for (std::size_t i = 0; i < indexes.size(); ++i) {
        if (i > 0) key += ',';
        key += std::to_string(indexes[i]);
      }
      key += '}';
    }
    return key;
  }
};

std::optional<Reference> ParseReference(std::string_view text) {
  if (text.empty() || !IsLetter(text[0])) return std::nullopt;
  Reference reference;
  std::size_t i = IdentifierEnd(text, 0);
  reference.base = LowerCase(text.substr(0, i));
  if (i == text.size()) return reference;
  i = SkipBlanks(text, i);
  if (i >= text.size() || text[i] != '{' || text.back() != '}') return std::nullopt;
  ++i;
  while (true) {
    i = SkipBlanks(text, i);
    bool negative = false;
    if (i < text.size() && (text[i] == '+' || text[i] == '-')) {
      negative = text[i] == '-';
      i = SkipBlanks(text, i + 1);
    }
    if (i >= text.size() || !IsDigit(text[i])) return std::nullopt;
    long long value = 0;
    for (; i < text.size() && IsDigit(text[i]); ++i) value = std::min(kHugeIndex, value * 10 + (text[i] - '0'));
    reference.indexes.push_back(negative ? -value : value);
    i = SkipBlanks(text, i);
    if (i < text.size() && text[i] == ',') {
      ++i;
      continue;
    }
    if (i + 1 != text.size()) return std::nullopt;  // only the closing '}' may follow
    return reference;
  }
}

// The shape a target name is declared with: an array's dimensions (empty: not an array), or a routine's array
// parameter of any size ("{*}", `open`, with its number of dimensions).
struct Shape {
  int file = 0;
  TargetKind kind = TargetKind::kCartesian;
  std::vector<long> dimensions;
  bool open = false;
  std::string name;  // as declared
  // Whether `indexes` name the whole target (no indexes, not an array) or one element inside it.
  bool Admits(const std::vector<long long>& indexes) const {
    if (indexes.size() != dimensions.size()) return false;
    if (open) return true;
    for (std::size_t i = 0; i < indexes.size(); ++i) {
      if (indexes[i] < 1 || indexes[i] > dimensions[i]) return false;
    }
    return true;
  }
  std::string Written() const {
    std::string text = name;
    if (!dimensions.empty()) {
      text += '{';
      for (std::size_t i = 0; i < dimensions.size(); ++i) {
        if (i > 0) text += ',';
        text += open ? std::string("*") : std::to_string(dimensions[i]);
      }
      text += '}';
    }
    return text;
  }
};

class Reader {
 public:
  Reader(ParsedProgram* program, const std::vector<ProgramFile>& files) : program_(program), files_(files) {}

  void ReadFile(const ProgramFile& file, int file_index) {
    const SourceText source(file, file_index);
    const std::string_view text = source.text();
    const Aggregates in(text, &source);
    std::size_t pos = 0;
    while (true) {
      pos = SkipSpace(text, pos);
      if (pos >= text.size()) break;
      const char c = text[pos];
      if (c == '"') {
        pos = StringEnd(text, pos);
      } else if (IsLetter(c)) {
        const std::size_t end = IdentifierEnd(text, pos);
        const std::string_view word = text.substr(pos, end - pos);
        // A record component ("p10.trans") or a late-bound name is never a statement's first word.
        const bool component = pos > 0 && text[pos - 1] == '.';
        if (component) {
          pos = end;
        } else if (EqualsNoCase(word, "CONST") || EqualsNoCase(word, "PERS") || EqualsNoCase(word, "VAR")) {
          pos = Declaration(source, in, end);
        } else if (EqualsNoCase(word, "ConfJ") || EqualsNoCase(word, "ConfL")) {
          pos = Monitoring(text, end, EqualsNoCase(word, "ConfJ") ? &conf_j_on_ : &conf_l_on_);
        } else if (EqualsNoCase(word, "robtarget") || EqualsNoCase(word, "jointtarget")) {
          Parameter(source, end, EqualsNoCase(word, "robtarget") ? TargetKind::kCartesian : TargetKind::kJoint);
          pos = end;
        } else if (const Instruction* instruction = InstructionNamed(word)) {
          pos = MotionStatementAt(source, in, pos, end, *instruction);
        } else {
          pos = end;
        }
      } else if (IsDigit(c)) {
        // A number's digits and exponent ("9E9") are no identifier.
        while (pos < text.size() && (IsIdentifierChar(text[pos]) || text[pos] == '.')) ++pos;
      } else {
        ++pos;
      }
    }
  }

  // Joins the motions to the targets they name, in program order, and gives each target its first motion.
  void Finish() {
    for (PendingMotion& pending : pending_) {
      int index = pending.target;
      if (index < 0) index = Resolve(pending.key, pending.statement.file, pending.kind);
      if (index < 0) {
        CheckShape(pending);
        continue;  // declared without numbers, or nowhere in these files: nothing to compensate
      }
      pending.statement.target = index;
      program_->motions.push_back(pending.statement);
      ProgramTarget& target = program_->targets[index];
      if (target.motion != Motion::kNone) continue;
      target.motion = pending.statement.motion;
      target.tool = pending.tool;
      target.base = pending.base;
      target.configuration_applies = target.kind == TargetKind::kCartesian && pending.configuration_monitored;
    }
  }

 private:
  // A reference that names no declared target: throws when the files declare its name (with the instruction's
  // kind) only with shapes it does not fit - an element outside the array, an array without an index, an index
  // on a name that is no array. RAPID rejects such a module. A name declared nowhere in these files may live in
  // a module the request does not carry, and one declared with another kind is not a target of this motion.
  void CheckShape(const PendingMotion& pending) const {
    if (pending.name.empty()) return;
    const auto it = shapes_.find(pending.name);
    if (it == shapes_.end()) return;
    const int file = pending.statement.file;
    // The declaration the error names: one with as many dimensions as the reference has indexes if any, the
    // reference's own module's first.
    auto prefer = [file](const Shape* current, const Shape& candidate) {
      return current == nullptr || (candidate.file == file && current->file != file);
    };
    const Shape* same_rank = nullptr;
    const Shape* any = nullptr;
    for (const Shape& shape : it->second) {
      if (shape.kind != pending.kind) continue;
      if (shape.Admits(pending.indexes)) return;
      if (prefer(any, shape)) any = &shape;
      if (shape.dimensions.size() == pending.indexes.size() && prefer(same_rank, shape)) same_rank = &shape;
    }
    if (any == nullptr) return;
    const MotionStatement& m = pending.statement;
    std::string written = NameKeyKeepingCase(
        std::string_view(files_[m.file].text).substr(m.reference_begin, m.reference_end - m.reference_begin));
    std::string reason;
    if (same_rank != nullptr) {
      reason = written + " is outside " + same_rank->Written() + " (indexes run from 1)";
    } else if (pending.indexes.empty()) {
      reason = written + " is the array " + any->Written() + ", not one target: name one of its elements";
    } else if (any->dimensions.empty()) {
      reason = written + " indexes " + any->Written() + ", which is not an array";
    } else {
      reason = written + " has " + std::to_string(pending.indexes.size()) + " index(es), " + any->Written() + " has " +
               std::to_string(any->dimensions.size()) + " dimension(s)";
    }
    SourceText(files_[m.file], m.file).Fail(m.reference_begin, reason);
  }

  // The reference as written without its blanks ("p{ 3 }" is "p{3}").
  static std::string NameKeyKeepingCase(std::string_view text) {
    std::string out;
    for (char c : text) {
      if (c != ' ' && c != '\t' && c != '\r' && c != '\n') out.push_back(c);
    }
    return out;
  }

  void AddShape(int file, TargetKind kind, std::string_view name, std::vector<long> dimensions, bool open) {
    shapes_[LowerCase(name)].push_back({file, kind, std::move(dimensions), open, std::string(name)});
  }

  // A routine's parameter written without VAR / PERS ("PROC p(robtarget a, INOUT jointtarget b{*})") after its
  // type at `pos`: its shape, so that a motion to it is not checked against a global target of the same name.
  void Parameter(const SourceText& source, std::size_t pos, TargetKind kind) {
    const std::string_view text = source.text();
    pos = SkipSpace(text, pos);
    const std::size_t name_end = IdentifierEnd(text, pos);
    if (name_end == pos || !IsLetter(text[pos])) return;
    const std::string_view name = text.substr(pos, name_end - pos);
    pos = SkipSpace(text, name_end);
    if (pos < text.size() && (text[pos] == ')' || text[pos] == ',')) {
      AddShape(source.file_index(), kind, name, {}, false);
    } else if (pos < text.size() && text[pos] == '{') {
      AddShape(source.file_index(), kind, name, std::vector<long>(OpenRank(text, pos), 0), true);
    }
  }

  // The number of dimensions of "{*}", "{*,*}", "{*,*,*}" at `pos` (its '{'); 1 if it is not that.
  static std::size_t OpenRank(std::string_view text, std::size_t pos) {
    std::size_t rank = 1;
    for (++pos; pos < text.size() && text[pos] != '}' && text[pos] != ')' && text[pos] != ';'; ++pos) {
      if (text[pos] == ',') ++rank;
    }
    return std::min<std::size_t>(rank, kMaxDimensions);
  }

  // A declared target of that kind named `key`: the one of the same file first (a module's LOCAL data hides the
  // task's), else the first of the program.
  int Resolve(const std::string& key, int file, TargetKind kind) const {
    const auto it = declared_.find(key);
    if (it == declared_.end()) return -1;
    int found = -1;
    for (const Declared& d : it->second) {
      if (program_->targets[d.target].kind != kind) continue;
      if (d.file == file) return d.target;
      if (found < 0) found = d.target;
    }
    return found;
  }

  int AddTarget(ProgramTarget target) {
    // A Cartesian target no motion moves to keeps its configuration: the controller would use it.
    target.configuration_applies = target.kind == TargetKind::kCartesian;
    program_->targets.push_back(std::move(target));
    return static_cast<int>(program_->targets.size()) - 1;
  }

  // After CONST / PERS / VAR: "robtarget NAME [{dims}] [:= value];". Other data types are skipped; a target
  // declaration that cannot be read throws. Returns where scanning goes on.
  std::size_t Declaration(const SourceText& source, const Aggregates& in, std::size_t pos) {
    const std::string_view text = source.text();
    pos = SkipSpace(text, pos);
    const std::size_t type_end = IdentifierEnd(text, pos);
    const std::string_view type = text.substr(pos, type_end - pos);
    TargetKind kind;
    if (EqualsNoCase(type, "robtarget")) {
      kind = TargetKind::kCartesian;
    } else if (EqualsNoCase(type, "jointtarget")) {
      kind = TargetKind::kJoint;
    } else {
      return type_end;
    }
    const char* type_name = kind == TargetKind::kCartesian ? "robtarget" : "jointtarget";
    pos = SkipSpace(text, type_end);
    const std::size_t name_end = IdentifierEnd(text, pos);
    if (name_end == pos || !IsLetter(text[pos])) in.Fail(pos, std::string("expected the ") + type_name + "'s name");
    const std::string name(text.substr(pos, name_end - pos));
    pos = SkipSpace(text, name_end);
    // A routine's parameter ("PROC Path(PERS robtarget points{*}, VAR jointtarget home)") declares no data.
    if (pos < text.size() && (text[pos] == ')' || text[pos] == ',')) {
      AddShape(source.file_index(), kind, name, {}, false);
      return pos;
    }
    std::vector<long> dimensions;
    if (pos < text.size() && text[pos] == '{') {
      const std::size_t open = pos;
      pos = SkipSpace(text, pos + 1);
      if (pos < text.size() && text[pos] == '*') {
        AddShape(source.file_index(), kind, name, std::vector<long>(OpenRank(text, open), 0), true);
        return pos;
      }
      while (true) {
        const std::optional<ScannedNumber> n = ScanNumber(text, pos);
        if (!n || n->value < 1 || n->value != std::floor(n->value) || n->value > 1e9 || text[pos] == '+' ||
            text[pos] == '-') {
          in.Fail(pos, "expected an array dimension (a positive integer)");
        }
        if (static_cast<int>(dimensions.size()) == kMaxDimensions) in.Fail(pos, "more than 3 array dimensions");
        dimensions.push_back(static_cast<long>(n->value));
        pos = SkipSpace(text, pos + n->length);
        if (pos < text.size() && text[pos] == ',') {
          pos = SkipSpace(text, pos + 1);
          continue;
        }
        in.Expect(pos, '}', "to close the array dimensions");
        pos = SkipSpace(text, pos + 1);
        break;
      }
    }
    AddShape(source.file_index(), kind, name, dimensions, false);
    if (pos < text.size() && text[pos] == ';') return pos + 1;  // no initial value: not a target
    if (pos + 1 >= text.size() || text[pos] != ':' || text[pos + 1] != '=') {
      in.Fail(pos, std::string("expected ':=' or ';' after the ") + type_name + "'s name");
    }
    pos = SkipSpace(text, pos + 2);
    // A value from an expression (":= p0", ":= Offs(p0, 0, 0, 10)") holds no numbers of its own.
    if (pos >= text.size() || text[pos] != '[') return pos;
    std::vector<long> index;
    pos = Elements(source, in, pos, kind, name, dimensions, &index);
    pos = SkipSpace(text, pos);
    in.Expect(pos, ';', std::string("after the ") + type_name + "'s value");
    return pos + 1;
  }

  // The value of dimension `index.size()` of an array (or the target itself when every dimension is read).
  std::size_t Elements(const SourceText& source, const Aggregates& in, std::size_t pos, TargetKind kind,
                       const std::string& name, const std::vector<long>& dimensions, std::vector<long>* index) {
    const std::string_view text = source.text();
    if (index->size() == dimensions.size()) {
      const Literal literal = ReadLiteral(in, text, pos, kind);
      ProgramTarget target = TargetOf(source, in, literal);
      std::string element = name;
      if (!index->empty()) {
        element += '{';
        for (std::size_t i = 0; i < index->size(); ++i) {
          if (i > 0) element += ',';
          element += std::to_string((*index)[i]);
        }
        element += '}';
      }
      target.name = element;
      const int added = AddTarget(std::move(target));
      declared_[NameKey(element)].push_back({source.file_index(), added});
      return literal.end;
    }
    const long count = dimensions[index->size()];
    pos = SkipSpace(text, pos);
    in.Expect(pos, '[', "to open the array's elements");
    ++pos;
    index->push_back(0);
    for (long i = 1; i <= count; ++i) {
      index->back() = i;
      pos = Elements(source, in, SkipSpace(text, pos), kind, name, dimensions, index);
      pos = SkipSpace(text, pos);
      if (i < count) {
        if (pos < text.size() && text[pos] == ']') {
          in.Fail(pos, "the array has " + std::to_string(i) + " elements, expected " + std::to_string(count));
        }
        in.Expect(pos, ',', "between the array's elements");
        ++pos;
      }
    }
    index->pop_back();
    if (pos < text.size() && text[pos] == ',') {
      in.Fail(pos, "the array has more than " + std::to_string(count) + " elements");
    }
    in.Expect(pos, ']', "to close the array's elements");
    return pos + 1;
  }

  // After ConfJ / ConfL: "\On" or "\Off". Anything else leaves the monitoring as it was.
  static std::size_t Monitoring(std::string_view text, std::size_t pos, bool* on) {
    pos = SkipSpace(text, pos);
    if (pos < text.size() && text[pos] == '\\') {
      pos = SkipSpace(text, pos + 1);
      if (WordAt(text, pos, "On")) *on = true;
      if (WordAt(text, pos, "Off")) *on = false;
    }
    return pos;
  }

  // The arguments of the statement from `pos` to its ';' (or the end of the text); `*end` is the ';' position.
  static std::vector<Argument> Arguments(std::string_view text, std::size_t pos, std::size_t* end) {
    std::vector<Argument> arguments;
    Argument current;
    bool empty = true;
    int depth = 0;
    auto close = [&] {
      if (!empty || current.optional) arguments.push_back(current);
      current = Argument{};
      empty = true;
    };
    while (pos < text.size()) {
      const char c = text[pos];
      if (c == ' ' || c == '\t' || c == '\r' || c == '\n') {
        ++pos;
        continue;
      }
      if (c == '!') {
        pos = CommentEnd(text, pos);
        continue;
      }
      // ';' ends the statement even inside unbalanced brackets: RAPID has no ';' within an expression, and a
      // typo must not hide the rest of the file.
      if (c == ';' || (depth == 0 && (c == ',' || c == '\\'))) {
        close();
        if (c == ';') {
          *end = pos;
          return arguments;
        }
        if (c == '\\') {
          current.optional = true;
          current.begin = current.end = pos + 1;
        }
        ++pos;
        continue;
      }
      if (empty) {
        current.begin = pos;
        empty = false;
      }
      if (c == '"') {
        pos = StringEnd(text, pos);
      } else {
        if (c == '[' || c == '(' || c == '{') ++depth;
        if ((c == ']' || c == ')' || c == '}') && depth > 0) --depth;
        ++pos;
      }
      current.end = pos;
    }
    close();
    *end = text.size();
    return arguments;
  }

  // The value of an argument written "Name := value" (a positional argument given by name, or an optional one
  // with a value); the whole argument otherwise. Empty for a switch ("\Conc").
  static std::pair<std::size_t, std::size_t> ValueOf(std::string_view text, const Argument& argument) {
    const std::size_t name_end = IdentifierEnd(text, argument.begin);
    std::size_t p = SkipSpace(text, name_end);
    if (name_end > argument.begin && p + 1 < argument.end && text[p] == ':' && text[p + 1] == '=') {
      return {SkipSpace(text, p + 2), argument.end};
    }
    if (argument.optional) return {argument.end, argument.end};
    return {argument.begin, argument.end};
  }

  // The instruction whose name is [word_begin, word_end): its targets, tool and work object. Returns the position
  // after its ';'.
  std::size_t MotionStatementAt(const SourceText& source, const Aggregates& in, std::size_t word_begin,
                                std::size_t word_end, const Instruction& instruction) {
    const std::string_view text = source.text();
    std::size_t semicolon = 0;
    const std::vector<Argument> arguments = Arguments(text, word_end, &semicolon);
    std::vector<std::pair<std::size_t, std::size_t>> positional;
    std::string base;
    for (const Argument& argument : arguments) {
      const auto [begin, end] = ValueOf(text, argument);
      if (!argument.optional) {
        positional.emplace_back(begin, end);
      } else if (WordAt(text, argument.begin, "WObj") && begin < end) {
        base = std::string(text.substr(begin, end - begin));
      }
    }
    if (EqualsNoCase(base, "wobj0")) base.clear();
    std::string tool;
    if (static_cast<int>(positional.size()) > instruction.tool_index) {
      const auto [begin, end] = positional[instruction.tool_index];
      tool = std::string(text.substr(begin, end - begin));
    }
    const int line = source.LineOf(word_begin);
    MotionStatement statement;
    statement.motion = instruction.motion;
    statement.file = source.file_index();
    statement.line = line;
    statement.begin = source.LineStart(line);
    const int last_line = source.LineOf(std::min(semicolon, text.size()));
    statement.end = source.LineStart(last_line) + source.Line(last_line).size();
    statement.own_begin = word_begin;
    statement.own_end = std::min(semicolon + 1, statement.end);
    const bool monitored = instruction.monitor == Monitor::kJoint    ? conf_j_on_
                           : instruction.monitor == Monitor::kLinear ? conf_l_on_
                                                                     : true;
    for (int i = 0; i < instruction.points && i < static_cast<int>(positional.size()); ++i) {
      const auto [begin, end] = positional[i];
      PendingMotion pending;
      pending.kind = instruction.kind;
      pending.configuration_monitored = monitored;
      pending.tool = tool;
      pending.base = base;
      pending.statement = statement;
      pending.statement.reference_begin = begin;
      pending.statement.reference_end = end;
      const std::string_view reference = text.substr(begin, end - begin);
      if (!reference.empty() && reference[0] == '[') {
        const Literal literal = ReadLiteral(in, text, begin, instruction.kind);
        if (SkipSpace(text, literal.end) < end) in.Fail(literal.end, "unexpected text after the target");
        pending.target = AddTarget(TargetOf(source, in, literal));
      } else if (const std::optional<Reference> parsed = ParseReference(reference)) {
        pending.key = parsed->Key();
        pending.name = parsed->base;
        pending.indexes = parsed->indexes;
      } else {
        continue;  // a computed target (Offs, RelTool, CRobT, ...): nothing of its own to compensate
      }
      pending_.push_back(std::move(pending));
    }
    return semicolon < text.size() ? semicolon + 1 : text.size();
  }

  ParsedProgram* program_;
  // ConfJ / ConfL monitoring in text order, on unless turned off (the controller's default at program start).
  bool conf_j_on_ = true;
  bool conf_l_on_ = true;
  std::vector<PendingMotion> pending_;
  std::unordered_map<std::string, std::vector<Declared>> declared_;
  // Every robtarget / jointtarget name's declarations and parameters, by lower-case name.
  std::unordered_map<std::string, std::vector<Shape>> shapes_;
  const std::vector<ProgramFile>& files_;
};

ParsedProgram Read(const std::vector<ProgramFile>& files) {
  ParsedProgram program;
  Reader reader(&program, files);
  for (std::size_t i = 0; i < files.size(); ++i) reader.ReadFile(files[i], static_cast<int>(i));
  reader.Finish();
  return program;
}

// "[[x,y,z],[q1,q2,q3,q4],[cf1,cf4,cf6,cfx],[eax_a..eax_f]]": the confdata and external axes as `like` writes
// them (its declaration or inline literal), the position and orientation from `values`.
std::string InlineTarget(const ProgramTarget& like, const std::vector<ProgramFile>& files,
                         const std::vector<double>& values) {
  if (like.kind == TargetKind::kJoint) return "";
  if (values.size() != 7) throw std::invalid_argument("a robtarget takes 7 values (x, y, z, q1..q4)");
  if (like.spans.size() != 7 || like.spans.back().file < 0 ||
      like.spans.back().file >= static_cast<int>(files.size())) {
    throw std::invalid_argument("the target is not one the RAPID reader found in these files");
  }
  const std::string_view text = files[like.spans.back().file].text;
  const NumberSpan& q4 = like.spans.back();
  if (q4.offset + q4.length > text.size()) throw std::invalid_argument("the target's span is outside its file");
  const Aggregates in(text, nullptr);
  std::size_t pos = SkipSpace(text, q4.offset + q4.length);
  in.Expect(pos, ']', "to close a robtarget's orientation");
  std::vector<ScannedNumber> rest;
  pos = in.List(in.Comma(pos + 1, "after a robtarget's orientation"), 4, "the confdata", &rest);
  in.List(in.Comma(pos, "after a robtarget's confdata"), 6, "the external axes", &rest);
  auto written = [&](std::size_t first, std::size_t count) {
    std::string list = "[";
    for (std::size_t i = first; i < first + count; ++i) {
      if (i > first) list += ',';
      list += text.substr(rest[i].offset, rest[i].length);
    }
    return list + "]";
  };
  std::string out = "[[";
  for (int i = 0; i < 7; ++i) {
    if (i == 3)
      out += "],[";
    else if (i > 0)
      out += ',';
    out += FormatInserted(values[i], i < 3 ? NumberUnit::kMm : NumberUnit::kQuaternion);
  }
  out += "]," + written(0, 4) + "," + written(4, 6) + "]";
  return out;
}

}  // namespace
}  // namespace robocal::programs::rapid

namespace robocal::programs {

const DialectSyntax& RapidSyntax() {
  static const DialectSyntax syntax{
      .dialect = Dialect::kRapid,
      .name = "rapid",
      .extensions = {".mod", ".modx", ".prg", ".sys"},
      .rotation = RotationConvention::kQuaternionWxyz,
      .mm_per_length_unit = 1.0,
      .joints_in_rad = false,
      .read = rapid::Read,
      .inline_target = rapid::InlineTarget,
  };
  return syntax;
}

}  // namespace robocal::programs
