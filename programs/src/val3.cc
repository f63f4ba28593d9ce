// Staubli VAL3: the targets of a program's data file (.dtx), the XML database SRS and the controller keep a
// program's global data in. A .dtx holds data only: jointRx values (j1..j6, deg) and pointRx values (x, y, z mm;
// rx, ry, rz deg, X Y' Z''; shoulder / elbow / wrist flags; the frame `fatherId`). The motions (movej, movel,
// movec in the .pgx code) and the tool each motion uses are not read, so no motion is listed and no target names
// a tool. docs/programs.md has the format, the flag mapping and what is not read.
//
// The XML is scanned by hand: the compensation rewrites the bytes of each number, and the XML libraries Debian
// ships (tinyxml2, libxml2's SAX interface) give no byte offsets of attribute values. The scanner knows the
// subset a .dtx uses (elements, attributes in either quote in any order, comments, CDATA, processing instructions,
// a DOCTYPE, entities in names) and reads the file once, front to back.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "robocal/programs/program.h"
#include "robocal/programs/text_scan.h"

namespace robocal::programs {
namespace {

constexpr std::size_t kNpos = std::string_view::npos;

bool IsXmlSpace(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }
bool IsNameStart(char c) {
  const auto u = static_cast<unsigned char>(c);
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_' || c == ':' || u >= 0x80;
}
bool IsNameChar(char c) { return IsNameStart(c) || (c >= '0' && c <= '9') || c == '-' || c == '.'; }

std::size_t SkipXmlSpace(std::string_view text, std::size_t pos) {
  while (pos < text.size() && IsXmlSpace(text[pos])) ++pos;
  return pos;
}

std::size_t NameEnd(std::string_view text, std::size_t pos) {
  if (pos >= text.size() || !IsNameStart(text[pos])) return pos;
  while (pos < text.size() && IsNameChar(text[pos])) ++pos;
  return pos;
}

// The name without its namespace prefix ("d:Value" is "Value").
std::string_view LocalName(std::string_view name) {
  const std::size_t colon = name.rfind(':');
  return colon == kNpos ? name : name.substr(colon + 1);
}

void AppendUtf8(std::uint32_t code, std::string* out) {
  if (code < 0x80) {
    out->push_back(static_cast<char>(code));
  } else if (code < 0x800) {
    out->push_back(static_cast<char>(0xC0 | (code >> 6)));
    out->push_back(static_cast<char>(0x80 | (code & 0x3F)));
  } else if (code < 0x10000) {
    out->push_back(static_cast<char>(0xE0 | (code >> 12)));
    out->push_back(static_cast<char>(0x80 | ((code >> 6) & 0x3F)));
    out->push_back(static_cast<char>(0x80 | (code & 0x3F)));
  } else {
    out->push_back(static_cast<char>(0xF0 | (code >> 18)));
    out->push_back(static_cast<char>(0x80 | ((code >> 12) & 0x3F)));
    out->push_back(static_cast<char>(0x80 | ((code >> 6) & 0x3F)));
    out->push_back(static_cast<char>(0x80 | (code & 0x3F)));
  }
}

// An attribute value with XML's predefined and numeric character references replaced. A reference robocal does
// not know (a DOCTYPE's own entity) stays as written: it only ever appears in names, which are compared as text.
std::string DecodeEntities(std::string_view raw) {
  std::string out;
  out.reserve(raw.size());
  for (std::size_t i = 0; i < raw.size();) {
    if (raw[i] != '&') {
      out.push_back(raw[i++]);
      continue;
    }
    const std::size_t semicolon = raw.find(';', i);
    // References are short; a far ';' means this '&' is not one.
    if (semicolon == kNpos || semicolon - i > 10) {
      out.push_back(raw[i++]);
      continue;
    }
    const std::string_view ref = raw.substr(i + 1, semicolon - i - 1);
    std::optional<std::uint32_t> code;
    if (ref == "lt") code = '<';
    if (ref == "gt") code = '>';
    if (ref == "amp") code = '&';
    if (ref == "quot") code = '"';
    if (ref == "apos") code = '\'';
    if (ref.size() >= 2 && ref[0] == '#') {
      const bool hex = ref[1] == 'x';
      std::uint32_t value = 0;
      bool ok = ref.size() > (hex ? 2u : 1u);
      for (std::size_t k = hex ? 2 : 1; ok && k < ref.size(); ++k) {
        const char c = ref[k];
        int digit = -1;
        if (c >= '0' && c <= '9') digit = c - '0';
        if (hex && c >= 'a' && c <= 'f') digit = c - 'a' + 10;
        if (hex && c >= 'A' && c <= 'F') digit = c - 'A' + 10;
        ok = digit >= 0;
        value = value * (hex ? 16 : 10) + static_cast<std::uint32_t>(digit < 0 ? 0 : digit);
        ok = ok && value <= 0x10FFFF;
      }
      if (ok && value != 0) code = value;
    }
    if (!code) {
      out.push_back(raw[i++]);
      continue;
    }
    AppendUtf8(*code, &out);
    i = semicolon + 1;
  }
  return out;
}

struct Attribute {
  std::string_view name;
  std::size_t name_offset = 0;
  // The raw value between the quotes.
  std::size_t value_offset = 0;
  std::string_view value;
};

struct Tag {
  std::string_view name;
  std::size_t begin = 0;  // the '<'
  bool end_tag = false;
  bool self_closing = false;
  std::vector<Attribute> attributes;
};

// Walks a file's tags in order, skipping comments, CDATA, processing instructions and declarations, and throws
// ProgramError where the markup is not XML: after a broken tag robocal cannot know where the next target is.
class TagScanner {
 public:
  explicit TagScanner(const SourceText& source) : source_(source), text_(source.text()) {}

