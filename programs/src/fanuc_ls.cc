// The FANUC TP source reader (.ls, the text form of a teach pendant program that FANUC's tools and the
// controller's ASCII backup write): the P[n] and PR[n] blocks of the /POS section, joint (J1..Jn) or Cartesian
// (X, Y, Z, W, P, R with CONFIG), and the J, L, C and A motions of the /MN section that move to them.
// docs/programs.md gives the mapping of FANUC's configuration letters and turn numbers onto robocal's flags.
#include <array>
#include <cstddef>
#include <limits>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "robocal/programs/program.h"
#include "robocal/programs/text_scan.h"

namespace robocal::programs {
namespace {

constexpr double kRadPerDeg = std::numbers::pi / 180.0;
/// The joints (0-based) the three turn numbers of CONFIG belong to: J4, J5 and J6, as FANUC's Remote Motion
/// Interface names them (Turn4, Turn5, Turn6) and as KAREL's CONFIG type stores them for the axes of
/// $SCR_GRP.$TURN_AXIS (4, 5, 6 on a 6-axis arm).
constexpr std::array<int, 3> kTurnJoints = {3, 4, 5};
/// Turn numbers beyond this are no robot's (a joint range of +-3.6e5 deg); refusing them keeps the ranges finite.
constexpr double kMaxTurn = 1000.0;
/// CONFIG's letters and the flags they set (docs/programs.md, "FANUC"). The flags are geometric and FANUC's
/// letters are too, given a robot model with the controller's joint zeros and directions:
/// - F(lip) is J5 > 0 and N(o flip) J5 < 0 on FANUC's arms; robocal's "noflip" (+1) is the sign z5.(z4 x z6) has
///   at J5 = +90 deg. So FANUC's F is robocal's noflip, and N its flip: the names cross, the geometry does not.
/// - U(p) / D(own): the elbow above / below the line from the shoulder to the wrist, robocal's elbow up / down.
/// - T / B: the wrist centre in front of / behind J1's axis (FANUC's front / back), robocal's shoulder front / back.
struct ConfigLetter {
  char letter;
  int ArmConfiguration::*flag;
  int value;
};
constexpr ConfigLetter kConfigLetters[] = {
    {'F', &ArmConfiguration::wrist, 1},  {'N', &ArmConfiguration::wrist, -1},   {'U', &ArmConfiguration::elbow, 1},
    {'D', &ArmConfiguration::elbow, -1}, {'T', &ArmConfiguration::shoulder, 1}, {'B', &ArmConfiguration::shoulder, -1},
};
/// The joints a GP1 joint block may list (J1..J9: a 6-axis arm and up to three integrated axes).
constexpr int kMaxBlockJoints = 9;

bool IsDigit(char c) { return c >= '0' && c <= '9'; }
bool IsLetter(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); }
bool IsWordChar(char c) { return IsDigit(c) || IsLetter(c) || c == '_'; }
char Upper(char c) { return (c >= 'a' && c <= 'z') ? static_cast<char>(c - 'a' + 'A') : c; }

bool StartsWithNoCase(std::string_view text, std::size_t pos, std::string_view word) {
  return pos <= text.size() && text.size() - pos >= word.size() && EqualsNoCase(text.substr(pos, word.size()), word);
}

/// The unsigned integer of at most 9 digits at `pos` (FANUC's indices and frame numbers); its end in `*after`.
std::optional<int> ScanIndex(std::string_view text, std::size_t pos, std::size_t* after) {
  std::size_t i = pos;
  int value = 0;
  while (i < text.size() && IsDigit(text[i]) && i - pos < 9) value = value * 10 + (text[i++] - '0');
  if (i == pos || (i < text.size() && IsWordChar(text[i]))) return std::nullopt;
  *after = i;
  return value;
}

/// A reference to a position as /MN and /POS write it: P[n], PR[n], with an optional comment (P[2:approach],
/// P[2:"approach"]). `name` is "P[n]" / "PR[n]" without the comment.
struct PositionRef {
  std::string name;
  std::size_t begin = 0;
  std::size_t end = 0;  // one past the ']'
};

/// The reference starting exactly at `pos`, or nullopt when none does or its index is not a number (an indirect
/// PR[R[3]], a group-qualified PR[GP1:1]): those name no block of the file.
std::optional<PositionRef> ScanPositionRef(std::string_view text, std::size_t pos) {
  std::string kind;
  std::size_t i = pos;
  if (StartsWithNoCase(text, pos, "PR[")) {
    kind = "PR";
    i += 3;
  } else if (StartsWithNoCase(text, pos, "P[")) {
    kind = "P";
    i += 2;
  } else {
    return std::nullopt;
  }
  if (pos > 0 && IsWordChar(text[pos - 1])) return std::nullopt;  // "SPR[", "LPR[": another word
  i = SkipBlanks(text, i);
  std::size_t after = 0;
  const std::optional<int> index = ScanIndex(text, i, &after);
  if (!index) return std::nullopt;
  i = SkipBlanks(text, after);
  if (i < text.size() && text[i] == ':') {
    // The comment: quoted (it may hold ']'), or up to the ']' on the same line.
    ++i;
    i = SkipBlanks(text, i);
    if (i < text.size() && text[i] == '"') {
      ++i;
      while (i < text.size() && text[i] != '"' && text[i] != '\n' && text[i] != '\r') ++i;
      if (i >= text.size() || text[i] != '"') return std::nullopt;
      ++i;
    }
    while (i < text.size() && text[i] != ']' && text[i] != '\n' && text[i] != '\r') ++i;
  }
  if (i >= text.size() || text[i] != ']') return std::nullopt;
  PositionRef ref;
  ref.name = kind + "[" + std::to_string(*index) + "]";
  ref.begin = pos;
  ref.end = i + 1;
  return ref;
}

/// One position block of /POS while it is read, and what the motions say of it.
struct Block {
  ProgramTarget target;
  /// Moved to by an INC motion: the block is an increment, not a position, and is not compensated.
  bool incremental = false;
};

/// One motion to a block, by the block's index in the file's blocks.
struct PendingMotion {
  int block = 0;
  MotionStatement statement;
};

/// GP1's components of a block while it is read (X Y Z W P R by index 0..5, joints J1..J9, frame numbers, CONFIG),
/// and the group being read.
struct BlockComponents {
  std::array<std::optional<ScannedNumber>, 6> cartesian;
  std::array<std::optional<ScannedNumber>, kMaxBlockJoints> joints;
  std::optional<std::string> uf, ut;
  std::optional<std::size_t> first_cartesian, first_joint;
  bool seen_config = false;
  int group = 0;
  bool gp1_seen = false;
};

/// A numeric component's key as read: lower case, where it starts, and the unit written after its number.
struct ComponentKey {
  std::string key;
  std::size_t begin = 0;
  std::string unit;
  std::size_t unit_begin = 0;
};

/// Reads one .ls file: its /POS blocks, then its /MN motions.
class LsFileReader {
 public:
  LsFileReader(const ProgramFile& file, int file_index) : source_(file, file_index), text_(source_.text()) {}

