// The Staubli VAL3 reader (val3.cc): the jointRx and pointRx values of robocal's own .dtx samples with the exact
// bytes of their numbers, names, frames and flags; the XML it must see through (comments, CDATA, declarations,
// entities, either quote, any attribute order); errors with file, line and column; and input it must survive.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "robocal/programs/program.h"
#include "robocal/programs/text_scan.h"

namespace robocal::programs {
const DialectSyntax& Val3Syntax();

namespace {

std::string ReadSample(const std::string& name) {
  std::ifstream in(std::string(ROBOCAL_PROGRAM_SAMPLES) + "/val3/" + name, std::ios::binary);
  EXPECT_TRUE(in.good()) << name;
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

ParsedProgram Read(const std::vector<ProgramFile>& files) { return Val3Syntax().read(files); }
ParsedProgram ReadText(const std::string& text) { return Read({{"cell.dtx", text}}); }

// A .dtx with the given Data elements.
std::string Dtx(const std::string& datas) {
  return "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n"
         "<Database xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
         "xmlns=\"http://www.staubli.com/robotics/VAL3/Data/2\">\n<Datas>\n" +
         datas + "</Datas>\n</Database>\n";
}

const ProgramTarget& Named(const ParsedProgram& program, const std::string& name) {
  for (const ProgramTarget& target : program.targets) {
    if (target.name == name) return target;
  }
  ADD_FAILURE() << "no target " << name;
  static const ProgramTarget none;
  return none;
}

std::string_view SpanText(const std::vector<ProgramFile>& files, const NumberSpan& span) {
  return std::string_view(files[span.file].text).substr(span.offset, span.length);
}

// Every target's spans hold exactly its numbers, and its line and column are those of its first number.
void ExpectExactSpans(const std::vector<ProgramFile>& files, const ParsedProgram& program) {
  for (const ProgramTarget& target : program.targets) {
    ASSERT_EQ(target.spans.size(), 6u) << *target.name;
    ASSERT_EQ(target.values.size(), 6u) << *target.name;
    for (std::size_t k = 0; k < 6; ++k) {
      const NumberSpan& span = target.spans[k];
      EXPECT_EQ(span.file, target.file);
      const std::string_view text = SpanText(files, span);
      const auto number = ScanNumber(text, 0);
      ASSERT_TRUE(number.has_value()) << *target.name << " " << k << " '" << text << "'";
      EXPECT_EQ(number->length, text.size()) << *target.name << " " << k;
      EXPECT_EQ(number->value, target.values[k]) << *target.name << " " << k;
    }
    const SourceText source(files[target.file], target.file);
    EXPECT_EQ(target.line, source.LineOf(target.spans[0].offset)) << *target.name;
    EXPECT_EQ(target.column, source.ColumnOf(target.spans[0].offset)) << *target.name;
  }
}

void ExpectError(const std::string& text, int line, int column, const std::string& reason_part) {
  try {
    ReadText(text);
    ADD_FAILURE() << "no error; expected " << line << ":" << column << " " << reason_part;
  } catch (const ProgramError& e) {
    EXPECT_EQ(e.file(), "cell.dtx");
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_EQ(e.column(), column) << e.what();
    EXPECT_NE(e.reason().find(reason_part), std::string::npos) << e.what();
  }
}

TEST(Val3Syntax, Row) {
  const DialectSyntax& row = Val3Syntax();
  EXPECT_EQ(row.dialect, Dialect::kVal3);
  EXPECT_STREQ(row.name, "val3");
  EXPECT_EQ(row.extensions, std::vector<std::string>{".dtx"});
  EXPECT_EQ(row.rotation, RotationConvention::kXyzIntrinsicDeg);
  EXPECT_EQ(row.mm_per_length_unit, 1.0);
  EXPECT_FALSE(row.joints_in_rad);
  EXPECT_NE(row.read, nullptr);
  EXPECT_EQ(row.inline_target, nullptr);  // a .dtx has no motions to insert a target before
}

TEST(Val3Samples, BothFilesEveryTargetExact) {
  const std::vector<ProgramFile> files = {{"palletize.dtx", ReadSample("palletize.dtx")},
                                          {"inspect.dtx", ReadSample("inspect.dtx")}};
  ASSERT_NE(files[0].text.find("\r\n"), std::string::npos);  // the mixed line ends are part of the sample
  const ParsedProgram program = Read(files);
  int joints = 0, points = 0;
  for (const ProgramTarget& target : program.targets) {
    (target.kind == TargetKind::kJoint ? joints : points)++;
    EXPECT_EQ(target.motion, Motion::kNone);  // a .dtx has data only
    EXPECT_TRUE(target.turns.empty());
    EXPECT_EQ(target.tool, "");  // the tool is chosen in the .pgx motion
    ASSERT_TRUE(target.name.has_value());
  }
  EXPECT_EQ(joints, 25);
  EXPECT_EQ(points, 25);
  EXPECT_TRUE(program.motions.empty());
  ExpectExactSpans(files, program);
  // Ordered by file, then by offset (of the value's first number in the text, whatever its attribute order).
  auto first_byte = [](const ProgramTarget& target) {
    std::size_t first = target.spans[0].offset;
    for (const NumberSpan& span : target.spans) first = std::min(first, span.offset);
    return first;
  };
  for (std::size_t i = 1; i < program.targets.size(); ++i) {
    const ProgramTarget& a = program.targets[i - 1];
    const ProgramTarget& b = program.targets[i];
    EXPECT_TRUE(a.file < b.file || (a.file == b.file && first_byte(a) < first_byte(b))) << *a.name << " " << *b.name;
  }
  EXPECT_EQ(program.targets.front().file, 0);
  EXPECT_EQ(program.targets.back().file, 1);
  EXPECT_EQ(*program.targets.back().name, "pLight");
}

TEST(Val3Samples, PalletizeNamesValuesAndPlaces) {
  const std::vector<ProgramFile> files = {{"palletize.dtx", ReadSample("palletize.dtx")}};
  const ParsedProgram program = Read(files);
  ASSERT_EQ(program.targets.size(), 25u);
  // Not targets: frames, tools, trsf, the commented-out jOld, the placeholder pTemp.
  for (const ProgramTarget& target : program.targets) {
    EXPECT_EQ(target.name->find("jOld"), std::string::npos);
    EXPECT_EQ(target.name->find("pTemp"), std::string::npos);
    EXPECT_EQ(target.name->find("fPallet"), std::string::npos);
  }

  const ProgramTarget& park = program.targets[0];
  EXPECT_EQ(*park.name, "jPark");  // size 1: named without index, as VAL3 code names it
  EXPECT_EQ(park.kind, TargetKind::kJoint);
  EXPECT_EQ(park.values, (std::vector<double>{0, -35, 125, 0, 90, 0}));
  EXPECT_EQ(park.line, 25);
  EXPECT_EQ(park.column, 26);
  EXPECT_FALSE(park.configuration_applies);
  EXPECT_TRUE(park.base.empty());

  // Attributes in reverse order: the spans still go j1..j6.
  const ProgramTarget& reversed = Named(program, "jClear[3]");
  EXPECT_EQ(reversed.values, (std::vector<double>{-50.375, -5.75, 97, 2, 79.25, -50}));
  EXPECT_GT(reversed.spans[0].offset, reversed.spans[5].offset);
  EXPECT_EQ(SpanText(files, reversed.spans[0]), "-50.375");
  // Folded over lines: the target is where j1 is.
  const ProgramTarget& folded = Named(program, "jClear[4]");
  EXPECT_EQ(folded.line, 34);
  EXPECT_EQ(folded.column, 18);
  EXPECT_EQ(SpanText(files, folded.spans[5]), "-62.500");
  // Tabs and spaces around '=': the span is the number alone.
  EXPECT_EQ(SpanText(files, Named(program, "jClear[2]").spans[3]), "1.5");
  EXPECT_EQ(SpanText(files, Named(program, "jClear[5]").spans[0]), "-75.625");
  EXPECT_EQ(SpanText(files, Named(program, "jClear[8]").spans[0]), "+37.750");
  EXPECT_EQ(Named(program, "jClear[6]").values[0], 12.5);  // <Value ...></Value>

  const ProgramTarget& pick0 = Named(program, "pPick[0]");
  EXPECT_EQ(pick0.kind, TargetKind::kCartesian);
  EXPECT_EQ(pick0.values, (std::vector<double>{100, 80, 350, 180, 0, 0}));
  EXPECT_EQ(pick0.base, "fPallet");  // fPallet[0] is fPallet
  EXPECT_EQ(pick0.configuration, (ArmConfiguration{1, 1, 1}));
  EXPECT_TRUE(pick0.configuration_applies);
  EXPECT_EQ(Named(program, "pPick[3]").values,
            (std::vector<double>{93.837, 619.051, 1163.416, 224.441, -33.274, 176.582}));
  EXPECT_EQ(Named(program, "pPick[3]").configuration, (ArmConfiguration{1, 1, 1}));
  EXPECT_EQ(Named(program, "pPick[4]").base, "fPallet[1]");
  EXPECT_EQ(Named(program, "pPick[7]").base, "fPallet[1]");  // written with character references
  EXPECT_EQ(Named(program, "pPlace").base, "fConveyor");
  EXPECT_EQ(Named(program, "pAbove[0]").base, "");  // world[0]
  EXPECT_EQ(Named(program, "pAbove[1]").base, "");  // world
  EXPECT_EQ(Named(program, "pAbove[2]").base, "");  // no fatherId
  EXPECT_EQ(Named(program, "pAbove[1]").values[3], -180.0);
  EXPECT_EQ(SpanText(files, Named(program, "pAbove[0]").spans[4]), "-0.000");
}

TEST(Val3Samples, FlagsMapOntoRobocalConfiguration) {
  const std::vector<ProgramFile> files = {{"palletize.dtx", ReadSample("palletize.dtx")},
                                          {"inspect.dtx", ReadSample("inspect.dtx")}};
  const ParsedProgram program = Read(files);
  // ssame / esame / wsame: every flag free, so the configuration does not apply.
  EXPECT_EQ(Named(program, "pPick[5]").configuration, ArmConfiguration{});
  EXPECT_FALSE(Named(program, "pPick[5]").configuration_applies);
  // epositive with a free shoulder: the geometric elbow is not known.
  EXPECT_EQ(Named(program, "pPick[6]").configuration, ArmConfiguration{});
  EXPECT_FALSE(Named(program, "pPick[6]").configuration_applies);
  // The wrist alone.
  EXPECT_EQ(Named(program, "pPick[7]").configuration, (ArmConfiguration{0, 0, -1}));
  EXPECT_TRUE(Named(program, "pPick[7]").configuration_applies);
  EXPECT_EQ(Named(program, "pAbove[2]").configuration, (ArmConfiguration{1, -1, 1}));  // lefty enegative
  EXPECT_EQ(Named(program, "pScan[6]").configuration, (ArmConfiguration{1, 1, -1}));
  // righty: behind axis 1, where joint 3 positive puts the elbow below the shoulder-wrist line.
  EXPECT_EQ(Named(program, "pScan[10]").configuration, (ArmConfiguration{-1, 1, 1}));    // righty enegative
  EXPECT_EQ(Named(program, "pScan[11]").configuration, (ArmConfiguration{-1, -1, -1}));  // righty epositive
  EXPECT_EQ(Named(program, "pScan[11]").file, 1);
  EXPECT_EQ(Named(program, "pScan[0]").base, "fHousing");
  EXPECT_EQ(Named(program, "pScan[6]").base, "fHousing[1]");
  EXPECT_EQ(Named(program, "pLight").base, "fFixture");
  EXPECT_EQ(Named(program, "jScan[8]").values, (std::vector<double>{12, -2.5, 114, -50, -40, 65}));
  EXPECT_EQ(SpanText(files, Named(program, "jScan[8]").spans[1]), "-2.5E+00");
}

// Rewriting every span with other numbers changes those values and nothing else the reader sees.
TEST(Val3Samples, RewrittenSpansReadBack) {
  const std::vector<ProgramFile> files = {{"palletize.dtx", ReadSample("palletize.dtx")}};
  const ParsedProgram before = Read(files);
  std::vector<NumberSpan> spans;
  for (const ProgramTarget& target : before.targets)
    spans.insert(spans.end(), target.spans.begin(), target.spans.end());
  std::sort(spans.begin(), spans.end(), [](const NumberSpan& a, const NumberSpan& b) { return a.offset > b.offset; });
  std::string text = files[0].text;
  for (const NumberSpan& span : spans) {
    text.replace(span.offset, span.length, "-1234.56789");
  }
  const ParsedProgram after = ReadText(text);
  ASSERT_EQ(after.targets.size(), before.targets.size());
  for (std::size_t i = 0; i < after.targets.size(); ++i) {
    EXPECT_EQ(after.targets[i].name, before.targets[i].name);
    EXPECT_EQ(after.targets[i].configuration, before.targets[i].configuration);
    EXPECT_EQ(after.targets[i].base, before.targets[i].base);
    EXPECT_EQ(after.targets[i].values, std::vector<double>(6, -1234.56789));
  }
}

TEST(Val3Xml, SeesThroughCommentsCdataDeclarationsAndPrefixes) {
  const std::string text =
      "<?xml version='1.0'?>\n"
      "<!DOCTYPE Database [ <!ENTITY x \"a > b ] c\"> ]>\n"
      "<v:Database xmlns:v=\"http://www.staubli.com/robotics/VAL3/Data/2\"><v:Datas>\n"
      "<!-- <Data name=\"c\" type=\"jointRx\"><Value j1=\"1\"/></Data> -->\n"
      "<v:Data name=\"jA\" type=\"jointRx\" size=\"2\">"
      "<![CDATA[ <Value key=\"9\" j1=\"9\" j2=\"9\" j3=\"9\" j4=\"9\" j5=\"9\" j6=\"9\"/> ]]>"
      "<?robocal ignore <Value ?>\n"
      "<v:Value key=\"0\" j1=\" 1.5 \" j2=\"2\" j3=\"3\" j4=\"4\" j5=\"5\" j6=\"6\" extra=\"&lt;&amp;\"/>\n"
      "<v:Value key=\"1\" j1=\"-1\" j2=\"-2\" j3=\"-3\" j4=\"-4\" j5=\"-5\" j6=\"-6\" j7=\"70\"/>\n"
      "</v:Data>\n"
      "<Value key=\"0\" j1=\"1\" j2=\"2\" j3=\"3\" j4=\"4\" j5=\"5\" j6=\"6\"/>\n"  // outside any Data
      "<Data name=\"tT\" type=\"tool\" size=\"1\"><Value key=\"0\" x=\"1\" y=\"2\" z=\"3\" rx=\"4\" ry=\"5\" "
      "rz=\"6\"/></Data>\n"
      "<Data name=\"jEmpty\" type=\"jointRx\" size=\"1\"/>\n"
      "<Value key=\"0\" j1=\"1\" j2=\"2\" j3=\"3\" j4=\"4\" j5=\"5\" j6=\"6\"/>\n"  // after a self-closed Data
      "</v:Datas></v:Database>\n";
  const std::vector<ProgramFile> files = {{"cell.dtx", text}};
  const ParsedProgram program = Read(files);
  ASSERT_EQ(program.targets.size(), 2u);
  EXPECT_EQ(*program.targets[0].name, "jA[0]");
  EXPECT_EQ(program.targets[0].values, (std::vector<double>{1.5, 2, 3, 4, 5, 6}));
  EXPECT_EQ(SpanText(files, program.targets[0].spans[0]), "1.5");  // the spaces around it are not rewritten
  EXPECT_EQ(program.targets[0].line, 6);
  EXPECT_EQ(*program.targets[1].name, "jA[1]");
  EXPECT_EQ(program.targets[1].values.size(), 6u);  // j7 (an external axis) is not listed
  ExpectExactSpans(files, program);
}

TEST(Val3Xml, NamesFromKeysAndEntities) {
  const ParsedProgram program =
      ReadText(Dtx("<Data name=\"p&#x41;\" type=\"pointRx\" size=\"1\">\n"
                   "  <Value key=\"0\" x=\"1\" y=\"2\" z=\"3\" rx=\"4\" ry=\"5\" rz=\"6\" fatherId=\"f&amp;g[2]\"/>\n"
                   "</Data>\n"
                   "<Data name=\"pB\" type=\"pointRx\" size=\"4\">\n"
                   "  <Value key=\"3\" x=\"1\" y=\"2\" z=\"3\" rx=\"4\" ry=\"5\" rz=\"6\" fatherId=\"world[0]\"/>\n"
                   "  <Value x=\"1\" y=\"2\" z=\"3\" rx=\"4\" ry=\"5\" rz=\"6\"/>\n"
                   "</Data>\n"));
  ASSERT_EQ(program.targets.size(), 3u);
  EXPECT_EQ(*program.targets[0].name, "pA");
  EXPECT_EQ(program.targets[0].base, "f&g[2]");
  EXPECT_EQ(*program.targets[1].name, "pB[3]");
  EXPECT_EQ(*program.targets[2].name, "pB[1]");  // no key: its place among the Values
}

TEST(Val3Errors, MalformedTargetsNameLineAndColumn) {
  const std::string head = Dtx("").substr(0, Dtx("").find("<Datas>\n") + 8);  // 3 lines
  const std::string data = "<Data name=\"j\" type=\"jointRx\" size=\"1\">\n";
  // Line 5 holds the Value.
  ExpectError(head + data + "<Value key=\"0\" j1=\"1\" j2=\"2,5\" j3=\"3\" j4=\"4\" j5=\"5\" j6=\"6\"/>\n</Data>", 5,
              27, "j2=\"2,5\" is not a number");
  ExpectError(head + data + "<Value key=\"0\" j1=\"abc\" j2=\"2\" j3=\"3\" j4=\"4\" j5=\"5\" j6=\"6\"/>\n</Data>", 5,
              20, "not a number");
  ExpectError(head + data + "<Value key=\"0\" j1=\"12.5mm\" j2=\"2\" j3=\"3\" j4=\"4\" j5=\"5\" j6=\"6\"/>\n", 5, 20,
              "not a number");
  ExpectError(head + data + "<Value key=\"0\" j1=\"\" j2=\"2\" j3=\"3\" j4=\"4\" j5=\"5\" j6=\"6\"/>\n", 5, 20,
              "not a number");
  ExpectError(head + data + "<Value key=\"0\" j1=\"1\" j2=\"2\" j3=\"3\" j5=\"5\" j6=\"6\"/>\n</Data>", 5, 1,
              "j: j4 not written");
  ExpectError(head + data + "<Value key=\"0\" j1=\"1\" j1=\"1\" j2=\"2\" j3=\"3\" j4=\"4\" j5=\"5\" j6=\"6\"/>\n", 5,
              23, "repeated");
  // A value missing its closing quote ends at the next quote; the tag stops making sense right after it.
  ExpectError(head + data + "<Value key=\"0\" j1=\"1\" j2=\"2 j3=\"3\" j4=\"4\" j5=\"5\" j6=\"6\"/>\n</Data>\n", 5, 33,
              "unexpected '3'");
  // One that meets the next tag first is reported at its opening quote.
  ExpectError(head + data + "<Value key=\"0\" j1=\"1\" j2=\"2\" j3=\"3\" j4=\"4\" j5=\"5\" j6=\"6/>\n</Data>\n", 5, 54,
              "j6 is not closed");
  ExpectError(head + data + "<Value key=\"0\" j1=1 j2=\"2\"/>\n", 5, 19, "not in quotes");
  ExpectError(head + data + "<Value key=\"0\" j1 j2=\"2\"/>\n", 5, 16, "j1 has no value");
  ExpectError(head + data + "<Value key=\"0\" j1=\"1\"", 5, 1, "not closed with >");
  ExpectError(head + "<!-- open comment\n<Data>", 4, 1, "comment");
  ExpectError(head +
                  "<Data type=\"jointRx\" size=\"1\">\n<Value j1=\"1\" j2=\"2\" j3=\"3\" j4=\"4\" j5=\"5\" "
                  "j6=\"6\"/>\n",
              4, 1, "has no name");
  ExpectError(head + "< Data>", 4, 1, "begins no XML tag");
  ExpectError(head +
                  "<Data name=\"p\" type=\"pointRx\" size=\"1\">\n"
                  "<Value x=\"1\" y=\"2\" z=\"3\" rx=\"4\" ry=\"5\" rz=\"6\" shoulder=\"left\"/>\n",
              5, 57, "shoulder=\"left\" is not one of lefty, righty");
  ExpectError(head +
                  "<Data name=\"p\" type=\"pointRx\" size=\"1\">\n"
                  "<Value x=\"1\" y=\"2\" z=\"3\" rx=\"4\" ry=\"5\" rz=\"6\" wrist=\"WPOSITIVE\"/>\n",
              5, 54, "wrist=");
}

// The keys and sizes of a target Data: every key an index below the size, no two Values with one key.
TEST(Val3Errors, KeysAndSizes) {
  const std::string head = Dtx("").substr(0, Dtx("").find("<Datas>\n") + 8);  // 3 lines
  const std::string joints = " j1=\"1\" j2=\"2\" j3=\"3\" j4=\"4\" j5=\"5\" j6=\"6\"/>\n";
  const std::string data2 = "<Data name=\"jA\" type=\"jointRx\" size=\"2\">\n";  // line 4
  // Two Values with key 0: both would be compensated as jA[0]. At the second's key, naming the first.
  ExpectError(head + data2 + "<Value key=\"0\"" + joints + "<Value key=\"0\"" + joints + "</Data>", 6, 13,
              "duplicate key: jA[0] is also the Value at line 5, column 1");
  // A Value without key is the element of its place: here 1, which key="1" already is.
  ExpectError(head + data2 + "<Value key=\"1\"" + joints + "<Value" + joints + "</Data>", 6, 1,
              "duplicate key: jA[1] is also the Value at line 5");
  ExpectError(head + data2 + "<Value key=\"0\" key=\"1\"" + joints + "</Data>", 5, 16, "the attribute key is repeated");
  // Keys out of [0, size): beyond, negative, not a number, overflowing.
  const std::string data1 = "<Data name=\"jB\" type=\"jointRx\" size=\"1\">\n";
  ExpectError(head + data1 + "<Value key=\"5\"" + joints + "</Data>", 5, 13,
              "key=\"5\" is not an index of jB (a whole number from 0 to 0, size=\"1\")");
  ExpectError(head + data1 + "<Value key=\"-1\"" + joints + "</Data>", 5, 13, "key=\"-1\" is not an index of jB");
  ExpectError(head + data1 + "<Value key=\"abc\"" + joints + "</Data>", 5, 13, "key=\"abc\" is not an index");
  ExpectError(head + data1 + "<Value key=\"\"" + joints + "</Data>", 5, 13, "key=\"\" is not an index");
  ExpectError(head + data1 + "<Value key=\"1.0\"" + joints + "</Data>", 5, 13, "is not an index");
  ExpectError(head + data1 + "<Value key=\"99999999999999999999\"" + joints + "</Data>", 5, 13,
              "key=\"99999999999999999999\" is not an index of jB");
  // A placeholder (no coordinate) is checked too: its key is still an element the controller must hold.
  ExpectError(head + data1 + "<Value key=\"0\"" + joints + "<Value key=\"3\"/>\n</Data>", 6, 13,
              "key=\"3\" is not an index");
  // Values without key past the size.
  ExpectError(head + data1 + "<Value" + joints + "<Value" + joints + "</Data>", 6, 1,
              "this Value without key is element 1 of jB, beyond its size=\"1\"");
  // Sizes: not a whole number, absurd, absent.
  ExpectError(head + "<Data name=\"p\" type=\"pointRx\" size=\"x\">\n</Data>", 4, 37,
              "size=\"x\" is not a whole number from 0 to 1000000");
  ExpectError(head + "<Data name=\"p\" type=\"pointRx\" size=\"4000000000\">\n</Data>", 4, 37,
              "size=\"4000000000\" is not a whole number");
  ExpectError(head + "<Data name=\"p\" type=\"pointRx\" size=\"-3\">\n</Data>", 4, 37, "not a whole number");
  ExpectError(head + "<Data name=\"p\" type=\"pointRx\" size=\"2.5\">\n</Data>", 4, 37, "not a whole number");
  ExpectError(head + "<Data name=\"p\" type=\"pointRx\">\n</Data>", 4, 1, "the p Data has no size");
  ExpectError(head + "<Data name=\"z\" type=\"jointRx\" size=\"0\">\n<Value" + joints + "</Data>", 5, 1,
              "element 0 of z, beyond its size=\"0\"");
  // Two arrays of one name.
  ExpectError(head + data1 + "</Data>\n" + data2 + "</Data>\n" + data1 + "</Data>", 8, 1,
              "a second Data named jB (the first is at line 4, column 1)");
}

// A file that is no .dtx, or is cut short, is refused rather than read as holding no target.
TEST(Val3Errors, NotADataFileOrCutShort) {
  ExpectError("hello", 1, 1, "not a VAL3 data file: no <Database> root element");
  ExpectError("\n\n  hello <b>world</b>", 3, 9, "not a VAL3 data file: the root element is <b>, not <Database>");
  ExpectError("", 1, 1, "no <Database> root element (the file is empty)");
  ExpectError("<?xml version=\"1.0\"?>\n<!-- only a comment -->\n", 1, 1, "no <Database> root element");
  std::string many;
  for (int i = 0; i < 100000; ++i) many += "<a>";
  ExpectError(many, 1, 1, "not a VAL3 data file: the root element is <a>");
  ExpectError("<Database><Datas>" + many, 1, 17 + 3 * 99999 + 1, "the element <a> is not closed before the end");
  // The samples cut before their last lines.
  const std::string sample = ReadSample("inspect.dtx");
  // The innermost open element is named: <Datas>, at line 7.
  ExpectError(sample.substr(0, sample.rfind("</Datas>")), 7, 3, "the element <Datas> is not closed");
  const std::string cut = sample.substr(0, sample.rfind("</Data>"));
  try {
    ReadText(cut);
    ADD_FAILURE() << "no error";
  } catch (const ProgramError& e) {
    EXPECT_NE(e.reason().find("the element <Data> is not closed"), std::string::npos) << e.what();
  }
  // Markup that does not nest, and elements after the root.
  ExpectError("<Database><Datas></Database>", 1, 18, "</Database> does not close <Datas> (line 1, column 11)");
  ExpectError("<Database></Database></Datas>", 1, 22, "</Datas> closes no open element");
  ExpectError("<Database></Database>\n<Data name=\"j\" type=\"jointRx\" size=\"1\"><Value j1=\"1\"/></Data>", 2, 1,
              "<Data> after the end of the <Database> root element");
  ExpectError(
      "<Data name=\"j\" type=\"jointRx\" size=\"1\"><Value key=\"0\" j1=\"1\" j2=\"2\" j3=\"3\" "
      "j4=\"4\" j5=\"5\" j6=\"6\"/></Data>",
      1, 1, "the root element is <Data>, not <Database>");
}

// What the Staubli editor writes, and XML allows, still reads: a byte order mark, comments and a DOCTYPE
// before the root, keys in any order or left out, spaces around a key, zero attributes left out of a
// placeholder, an empty array, a self-closed root.
TEST(Val3Xml, KeysAsTheEditorWritesThem) {
  const ParsedProgram program = ReadText(
      "\xEF\xBB\xBF<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<!-- cell 3 -->\n<!DOCTYPE Database>\n"
      "<Database xmlns=\"http://www.staubli.com/robotics/VAL3/Data/2\"><Datas>\n"
      "<Data name=\"jA\" type=\"jointRx\" size=\"3\">\n"
      "  <Value key=\"1\" j1=\"1\" j2=\"2\" j3=\"3\" j4=\"4\" j5=\"5\" j6=\"6\"/>\n"
      "  <Value key=\" 0 \" j1=\"1\" j2=\"2\" j3=\"3\" j4=\"4\" j5=\"5\" j6=\"6\"/>\n"
      "  <Value/>\n"  // element 2, by its place: a placeholder
      "</Data>\n"
      "<Data name=\"pB\" type=\"pointRx\" size=\"3\">\n"
      "  <Value x=\"1\" y=\"2\" z=\"3\" rx=\"4\" ry=\"5\" rz=\"6\"/><![CDATA[ <Value key=\"0\"/> ]]>\n"
      "  <Value key=\"1\" fatherId=\"world[0]\"/>\n"
      "  <Value x=\"1\" y=\"2\" z=\"3\" rx=\"4\" ry=\"5\" rz=\"6\"/>\n"
      "</Data>\n"
      "<Data name=\"jEmpty\" type=\"jointRx\" size=\"0\"></Data>\n"
      "<Data name=\"t\" type=\"tool\" size=\"x\"><Value key=\"-1\"/><Value key=\"-1\"/></Data>\n"
      "</Datas></Database>\n<!-- end -->\n");
  ASSERT_EQ(program.targets.size(), 4u);
  EXPECT_EQ(*program.targets[0].name, "jA[1]");
  EXPECT_EQ(*program.targets[1].name, "jA[0]");
  EXPECT_EQ(*program.targets[2].name, "pB[0]");
  EXPECT_EQ(*program.targets[3].name, "pB[2]");
  EXPECT_EQ(ReadText("<Database/>").targets.size(), 0u);
}

TEST(Val3Errors, CrlfLinesAndTheSecondFile) {
  const std::string bad =
      "<Database>\r\n<Datas>\r\n<Data name=\"p\" type=\"pointRx\" size=\"1\">\r\n"
      "\t<Value x=\"1\" y=\"2\" z=\"3\" rx=\"4\" ry=\"5\" rz=\"nan\"/>\r\n";
  try {
    Read({{"good.dtx", ReadSample("inspect.dtx")}, {"bad.dtx", bad}});
    ADD_FAILURE() << "no error";
  } catch (const ProgramError& e) {
    EXPECT_EQ(e.file(), "bad.dtx");
    EXPECT_EQ(e.line(), 4);
    EXPECT_EQ(e.column(), 45);
  }
}

// Not targets, so no error: a placeholder value, broken numbers in a tool, an unknown type.
TEST(Val3Errors, WhatIsNotATargetIsNotChecked) {
  const ParsedProgram program = ReadText(
      Dtx("<Data name=\"p\" type=\"pointRx\" size=\"1\"><Value key=\"0\" fatherId=\"fA[0]\" shoulder=\"lefty\"/>"
          "</Data>\n"
          "<Data name=\"j\" type=\"jointRx\" size=\"1\"><Value key=\"0\"/></Data>\n"
          "<Data name=\"t\" type=\"tool\" size=\"1\"><Value key=\"0\" x=\"1,5\" z=\"\"/></Data>\n"
          "<Data name=\"s\" type=\"pointRs\" size=\"1\"><Value key=\"0\" x=\"1\"/></Data>\n"));
  EXPECT_TRUE(program.targets.empty());
}

// Every prefix of a sample, and seeded random damage to it: the reader returns or throws ProgramError, and
// whatever it returns has spans inside the text that hold its numbers.
TEST(Val3Robustness, TruncatedAndDamagedFiles) {
  const std::string sample = ReadSample("palletize.dtx");
  auto check = [](const std::string& text) {
    const std::vector<ProgramFile> files = {{"x.dtx", text}};
    try {
      const ParsedProgram program = Read(files);
      for (const ProgramTarget& target : program.targets) {
        for (const NumberSpan& span : target.spans) {
          ASSERT_LE(span.offset + span.length, text.size());
        }
      }
      ExpectExactSpans(files, program);
    } catch (const ProgramError& e) {
      ASSERT_GE(e.line(), 1);
      ASSERT_GE(e.column(), 1);
      ASSERT_EQ(e.file(), "x.dtx");
    }
  };
  for (std::size_t n = 0; n <= sample.size(); n += 7) check(sample.substr(0, n));
  std::mt19937 random(37);
  const std::string alphabet = "<>/=\"'!-?[]&;#x0123456789.eE+- \t\r\nabcDV\x80\xff";
  for (int trial = 0; trial < 2000; ++trial) {
    std::string text = sample;
    const int edits = 1 + static_cast<int>(random() % 4);
    for (int e = 0; e < edits; ++e) {
      const std::size_t at = random() % text.size();
      const char c = alphabet[random() % alphabet.size()];
      switch (random() % 3) {
        case 0:
          text[at] = c;
          break;
        case 1:
          text.insert(text.begin() + static_cast<std::ptrdiff_t>(at), c);
          break;
        default:
          text.erase(at, 1 + random() % 8);
          break;
      }
    }
    check(text);
  }
  check(std::string(1, '\0'));
  check("<");
  check("<!");
  check("<!--");
  check("<![CDATA[");
  check("<a b='");
  check("<Data type='jointRx'><Value j1='1' j2='2' j3='3' j4='4' j5='5' j6='");
  check("<Data type='jointRx'><Value j1='&#99999999999;' j2='2' j3='3' j4='4' j5='5' j6='6'/>");
  check(
      "<Data name='&#x110000;&#0;&#;&#x;&' type='pointRx'><Value x='1' y='2' z='3' rx='4' ry='5' rz='6' "
      "fatherId='&#xFFFF;&#x10FFFF;'/>");
}

// 10,000 targets read in one linear pass (reading time is the benchmark's, never a test's).
TEST(Val3LargeProgram, TenThousandTargetsReadWhole) {
  std::string datas = "<Data name=\"pMany\" access=\"public\" xsi:type=\"array\" type=\"pointRx\" size=\"5000\">\n";
  for (int i = 0; i < 5000; ++i) {
    datas += "  <Value key=\"" + std::to_string(i) + "\" x=\"" + std::to_string(300 + i % 200) +
             ".125\" y=\"-12.500\" z=\"450.000\" rx=\"180.000\" ry=\"0.000\" rz=\"" + std::to_string(i % 90) +
             ".5\" shoulder=\"lefty\" elbow=\"epositive\" wrist=\"wpositive\" fatherId=\"fPart[0]\" />\n";
  }
  datas += "</Data>\n<Data name=\"jMany\" access=\"public\" xsi:type=\"array\" type=\"jointRx\" size=\"5000\">\n";
  for (int i = 0; i < 5000; ++i) {
    datas += "  <Value key=\"" + std::to_string(i) + "\" j1=\"" + std::to_string(i % 170) +
             ".25\" j2=\"-20.000\" j3=\"110.000\" j4=\"0.500\" j5=\"80.000\" j6=\"-12.000\" />\n";
  }
  datas += "</Data>\n";
  const std::string text = Dtx(datas);
  const ParsedProgram program = ReadText(text);
  ASSERT_EQ(program.targets.size(), 10000u);
  EXPECT_EQ(*program.targets[4999].name, "pMany[4999]");
  EXPECT_EQ(program.targets[4999].values[0], 300 + 4999 % 200 + 0.125);
  EXPECT_EQ(*program.targets[9999].name, "jMany[4999]");
}

}  // namespace
}  // namespace robocal::programs