  // The next tag into *tag; false at the end of the file.
  bool Next(Tag* tag) {
    while (true) {
      const std::size_t lt = text_.find('<', pos_);
      if (lt == kNpos) {
        pos_ = text_.size();
        return false;
      }
      if (text_.substr(lt, 4) == "<!--") {
        pos_ = SkipPast(lt, lt + 4, "-->", "a comment <!-- is not closed with -->");
      } else if (text_.substr(lt, 9) == "<![CDATA[") {
        pos_ = SkipPast(lt, lt + 9, "]]>", "a CDATA section is not closed with ]]>");
      } else if (text_.substr(lt, 2) == "<?") {
        pos_ = SkipPast(lt, lt + 2, "?>", "a processing instruction <? is not closed with ?>");
      } else if (text_.substr(lt, 2) == "<!") {
        pos_ = SkipDeclaration(lt);
      } else {
        ReadTag(lt, tag);
        return true;
      }
    }
  }

 private:
  std::size_t SkipPast(std::size_t begin, std::size_t from, std::string_view end, const char* reason) const {
    const std::size_t at = text_.find(end, from);
    if (at == kNpos) source_.Fail(begin, reason);
    return at + end.size();
  }

  // <!DOCTYPE ...> and the like: up to the '>' outside quotes and outside an internal subset's brackets.
  std::size_t SkipDeclaration(std::size_t lt) const {
    int depth = 0;
    char quote = 0;
    for (std::size_t i = lt + 2; i < text_.size(); ++i) {
      const char c = text_[i];
      if (quote) {
        if (c == quote) quote = 0;
      } else if (c == '"' || c == '\'') {
        quote = c;
      } else if (c == '[') {
        ++depth;
      } else if (c == ']') {
        --depth;
      } else if (c == '>' && depth <= 0) {
        return i + 1;
      }
    }
    source_.Fail(lt, "a declaration <! is not closed with >");
  }