  void Read() {
    // Section headers start a line with '/' and a word (/PROG, /ATTR, /APPL, /MN, /POS, /END). /POS is read
    // first: /MN names its blocks.
    struct Section {
      std::string name;
      std::size_t begin = 0;  // the line after the header
      std::size_t end = 0;    // the start of the next header line
    };
    std::vector<Section> sections;
    for (int line = 1; line <= source_.line_count(); ++line) {
      const std::string_view content = source_.Line(line);
      if (content.size() < 2 || content[0] != '/' || !IsLetter(content[1])) continue;
      std::size_t word_end = 1;
      while (word_end < content.size() && IsWordChar(content[word_end])) ++word_end;
      const std::size_t start = source_.LineStart(line);
      if (!sections.empty()) sections.back().end = start;
      const std::size_t next = line < source_.line_count() ? source_.LineStart(line + 1) : text_.size();
      sections.push_back({LowerCase(content.substr(1, word_end - 1)), next, text_.size()});
    }
    for (const Section& section : sections) {
      if (section.name == "pos") ReadPositions(section.begin, section.end);
    }
    for (const Section& section : sections) {
      if (section.name == "mn") ReadMotions(section.begin, section.end);
    }
  }

  std::vector<Block>& blocks() { return blocks_; }
  std::vector<PendingMotion>& motions() { return motions_; }