  void ReadTag(std::size_t lt, Tag* tag) {
    tag->begin = lt;
    tag->attributes.clear();
    tag->self_closing = false;
    tag->end_tag = lt + 1 < text_.size() && text_[lt + 1] == '/';
    const std::size_t name_begin = lt + (tag->end_tag ? 2 : 1);
    const std::size_t name_end = NameEnd(text_, name_begin);
    if (name_end == name_begin) source_.Fail(lt, "'<' begins no XML tag (write &lt; for a '<' in text)");
    tag->name = text_.substr(name_begin, name_end - name_begin);
    std::size_t p = name_end;
    while (true) {
      const std::size_t before_space = p;
      p = SkipXmlSpace(text_, p);
      if (p >= text_.size()) source_.Fail(lt, "the tag <" + std::string(tag->name) + " is not closed with >");
      if (text_[p] == '>') {
        pos_ = p + 1;
        return;
      }
      if (!tag->end_tag && text_[p] == '/' && p + 1 < text_.size() && text_[p + 1] == '>') {
        tag->self_closing = true;
        pos_ = p + 2;
        return;
      }
      const std::size_t attribute_end = NameEnd(text_, p);
      if (tag->end_tag || attribute_end == p || p == before_space) {
        source_.Fail(p, "unexpected '" + std::string(1, text_[p]) + "' in the tag <" + std::string(tag->name) + ">");
      }
      Attribute attribute;
      attribute.name = text_.substr(p, attribute_end - p);
      attribute.name_offset = p;
      p = SkipXmlSpace(text_, attribute_end);
      if (p >= text_.size() || text_[p] != '=') {
        source_.Fail(attribute.name_offset, "the attribute " + std::string(attribute.name) + " has no value");
      }
      p = SkipXmlSpace(text_, p + 1);
      if (p >= text_.size() || (text_[p] != '"' && text_[p] != '\'')) {
        source_.Fail(p, "the value of the attribute " + std::string(attribute.name) + " is not in quotes");
      }
      // XML allows no '<' in a value: meeting one first means the value's closing quote is missing.
      const char quote_chars[] = {text_[p], '<', '\0'};
      const std::size_t close = text_.find_first_of(quote_chars, p + 1);
      if (close == kNpos || text_[close] == '<') {
        source_.Fail(p, "the value of the attribute " + std::string(attribute.name) + " is not closed with " +
                            std::string(1, text_[p]));
      }
      attribute.value_offset = p + 1;
      attribute.value = text_.substr(p + 1, close - p - 1);
      tag->attributes.push_back(attribute);
      p = close + 1;
    }
  }

  const SourceText& source_;
  std::string_view text_;
  std::size_t pos_ = 0;
};

const Attribute* Find(const Tag& tag, std::string_view name) {
  for (const Attribute& attribute : tag.attributes) {
    if (attribute.name == name) return &attribute;
  }
  return nullptr;
}

// The largest array size robocal reads (a .dtx holds every element, so this is a file of 100 MB and more).
constexpr std::uint64_t kMaxSize = 1000000;

// The Data element a Value belongs to.
struct DataInfo {
  std::string name;
  std::optional<TargetKind> kind;  // nullopt: a type that holds no target (frame, tool, trsf, num, ...)
  bool single = false;             // size="1": VAL3 code names its one element without an index
  std::uint64_t size = 0;          // a target Data's size (checked)
  int values_seen = 0;
  // A target Data's keys so far: the index, and the offset of the Value that has it.
  std::unordered_map<std::uint64_t, std::size_t> keys;
};

// An attribute's decoded value without the XML spaces around it.
std::string Trimmed(std::string_view raw) {
  std::string value = DecodeEntities(raw);
  std::size_t begin = 0, end = value.size();
  while (begin < end && IsXmlSpace(value[begin])) ++begin;
  while (end > begin && IsXmlSpace(value[end - 1])) --end;
  return value.substr(begin, end - begin);
}

// A whole number of decimal digits, nullopt if `text` is not one or is above `max`.
std::optional<std::uint64_t> WholeNumber(std::string_view text, std::uint64_t max) {
  if (text.empty()) return std::nullopt;
  std::uint64_t value = 0;
  for (const char c : text) {
    if (c < '0' || c > '9') return std::nullopt;
    value = value * 10 + static_cast<std::uint64_t>(c - '0');
    if (value > max) return std::nullopt;
  }
  return value;
}

constexpr std::array<std::string_view, 6> kJointComponents = {"j1", "j2", "j3", "j4", "j5", "j6"};
constexpr std::array<std::string_view, 6> kCartesianComponents = {"x", "y", "z", "rx", "ry", "rz"};

// The frame a point is in, as the program names it: "" for the world, and an array's element 0 without its
// index, as VAL3 code names it ("fPart[0]" and "fPart" are the same frame).
std::string FrameName(std::string father) {
  if (father.size() > 3 && father.compare(father.size() - 3, 3, "[0]") == 0) father.resize(father.size() - 3);
  if (father.empty() || father == "world") return "";
  return father;
}

// A configuration word (decoded) as Staubli's sign: +1 for `positive`, -1 for `negative`, 0 for the words that
// leave it to the controller; nullopt for a word the attribute does not take.
std::optional<int> FlagOf(std::string_view word, std::string_view positive, std::string_view negative,
                          std::string_view same, std::string_view free) {
  if (word == positive) return 1;
  if (word == negative) return -1;
  if (word == same || word == free) return 0;
  return std::nullopt;
}

class Val3Reader {
 public:
  Val3Reader(const SourceText& source, ParsedProgram* program) : source_(source), program_(program) {}

  void Read() {
    TagScanner scanner(source_);
    Tag tag;
    std::optional<DataInfo> data;
    // The open elements (name, offset of the '<'), and whether the root has been met: a .dtx is one
    // <Database> element, and every element it opens is closed, or the file was cut or is no .dtx at all.
    std::vector<std::pair<std::string_view, std::size_t>> open;
    bool root_seen = false;
    std::unordered_map<std::string, std::size_t> data_names;  // the target Data's names, and where
    while (scanner.Next(&tag)) {
      CheckNesting(tag, &open, &root_seen);
      const std::string_view local = LocalName(tag.name);
      if (EqualsNoCase(local, "Data")) {
        data.reset();
        if (!tag.end_tag && !tag.self_closing) data = DataOf(tag);
        if (data && data->kind) {
          // Two arrays of one name would give two targets of each name.
          const auto [it, inserted] = data_names.emplace(data->name, tag.begin);
          if (!inserted) {
            source_.Fail(tag.begin,
                         "a second Data named " + data->name + " (the first is at " + Where(it->second) + ")");
          }
        }
      } else if (EqualsNoCase(local, "Value") && !tag.end_tag && data) {
        if (data->kind) {
          CheckKey(tag, &*data);
          ReadValue(tag, *data);
        }
        ++data->values_seen;
      }
    }
    if (!root_seen) {
      std::size_t first = 0;
      const std::string_view text = source_.text();
      if (text.substr(0, 3) == "\xEF\xBB\xBF") first = 3;  // a UTF-8 byte order mark
      first = SkipXmlSpace(text, first);
      source_.Fail(first == text.size() ? 0 : first,
                   "not a VAL3 data file: no <Database> root element" +
                       std::string(first == text.size() ? " (the file is empty)" : ""));
    }
    if (!open.empty()) {
      source_.Fail(open.back().second, "the element <" + std::string(open.back().first) +
                                           "> is not closed before the end of the file (the file is cut short?)");
    }
  }

 private:
  std::string Where(std::size_t offset) const {
    return "line " + std::to_string(source_.LineOf(offset)) + ", column " + std::to_string(source_.ColumnOf(offset));
  }

  void CheckNesting(const Tag& tag, std::vector<std::pair<std::string_view, std::size_t>>* open,
                    bool* root_seen) const {
    const std::string name(tag.name);
    if (tag.end_tag) {
      if (open->empty()) source_.Fail(tag.begin, "</" + name + "> closes no open element");
      if (open->back().first != tag.name) {
        source_.Fail(tag.begin, "</" + name + "> does not close <" + std::string(open->back().first) + "> (" +
                                    Where(open->back().second) + ")");
      }
      open->pop_back();
      return;
    }
    if (open->empty()) {
      if (*root_seen) source_.Fail(tag.begin, "<" + name + "> after the end of the <Database> root element");
      if (!EqualsNoCase(LocalName(tag.name), "Database")) {
        source_.Fail(tag.begin, "not a VAL3 data file: the root element is <" + name + ">, not <Database>");
      }
      *root_seen = true;
    }
    if (!tag.self_closing) open->emplace_back(tag.name, tag.begin);
  }

  DataInfo DataOf(const Tag& tag) const {
    DataInfo data;
    if (const Attribute* name = Find(tag, "name")) data.name = DecodeEntities(name->value);
    if (const Attribute* type = Find(tag, "type")) {
      const std::string decoded = DecodeEntities(type->value);
      if (decoded == "jointRx") data.kind = TargetKind::kJoint;
      if (decoded == "pointRx") data.kind = TargetKind::kCartesian;
    }
    const Attribute* size = Find(tag, "size");
    if (size) data.single = Trimmed(size->value) == "1";
    if (!data.kind) return data;  // not a target: the rest is not read
    // Its targets would have no name to report them by, or to tell the request's frames from.
    if (data.name.empty()) source_.Fail(tag.begin, "a jointRx or pointRx Data has no name");
    // The size bounds the keys: without it a key the controller refuses could not be told.
    if (!size) source_.Fail(tag.begin, "the " + data.name + " Data has no size (SRS writes size=\"N\")");
    const std::optional<std::uint64_t> n = WholeNumber(Trimmed(size->value), kMaxSize);
    if (!n) {
      source_.Fail(size->value_offset, "size=\"" + std::string(size->value.substr(0, 40)) +
                                           "\" is not a whole number from 0 to " + std::to_string(kMaxSize));
    }
    data.size = *n;
    return data;
  }