 private:
  // ---- /POS ----

  void ReadPositions(std::size_t begin, std::size_t end) {
    // Everything the blocks hold lies within the section: reading a view that ends there keeps every scan in it.
    const std::string_view text = text_.substr(0, end);
    std::size_t p = begin;
    while (true) {
      p = SkipWhitespace(text, p);
      if (p >= text.size()) return;
      const std::optional<PositionRef> ref = ScanPositionRef(text, p);
      if (!ref) source_.Fail(p, "expected a position P[n]{ ... }; or PR[n]{ ... };");
      std::size_t q = SkipWhitespace(text, ref->end);
      if (q >= text.size() || text[q] != '{') source_.Fail(q, "expected '{' after " + ref->name);
      if (names_.count(ref->name)) source_.Fail(ref->begin, ref->name + " is defined twice");
      p = ReadBlock(text, *ref, q + 1);
    }
  }

  /// Reads a block's groups from `p` (after its '{') to its "};", and returns the offset after it.
  std::size_t ReadBlock(std::string_view text, const PositionRef& ref, std::size_t p) {
    Block block;
    ProgramTarget& target = block.target;
    target.file = source_.file_index();
    target.name = ref.name;
    BlockComponents c;
    while (true) {
      p = SkipWhitespace(text, p);
      while (p < text.size() && text[p] == ',') p = SkipWhitespace(text, p + 1);
      if (p >= text.size()) source_.Fail(ref.begin, ref.name + " has no closing '};'");
      if (text[p] == '}') {
        ++p;
        const std::size_t semicolon = SkipBlanks(text, p);
        if (semicolon < text.size() && text[semicolon] == ';') p = semicolon + 1;
        break;
      }
      // A group header: GPn:
      if (StartsWithNoCase(text, p, "GP") && p + 2 < text.size() && IsDigit(text[p + 2])) {
        std::size_t after = 0;
        const std::optional<int> number = ScanIndex(text, p + 2, &after);
        const std::size_t colon = number ? SkipBlanks(text, after) : text.size();
        if (!number || colon >= text.size() || text[colon] != ':') source_.Fail(p, "expected a group GPn:");
        c.group = *number;
        if (c.group == 1) {
          if (c.gp1_seen) source_.Fail(p, ref.name + " has GP1 twice");
          c.gp1_seen = true;
        }
        p = colon + 1;
        continue;
      }
      if (c.group == 0) source_.Fail(p, "expected a group GPn: in " + ref.name);
      p = ReadComponent(text, ref, p, &c, &target);
    }

    if (!c.gp1_seen) return p;  // another group's position only: nothing of the robot's
    SetBlockValues(ref, c, &target);
    target.tool = c.ut.value_or("");
    target.line = source_.LineOf(target.spans.front().offset);
    target.column = source_.ColumnOf(target.spans.front().offset);
    names_.emplace(ref.name, static_cast<int>(blocks_.size()));
    blocks_.push_back(std::move(block));
    return p;
  }