  // A Value's key: an index below the Data's size, and no other Value's. A Value without key takes its place
  // among its siblings.
  void CheckKey(const Tag& tag, DataInfo* data) const {
    const Attribute* key = nullptr;
    for (const Attribute& attribute : tag.attributes) {
      if (attribute.name != "key") continue;
      if (key) source_.Fail(attribute.name_offset, "the attribute key is repeated");
      key = &attribute;
    }
    std::uint64_t index = static_cast<std::uint64_t>(data->values_seen);
    std::size_t at = tag.begin;
    if (key) {
      at = key->value_offset;
      const std::optional<std::uint64_t> n = WholeNumber(Trimmed(key->value), kMaxSize);
      if (!n || *n >= data->size) {
        source_.Fail(at, "key=\"" + std::string(key->value.substr(0, 40)) + "\" is not an index of " + data->name +
                             " (a whole number from 0 to " +
                             (data->size == 0
                                  ? std::string("-1, none: size=\"0\"")
                                  : std::to_string(data->size - 1) + ", size=\"" + std::to_string(data->size) + "\"") +
                             ")");
      }
      index = *n;
    } else if (index >= data->size) {
      source_.Fail(at, "this Value without key is element " + std::to_string(index) + " of " + data->name +
                           ", beyond its size=\"" + std::to_string(data->size) + "\"");
    }
    const auto [it, inserted] = data->keys.emplace(index, tag.begin);
    if (!inserted) {
      source_.Fail(
          at, "duplicate key: " + data->name + "[" + std::to_string(index) + "] is also the Value at " +
                  Where(it->second) +
                  (key ? "" : " (this Value has no key: it is element " + std::to_string(index) + " by its place)"));
    }
  }

  void ReadValue(const Tag& tag, const DataInfo& data) {
    const bool joint = *data.kind == TargetKind::kJoint;
    const auto& components = joint ? kJointComponents : kCartesianComponents;
    std::array<std::optional<ScannedNumber>, 6> numbers;
    std::string father;
    // Raw flags: +1 / -1 as Staubli names them (lefty, epositive, wpositive are +1), 0 free or same.
    int lefty = 0, elbow_positive = 0, wrist_positive = 0;
    for (const Attribute& attribute : tag.attributes) {
      const std::string_view name = attribute.name;
      bool component = false;
      for (std::size_t k = 0; k < components.size(); ++k) {
        if (name != components[k]) continue;
        component = true;
        if (numbers[k]) source_.Fail(attribute.name_offset, "the attribute " + std::string(name) + " is repeated");
        numbers[k] = NumberOf(attribute);
      }
      if (component) continue;
      if (!joint && name == "fatherId") {
        father = DecodeEntities(attribute.value);
      } else if (!joint && name == "shoulder") {
        lefty = Flag(attribute, "lefty", "righty", "ssame", "sfree");
      } else if (!joint && name == "elbow") {
        elbow_positive = Flag(attribute, "epositive", "enegative", "esame", "efree");
      } else if (!joint && name == "wrist") {
        wrist_positive = Flag(attribute, "wpositive", "wnegative", "wsame", "wfree");
      }
    }

    std::string missing;
    int written = 0;
    for (std::size_t k = 0; k < components.size(); ++k) {
      if (numbers[k]) {
        ++written;
      } else {
        missing += (missing.empty() ? "" : ", ") + std::string(components[k]);
      }
    }
    // A value with no coordinate written holds VAL3's default (all zero): a placeholder the program fills at
    // run time (here(), appro(), compose()), with no number to rewrite.
    if (written == 0) return;
    // The key, checked (CheckKey): the attribute's number, or the Value's place among its siblings.
    std::uint64_t key = static_cast<std::uint64_t>(data.values_seen);
    if (const Attribute* attribute = Find(tag, "key")) key = *WholeNumber(Trimmed(attribute->value), kMaxSize);
    const std::string name = data.single && key == 0 ? data.name : data.name + "[" + std::to_string(key) + "]";
    if (written < static_cast<int>(components.size())) {
      // SRS leaves a zero out of the file; robocal can rewrite only numbers that are written.
      source_.Fail(tag.begin, name + ": " + missing + " not written (a .dtx leaves zeros out; write them, e.g. " +
                                  std::string(components[0]) + "=\"0\", to have the target compensated)");
    }

    ProgramTarget target;
    target.file = source_.file_index();
    target.line = source_.LineOf(numbers[0]->offset);
    target.column = source_.ColumnOf(numbers[0]->offset);
    target.name = name;
    target.kind = *data.kind;
    for (const std::optional<ScannedNumber>& number : numbers) {
      target.values.push_back(number->value);
      target.spans.push_back(NumberSpan{source_.file_index(), number->offset, number->length});
    }
    if (!joint) {
      // Staubli's flags are joint signs and a side (docs/programs.md): lefty is the wrist centre in front of
      // axis 1, epositive joint 3 >= 0, wpositive joint 5 >= 0. robocal's elbow is geometric: joint 3's sign
      // means "up" in front of axis 1 and "down" behind it, so the elbow is known only with the shoulder.
      target.configuration.shoulder = lefty;
      target.configuration.elbow = lefty * elbow_positive;
      target.configuration.wrist = wrist_positive;
      target.configuration_applies = !target.configuration.empty();
      target.base = FrameName(father);
    }
    program_->targets.push_back(std::move(target));
  }