  /// One component: KEY (':' | '=') VALUE [unit], kept when of GP1; returns the offset after it.
  std::size_t ReadComponent(std::string_view text, const PositionRef& ref, std::size_t p, BlockComponents* c,
                            ProgramTarget* target) {
    const std::size_t key_begin = p;
    while (p < text.size() && IsWordChar(text[p])) ++p;
    if (p == key_begin) source_.Fail(p, "expected a component of " + ref.name);
    const std::string key = LowerCase(text.substr(key_begin, p - key_begin));
    p = SkipBlanks(text, p);
    if (p >= text.size() || (text[p] != ':' && text[p] != '=')) {
      source_.Fail(p, "expected ':' or '=' after " + std::string(text.substr(key_begin, p - key_begin)));
    }
    p = SkipBlanks(text, p + 1);
    const bool mine = c->group == 1;

    if (key == "uf" || key == "ut") {
      std::size_t after = 0;
      if (!ScanIndex(text, p, &after)) source_.Fail(p, "expected a frame number after " + key);
      if (mine) {
        std::optional<std::string>& frame = key == "uf" ? c->uf : c->ut;
        if (frame) source_.Fail(key_begin, ref.name + " gives " + key + " twice");
        frame = std::string(text.substr(p, after - p));
      }
      return after;
    }
    if (key == "config") {
      if (p >= text.size() || text[p] != '\'') source_.Fail(p, "expected the configuration in quotes");
      std::size_t close = p + 1;
      while (close < text.size() && text[close] != '\'' && text[close] != '\n' && text[close] != '\r') ++close;
      if (close >= text.size() || text[close] != '\'') source_.Fail(p, "the configuration has no closing quote");
      if (mine) {
        if (c->seen_config) source_.Fail(key_begin, ref.name + " gives CONFIG twice");
        c->seen_config = true;
        ReadConfig(text, p + 1, close, target);
      }
      return close + 1;
    }

    // A number with its unit.
    const std::optional<ScannedNumber> number = ScanNumber(text, p);
    if (!number) source_.Fail(p, "expected a number for " + std::string(text.substr(key_begin, key.size())));
    p = SkipBlanks(text, number->offset + number->length);
    std::size_t unit_end = p;
    while (unit_end < text.size() && IsLetter(text[unit_end])) ++unit_end;
    const std::string unit = LowerCase(text.substr(p, unit_end - p));
    p = unit_end;
    if (mine) {
      StoreNumber(text, ref, {.key = key, .begin = key_begin, .unit = unit, .unit_begin = p - unit.size()}, *number, c);
    }
    return p;
  }

  /// A number of GP1: a Cartesian component or a joint (an extended axis is kept as written).
  void StoreNumber(std::string_view text, const PositionRef& ref, const ComponentKey& k, const ScannedNumber& number,
                   BlockComponents* c) {
    const std::string& key = k.key;
    const std::size_t key_begin = k.begin;
    static constexpr std::string_view kCartesianKeys = "xyzwpr";
    if (key.size() == 1 && kCartesianKeys.find(key[0]) != std::string_view::npos) {
      const std::size_t index = kCartesianKeys.find(key[0]);
      const char* expected = index < 3 ? "mm" : "deg";
      if (!k.unit.empty() && k.unit != expected) {
        source_.Fail(k.unit_begin, std::string("expected ") + expected + " for " + key);
      }
      if (c->first_joint) source_.Fail(key_begin, ref.name + " mixes joint and Cartesian components");
      if (c->cartesian[index]) source_.Fail(key_begin, ref.name + " gives " + key + " twice");
      if (!c->first_cartesian) c->first_cartesian = key_begin;
      c->cartesian[index] = number;
    } else if ((key[0] == 'j' || key[0] == 'e') && key.size() >= 2 &&
               key.find_first_not_of("0123456789", 1) == std::string::npos && key.size() <= 3) {
      if (!k.unit.empty() && k.unit != "deg" && k.unit != "mm") source_.Fail(k.unit_begin, "expected deg or mm");
      if (key[0] == 'e') return;  // an extended axis of GP1: kept as written
      const int joint = std::stoi(key.substr(1));
      if (joint < 1 || joint > kMaxBlockJoints) source_.Fail(key_begin, "no joint " + key + " in a GP1 block");
      if (c->first_cartesian) source_.Fail(key_begin, ref.name + " mixes joint and Cartesian components");
      if (c->joints[joint - 1]) source_.Fail(key_begin, ref.name + " gives " + key + " twice");
      if (!c->first_joint) c->first_joint = key_begin;
      c->joints[joint - 1] = number;
    } else {
      source_.Fail(key_begin,
                   "unknown component " + std::string(text.substr(key_begin, key.size())) + " of " + ref.name);
    }
  }