  // The number of a coordinate: the whole value, XML spaces around it allowed, nothing else.
  ScannedNumber NumberOf(const Attribute& attribute) const {
    const std::string_view text = source_.text();
    const std::size_t end = attribute.value_offset + attribute.value.size();
    std::size_t begin = attribute.value_offset;
    while (begin < end && IsXmlSpace(text[begin])) ++begin;
    // Scanned on the value alone, so that a number cannot run past the closing quote.
    const std::optional<ScannedNumber> number = ScanNumber(attribute.value, begin - attribute.value_offset);
    std::size_t after = number ? begin + number->length : begin;
    while (after < end && IsXmlSpace(text[after])) ++after;
    if (!number || after != end) {
      source_.Fail(attribute.value_offset, std::string(attribute.name) + "=\"" +
                                               std::string(attribute.value.substr(0, 40)) + "\" is not a number");
    }
    ScannedNumber found = *number;
    found.offset = begin;
    return found;
  }

  int Flag(const Attribute& attribute, std::string_view positive, std::string_view negative, std::string_view same,
           std::string_view free) const {
    const std::optional<int> flag = FlagOf(DecodeEntities(attribute.value), positive, negative, same, free);
    if (!flag) {
      source_.Fail(attribute.value_offset, std::string(attribute.name) + "=\"" +
                                               std::string(attribute.value.substr(0, 40)) + "\" is not one of " +
                                               std::string(positive) + ", " + std::string(negative) + ", " +
                                               std::string(same) + ", " + std::string(free));
    }
    return *flag;
  }

  const SourceText& source_;
  ParsedProgram* program_;
};

ParsedProgram ReadVal3(const std::vector<ProgramFile>& files) {
  ParsedProgram program;
  for (std::size_t i = 0; i < files.size(); ++i) {
    const SourceText source(files[i], static_cast<int>(i));
    Val3Reader(source, &program).Read();
  }
  return program;
}

}  // namespace

const DialectSyntax& Val3Syntax() {
  static const DialectSyntax syntax{
      .dialect = Dialect::kVal3,
      .name = "val3",
      .extensions = {".dtx"},
      .rotation = RotationConvention::kXyzIntrinsicDeg,
      .mm_per_length_unit = 1.0,
      .joints_in_rad = false,
      .read = &ReadVal3,
      // A .dtx holds data only; inserting a target would need a motion in the .pgx code, which robocal does not
      // read.
      .inline_target = nullptr,
  };
  return syntax;
}

}  // namespace robocal::programs