  /// The target's values and kind from GP1's components: X, Y, Z, W, P, R, or joints J1..Jn without a gap.
  void SetBlockValues(const PositionRef& ref, const BlockComponents& c, ProgramTarget* target) {
    if (c.first_cartesian) {
      static constexpr const char* kNames[6] = {"X", "Y", "Z", "W", "P", "R"};
      for (int i = 0; i < 6; ++i) {
        if (!c.cartesian[i]) source_.Fail(ref.begin, ref.name + " has no " + kNames[i]);
        target->values.push_back(c.cartesian[i]->value);
        target->spans.push_back({source_.file_index(), c.cartesian[i]->offset, c.cartesian[i]->length});
      }
      target->kind = TargetKind::kCartesian;
      // The controller reaches a Cartesian position with the configuration stored in it, whatever the motion.
      target->configuration_applies = true;
      target->base = (c.uf && *c.uf != "0") ? *c.uf : "";
    } else if (c.first_joint) {
      int count = 0;
      while (count < kMaxBlockJoints && c.joints[count]) ++count;
      for (int i = count; i < kMaxBlockJoints; ++i) {
        if (c.joints[i])
          source_.Fail(ref.begin,
                       ref.name + " has J" + std::to_string(i + 1) + " without J" + std::to_string(count + 1));
      }
      for (int i = 0; i < count; ++i) {
        target->values.push_back(c.joints[i]->value);
        target->spans.push_back({source_.file_index(), c.joints[i]->offset, c.joints[i]->length});
      }
      target->kind = TargetKind::kJoint;
      // A joint position does not depend on the user frame; its turn numbers and letters mean nothing.
      target->configuration = ArmConfiguration{};
      target->turns.clear();
      target->configuration_applies = false;
    } else {
      source_.Fail(ref.begin, ref.name + " has neither joints nor X, Y, Z, W, P, R in GP1");
    }
  }

  /// The configuration string's text [begin, end) (between the quotes): letters F|N, U|D, T|B, then up to three
  /// turn numbers, comma separated ("N U T, 0, 0, 0").
  void ReadConfig(std::string_view text, std::size_t begin, std::size_t end, ProgramTarget* target) {
    const std::string_view config = text.substr(0, end);
    std::size_t p = SkipBlanks(config, begin);
    while (p < config.size() && config[p] != ',') {
      const ConfigLetter* letter = nullptr;
      for (const ConfigLetter& candidate : kConfigLetters) {
        if (Upper(config[p]) == candidate.letter) letter = &candidate;
      }
      if (!letter) {
        source_.Fail(p, "unknown configuration letter '" + std::string(1, config[p]) + "' (F|N, U|D, T|B)");
      }
      int& flag = target->configuration.*(letter->flag);
      if (flag != 0) source_.Fail(p, "the configuration gives the same flag twice");
      flag = letter->value;
      ++p;
      if (p < config.size() && IsWordChar(config[p])) source_.Fail(p, "expected letters apart: 'N U T, ...'");
      p = SkipBlanks(config, p);
    }
    std::size_t turn = 0;
    while (p < config.size()) {  // at a ','
      p = SkipBlanks(config, p + 1);
      const std::optional<ScannedNumber> number = ScanNumber(config, p);
      if (!number || config.substr(number->offset, number->length).find_first_of(".eE") != std::string_view::npos) {
        source_.Fail(p, "expected a turn number (an integer)");
      }
      if (turn >= kTurnJoints.size()) source_.Fail(p, "more than three turn numbers");
      if (number->value > kMaxTurn || number->value < -kMaxTurn) source_.Fail(p, "turn number out of range");
      // Turn k: the joint in [-180 + 360 k, 180 + 360 k) deg.
      const double k = number->value;
      target->turns.push_back({kTurnJoints[turn], (-180.0 + 360.0 * k) * kRadPerDeg, (180.0 + 360.0 * k) * kRadPerDeg});
      ++turn;
      p = SkipBlanks(config, number->offset + number->length);
      if (p < config.size() && config[p] != ',') source_.Fail(p, "expected ',' between turn numbers");
    }
  }

  // ---- /MN ----

  void ReadMotions(std::size_t begin, std::size_t end) {
    // The section's lines: those starting in [begin, end).
    auto in_section = [&](int line) {
      return line <= source_.line_count() && source_.LineStart(line) >= begin && source_.LineStart(line) < end;
    };
    int line = source_.LineOf(begin);
    if (source_.LineStart(line) < begin) ++line;
    while (in_section(line)) {
      // A statement: a numbered line ("  12:J P[1] ...") or any line, up to the line holding its ';' outside
      // quotes, or up to the line before the next numbered line. Circular motions and long options continue on
      // lines of their own (FANUC starts them with ':').
      const int statement_first = line;
      bool terminated = Terminated(source_.Line(line));
      ++line;
      while (!terminated && in_section(line) && !Numbered(source_.Line(line))) {
        terminated = Terminated(source_.Line(line));
        ++line;
      }
      ReadStatement(statement_first, line - 1);
    }
  }

  /// The offset just after a line's statement number and ':' ("  12:"), or after a leading ':' of a
  /// continuation line; the line's first non-blank byte otherwise.
  static std::size_t BodyStart(std::string_view line) {
    std::size_t p = SkipBlanks(line, 0);
    std::size_t digits = p;
    while (digits < line.size() && IsDigit(line[digits])) ++digits;
    const std::size_t colon = SkipBlanks(line, digits);
    if (colon < line.size() && line[colon] == ':') return colon + 1;
    return p;
  }

  static bool Numbered(std::string_view line) {
    const std::size_t p = SkipBlanks(line, 0);
    std::size_t digits = p;
    while (digits < line.size() && IsDigit(line[digits])) ++digits;
    if (digits == p) return false;
    const std::size_t colon = SkipBlanks(line, digits);
    return colon < line.size() && line[colon] == ':';
  }

  /// Whether a line holds a ';' outside double quotes (the end of its statement).
  static bool Terminated(std::string_view line) { return TerminatorIn(line) != std::string_view::npos; }
  static std::size_t TerminatorIn(std::string_view line) {
    bool quoted = false;
    for (std::size_t i = 0; i < line.size(); ++i) {
      if (line[i] == '"') quoted = !quoted;
      if (line[i] == ';' && !quoted) return i;
    }
    return std::string_view::npos;
  }

  void ReadStatement(int first, int last) {
    const std::size_t line_begin = source_.LineStart(first);
    const std::string_view line = source_.Line(first);
    std::size_t p = SkipBlanks(line, BodyStart(line));
    if (p >= line.size()) return;
    Motion motion;
    switch (Upper(line[p])) {
      case 'J':
        motion = Motion::kJoint;
        break;
      case 'L':
        motion = Motion::kLinear;
        break;
      case 'C':  // C: the via point here, the end at the start of the next line
      case 'A':  // A: one point of a circular arc (R-30iB's arc motion)
        motion = Motion::kCircular;
        break;
      default:
        return;
    }
    const char letter = Upper(line[p]);
    // The motion letter is a word of its own, followed by its position: "J P[1]", not "JMP LBL[1]".
    if (p + 1 >= line.size() || (line[p + 1] != ' ' && line[p + 1] != '\t')) return;
    p = SkipBlanks(line, p + 1);
    const std::size_t statement_end = source_.LineStart(last) + source_.Line(last).size();
    std::vector<PositionRef> refs;
    const std::optional<PositionRef> first_ref =
        ScanPositionRef(text_.substr(0, line_begin + line.size()), line_begin + p);
    if (!first_ref) return;  // an indirect or group-qualified register: no block of this file
    refs.push_back(*first_ref);
    std::size_t options_from = first_ref->end;
    if (letter == 'C') {
      if (last == first) source_.Fail(line_begin + p, "the circular motion has no end point on the next line");
      const std::size_t next_begin = source_.LineStart(first + 1);
      const std::string_view next = source_.Line(first + 1);
      const std::size_t q = SkipBlanks(next, BodyStart(next));
      const std::optional<PositionRef> end_ref =
          ScanPositionRef(text_.substr(0, next_begin + next.size()), next_begin + q);
      if (!end_ref) {
        if (q < next.size() && (Upper(next[q]) == 'P')) return;  // an indirect register as end point
        source_.Fail(next_begin + q, "expected the circular motion's end point P[n] or PR[n]");
      }
      refs.push_back(*end_ref);
      options_from = end_ref->end;
    }
    const bool incremental = HasIncrement(options_from, statement_end, first_ref->end, line_begin + line.size());
    for (const PositionRef& ref : refs) {
      const auto it = names_.find(ref.name);
      if (it == names_.end()) continue;  // a register or a point without a block here: nothing to rewrite
      if (incremental) {
        blocks_[it->second].incremental = true;
        continue;
      }
      PendingMotion pending;
      pending.block = it->second;
      MotionStatement& statement = pending.statement;
      statement.motion = motion;
      statement.file = source_.file_index();
      statement.line = first;
      statement.begin = line_begin;
      statement.end = statement_end;
      statement.reference_begin = ref.begin;
      statement.reference_end = ref.end;
      motions_.push_back(pending);
    }
  }

  /// Whether the statement's options (from `from` to its ';', and the rest of its first line after `via_end`)
  /// name INC, outside brackets and quotes.
  bool HasIncrement(std::size_t from, std::size_t statement_end, std::size_t via_end, std::size_t first_line_end) {
    auto scan = [&](std::size_t begin, std::size_t end) {
      int depth = 0;
      bool quoted = false;
      for (std::size_t i = begin; i < end; ++i) {
        const char c = text_[i];
        if (c == '"') quoted = !quoted;
        if (quoted) continue;
        if (c == ';') return false;
        if (c == '[') ++depth;
        if (c == ']' && depth > 0) --depth;
        if (depth == 0 && (i == 0 || !IsWordChar(text_[i - 1])) && WordAt(text_, i, "INC")) return true;
      }
      return false;
    };
    // For a circular motion the first line's options lie between the via point and the line's end.
    if (from > first_line_end && scan(via_end, first_line_end)) return true;
    return scan(from, statement_end);
  }

  SourceText source_;
  std::string_view text_;
  std::vector<Block> blocks_;
  std::vector<PendingMotion> motions_;
  std::unordered_map<std::string, int> names_;
};

ParsedProgram ReadFanucLs(const std::vector<ProgramFile>& files) {
  ParsedProgram program;
  for (std::size_t f = 0; f < files.size(); ++f) {
    LsFileReader reader(files[f], static_cast<int>(f));
    reader.Read();
    // Blocks moved to incrementally are left out; the others keep their order (the text's).
    std::vector<int> index_of(reader.blocks().size(), -1);
    for (std::size_t b = 0; b < reader.blocks().size(); ++b) {
      Block& block = reader.blocks()[b];
      if (block.incremental) continue;
      index_of[b] = static_cast<int>(program.targets.size());
      program.targets.push_back(std::move(block.target));
    }
    for (PendingMotion& pending : reader.motions()) {
      const int target = index_of[pending.block];
      if (target < 0) continue;
      pending.statement.target = target;
      if (program.targets[target].motion == Motion::kNone) program.targets[target].motion = pending.statement.motion;
      program.motions.push_back(pending.statement);
    }
  }
  return program;
}

}  // namespace

const DialectSyntax& FanucLsSyntax() {
  static const DialectSyntax syntax{
      .dialect = Dialect::kFanucLs,
      .name = "fanuc-ls",
      .extensions = {".ls"},
      .rotation = RotationConvention::kXyzFixedDeg,
      .mm_per_length_unit = 1.0,
      .joints_in_rad = false,
      .read = ReadFanucLs,
      // A TP program moves only to numbered positions: an inserted target would need new P numbers and blocks.
      .inline_target = nullptr,
  };
  return syntax;
}

}  // namespace robocal::programs
