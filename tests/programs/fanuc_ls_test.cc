// The FANUC .ls reader on its own: robocal's two sample programs (one as the controller writes it, CRLF with a few
// LF lines; one offline-programmed and hand-edited, LF), and small programs for each rule of docs/programs.md (the
// /POS blocks and their components, CONFIG's letters and turn numbers, the motions of /MN and their spans, INC,
// errors with file, line and column), robustness on truncated, mutated and random input, and a 10,000-target
// program.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "robocal/programs/program.h"
#include "robocal/programs/text_scan.h"

namespace robocal::programs {
const DialectSyntax& FanucLsSyntax();

namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

constexpr double kDeg = std::numbers::pi / 180.0;

ParsedProgram Read(const std::string& text, const std::string& name = "test.ls") {
  return FanucLsSyntax().read({ProgramFile{name, text}});
}

std::string Sample(const std::string& name) {
  std::ifstream in(std::string(ROBOCAL_PROGRAM_SAMPLES) + "/fanuc/" + name, std::ios::binary);
  EXPECT_TRUE(in.good()) << name;
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// 1-based line and column of an offset, counted here rather than by the reader's SourceText.
std::pair<int, int> LineColumn(const std::string& text, std::size_t offset) {
  int line = 1;
  std::size_t start = 0;
  for (std::size_t i = 0; i < offset; ++i) {
    if (text[i] == '\n' || (text[i] == '\r' && (i + 1 >= text.size() || text[i + 1] != '\n'))) {
      ++line;
      start = i + 1;
    }
  }
  return {line, static_cast<int>(offset - start) + 1};
}

// A program of /MN lines and /POS blocks, as the tests below need them.
std::string Program(const std::string& mn, const std::string& pos) {
  return "/PROG  TEST\n/ATTR\nOWNER\t\t= MNEDITOR;\nDEFAULT_GROUP\t= 1,*,*,*,*;\n/MN\n" + mn + "/POS\n" + pos +
         "/END\n";
}

std::string CartesianBlock(const std::string& name, const std::string& config,
                           const std::string& frames = "UF : 0, UT : 1") {
  return name + "{\n   GP1:\n\t" + frames + ",\t\tCONFIG : '" + config +
         "',\n\tX =   100.000  mm,\tY =   -20.500  mm,\tZ =   300.250  mm,\n"
         "\tW =   180.000 deg,\tP =     0.000 deg,\tR =   -90.000 deg\n};\n";
}

std::string JointBlock(const std::string& name) {
  return name +
         "{\n   GP1:\n\tUF : 0, UT : 1,\n\tJ1=     1.000 deg,\tJ2=     2.000 deg,\tJ3=     3.000 deg,\n"
         "\tJ4=     4.000 deg,\tJ5=     5.000 deg,\tJ6=     6.000 deg\n};\n";
}

const ProgramTarget* Find(const ParsedProgram& program, const std::string& name, int file = 0) {
  for (const ProgramTarget& target : program.targets) {
    if (target.name == name && target.file == file) return &target;
  }
  return nullptr;
}

// What every result must satisfy: spans that read back as exactly the values, each target at its first span,
// targets in text order, motions pointing at targets, covering whole lines and their references.
void ExpectConsistent(const std::vector<ProgramFile>& files, const ParsedProgram& program) {
  for (std::size_t t = 0; t < program.targets.size(); ++t) {
    const ProgramTarget& target = program.targets[t];
    ASSERT_EQ(target.values.size(), target.spans.size());
    ASSERT_EQ(target.values.size(), target.kind == TargetKind::kCartesian ? 6u : target.values.size());
    ASSERT_FALSE(target.values.empty());
    const std::string& text = files[target.file].text;
    for (std::size_t k = 0; k < target.spans.size(); ++k) {
      const NumberSpan& span = target.spans[k];
      ASSERT_EQ(span.file, target.file);
      ASSERT_LE(span.offset + span.length, text.size());
      const std::string number_text = text.substr(span.offset, span.length);
      const std::optional<ScannedNumber> number = ScanNumber(number_text, 0);
      ASSERT_TRUE(number.has_value()) << number_text;
      EXPECT_EQ(number->length, number_text.size()) << number_text;
      EXPECT_EQ(number->value, target.values[k]);
      if (k > 0) {
        EXPECT_GT(span.offset, target.spans[k - 1].offset);
      }
    }
    const auto [line, column] = LineColumn(text, target.spans[0].offset);
    EXPECT_EQ(target.line, line);
    EXPECT_EQ(target.column, column);
    if (t > 0) {
      const ProgramTarget& before = program.targets[t - 1];
      EXPECT_TRUE(before.file < target.file ||
                  (before.file == target.file && before.spans[0].offset < target.spans[0].offset));
    }
    if (target.kind == TargetKind::kJoint) {
      EXPECT_TRUE(target.configuration.empty());
      EXPECT_TRUE(target.turns.empty());
      EXPECT_FALSE(target.configuration_applies);
      EXPECT_EQ(target.base, "");
    } else {
      EXPECT_TRUE(target.configuration_applies);
    }
  }
  std::vector<bool> moved(program.targets.size(), false);
  for (const MotionStatement& motion : program.motions) {
    ASSERT_GE(motion.target, 0);
    ASSERT_LT(motion.target, static_cast<int>(program.targets.size()));
    const std::string& text = files[motion.file].text;
    ASSERT_LE(motion.begin, motion.reference_begin);
    ASSERT_LT(motion.reference_begin, motion.reference_end);
    ASSERT_LE(motion.reference_end, motion.end);
    ASSERT_LE(motion.end, text.size());
    EXPECT_TRUE(motion.begin == 0 || text[motion.begin - 1] == '\n' || text[motion.begin - 1] == '\r');
    EXPECT_TRUE(motion.end == text.size() || text[motion.end] == '\n' || text[motion.end] == '\r');
    EXPECT_EQ(LineColumn(text, motion.begin).first, motion.line);
    const std::string reference = text.substr(motion.reference_begin, motion.reference_end - motion.reference_begin);
    // "P[3]" is written "P[3]", "P[ 3 ]" or with its comment, "P[3:approach]".
    std::string written;
    for (char c : reference.substr(0, reference.find(':'))) {
      if (c != ' ' && c != '\t') written += c;
    }
    if (written.back() != ']') written += ']';
    EXPECT_EQ(written, *program.targets[motion.target].name) << reference;
    EXPECT_EQ(reference.back(), ']');
    if (!moved[motion.target]) {
      EXPECT_EQ(program.targets[motion.target].motion, motion.motion);
    }
    moved[motion.target] = true;
  }
  for (std::size_t t = 0; t < moved.size(); ++t) {
    if (!moved[t]) {
      EXPECT_EQ(program.targets[t].motion, Motion::kNone) << *program.targets[t].name;
    }
  }
}

void ExpectProgramError(const std::string& text, int line, int column, const std::string& reason) {
  try {
    Read(text, "bad.ls");
    ADD_FAILURE() << "no error for:\n" << text;
  } catch (const ProgramError& e) {
    EXPECT_EQ(e.file(), "bad.ls");
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_EQ(e.column(), column) << e.what();
    EXPECT_THAT(e.reason(), HasSubstr(reason));
  }
}

TEST(FanucLsSyntaxTest, Row) {
  const DialectSyntax& row = FanucLsSyntax();
  EXPECT_EQ(row.dialect, Dialect::kFanucLs);
  EXPECT_STREQ(row.name, "fanuc-ls");
  EXPECT_THAT(row.extensions, ElementsAre(".ls"));
  EXPECT_EQ(row.rotation, RotationConvention::kXyzFixedDeg);
  EXPECT_EQ(row.mm_per_length_unit, 1.0);
  EXPECT_FALSE(row.joints_in_rad);
  EXPECT_NE(row.read, nullptr);
  EXPECT_EQ(row.inline_target, nullptr);
}

// ---- the samples ----

TEST(FanucLsSampleTest, WeldCellHasEveryTargetAndMotion) {
  const std::vector<ProgramFile> files = {{"weld_cell.ls", Sample("weld_cell.ls")}};
  const std::string& text = files[0].text;
  ASSERT_NE(text.find("\r\n"), std::string::npos);
  ASSERT_NE(text.find(";\n"), std::string::npos);  // the lines an editor left with LF
  const ParsedProgram program = FanucLsSyntax().read(files);
  ExpectConsistent(files, program);

  int joint = 0, cartesian = 0;
  for (const ProgramTarget& target : program.targets) {
    (target.kind == TargetKind::kJoint ? joint : cartesian) += 1;
  }
  EXPECT_EQ(joint, 21);      // P[1..20] and P[45]
  EXPECT_EQ(cartesian, 24);  // P[21..44]
  // 20 J, 22 L / C statements with 24 points, J P[1] and J P[2] again; PR[1] has no block, //L is commented out.
  EXPECT_EQ(program.motions.size(), 20u + 24u + 2u);

  const ProgramTarget* home = Find(program, "P[1]");
  ASSERT_NE(home, nullptr);
  EXPECT_EQ(home->kind, TargetKind::kJoint);
  EXPECT_THAT(home->values, ElementsAre(0.0, -20.0, 10.0, 0.0, -80.0, 0.0));
  EXPECT_EQ(home->tool, "1");
  EXPECT_EQ(home->motion, Motion::kJoint);
  const std::size_t home_j1 = text.find("J1=", text.find("P[1:\"home\"]{"));
  EXPECT_EQ(home->line, LineColumn(text, home_j1).first);

  const ProgramTarget* spare = Find(program, "P[45]");
  ASSERT_NE(spare, nullptr);
  EXPECT_EQ(spare->motion, Motion::kNone);

  // A Cartesian point in UF 3 with tool 2: frames as their numbers, the flags its CONFIG gives.
  const ProgramTarget* first_seam = Find(program, "P[21]");
  ASSERT_NE(first_seam, nullptr);
  EXPECT_EQ(first_seam->kind, TargetKind::kCartesian);
  EXPECT_EQ(first_seam->base, "3");
  EXPECT_EQ(first_seam->tool, "2");
  EXPECT_EQ(first_seam->motion, Motion::kLinear);
  EXPECT_EQ(first_seam->configuration, (ArmConfiguration{1, 1, 1}));  // 'F U T': shoulder, elbow, wrist
  const ProgramTarget* back = Find(program, "P[38]");
  ASSERT_NE(back, nullptr);
  EXPECT_EQ(back->configuration, (ArmConfiguration{-1, -1, -1}));  // 'N D B'
  EXPECT_EQ(back->base, "5");
  const ProgramTarget* turned = Find(program, "P[43]");
  ASSERT_NE(turned, nullptr);
  ASSERT_EQ(turned->turns.size(), 3u);  // 'N U T, -1, 0, 0': J4 one turn down
  EXPECT_EQ(turned->turns[0].joint, 3);
  EXPECT_NEAR(turned->turns[0].min, -540.0 * kDeg, 1e-12);
  EXPECT_NEAR(turned->turns[0].max, -180.0 * kDeg, 1e-12);
  EXPECT_EQ(turned->turns[2].joint, 5);
  EXPECT_NEAR(turned->turns[2].min, -180.0 * kDeg, 1e-12);

  // The circle P[27] -> P[28]: two entries of one statement spanning two lines, the via point first.
  const std::size_t circle = text.find("  34:C P[27]");
  ASSERT_NE(circle, std::string::npos);
  std::vector<const MotionStatement*> circle_motions;
  for (const MotionStatement& motion : program.motions) {
    if (motion.begin == circle) circle_motions.push_back(&motion);
  }
  ASSERT_EQ(circle_motions.size(), 2u);
  EXPECT_EQ(*program.targets[circle_motions[0]->target].name, "P[27]");
  EXPECT_EQ(*program.targets[circle_motions[1]->target].name, "P[28]");
  EXPECT_EQ(circle_motions[0]->motion, Motion::kCircular);
  const std::string statement = text.substr(circle, circle_motions[0]->end - circle);
  EXPECT_EQ(statement, "  34:C P[27]    \r\n    :  P[28] 300mm/sec CNT50    ;");
  EXPECT_EQ(text.substr(circle_motions[1]->reference_begin, 5), "P[28]");

  // A motion with the point's comment and an offset: the reference keeps the comment.
  const std::size_t seam_end = text.find("L P[41:seam end]");
  bool found = false;
  for (const MotionStatement& motion : program.motions) {
    if (motion.reference_begin == seam_end + 2) {
      found = true;
      EXPECT_EQ(motion.reference_end - motion.reference_begin, std::string("P[41:seam end]").size());
    }
  }
  EXPECT_TRUE(found);
}

TEST(FanucLsSampleTest, DeburrReadsRegistersArcsAndLeavesIncrementsOut) {
  const std::vector<ProgramFile> files = {{"deburr.ls", Sample("deburr.ls")}};
  const std::string& text = files[0].text;
  ASSERT_EQ(text.find('\r'), std::string::npos);
  const ParsedProgram program = FanucLsSyntax().read(files);
  ExpectConsistent(files, program);

  int joint = 0, cartesian = 0;
  for (const ProgramTarget& target : program.targets) {
    (target.kind == TargetKind::kJoint ? joint : cartesian) += 1;
  }
  EXPECT_EQ(joint, 23);      // PR[1] and P[1..22]
  EXPECT_EQ(cartesian, 21);  // P[23..42] and PR[2]; P[43] is an increment
  EXPECT_EQ(Find(program, "P[43]"), nullptr);

  const ProgramTarget* park = Find(program, "PR[1]");
  ASSERT_NE(park, nullptr);
  EXPECT_THAT(park->values, ElementsAre(-30.0, 0.0, 0.0, 0.0, -90.0, 0.0));
  EXPECT_EQ(park->motion, Motion::kJoint);
  EXPECT_EQ(park->tool, "4");
  const ProgramTarget* pounce = Find(program, "PR[2]");
  ASSERT_NE(pounce, nullptr);
  EXPECT_EQ(pounce->base, "");  // UF 0
  EXPECT_EQ(pounce->motion, Motion::kJoint);

  // The extended axis E1 and the second group's joints stay as written.
  const ProgramTarget* with_track = Find(program, "P[5]");
  ASSERT_NE(with_track, nullptr);
  EXPECT_EQ(with_track->values.size(), 6u);
  const ProgramTarget* with_group2 = Find(program, "P[9]");
  ASSERT_NE(with_group2, nullptr);
  EXPECT_EQ(with_group2->values.size(), 6u);
  const std::size_t gp2_joint = text.find("45.000 deg");
  for (const NumberSpan& span : with_group2->spans) EXPECT_LT(span.offset, gp2_joint);

  // Hand-written spacing: "X =613.46 mm" and "R = -73.65451 deg" read to the digit.
  const ProgramTarget* line_point = Find(program, "P[23]");
  ASSERT_NE(line_point, nullptr);
  EXPECT_EQ(line_point->base, "7");
  EXPECT_EQ(line_point->motion, Motion::kLinear);

  // A points: one circular entry each; a circle with its end on an indented line without ':'.
  for (const char* name : {"P[29]", "P[30]", "P[31]", "P[26]", "P[27]", "P[34]", "P[35]"}) {
    const ProgramTarget* target = Find(program, name);
    ASSERT_NE(target, nullptr) << name;
    EXPECT_EQ(target->motion, Motion::kCircular) << name;
  }
  const std::size_t circle = text.find("  31:C P[26] \n       P[27] 150mm/sec CNT100 ;");
  ASSERT_NE(circle, std::string::npos);
  int entries = 0;
  for (const MotionStatement& motion : program.motions) {
    if (motion.begin == circle) {
      ++entries;
      EXPECT_EQ(motion.end, circle + std::string("  31:C P[26] \n       P[27] 150mm/sec CNT100 ;").size());
    }
  }
  EXPECT_EQ(entries, 2);
  // PR[R[5]] is indirect: it names no block. The motions: 2 PR[1], 22 J, 18 L / A / C statements with 20
  // points, PR[2].
  EXPECT_EQ(program.motions.size(), 2u + 22u + 20u + 1u);
}

TEST(FanucLsSampleTest, TwoFilesKeepTheirOwnNumbers) {
  const std::vector<ProgramFile> files = {{"weld_cell.ls", Sample("weld_cell.ls")}, {"deburr.ls", Sample("deburr.ls")}};
  const ParsedProgram program = FanucLsSyntax().read(files);
  ExpectConsistent(files, program);
  EXPECT_EQ(program.targets.size(), 45u + 44u);
  EXPECT_EQ(program.motions.size(), 46u + 45u);
  const ProgramTarget* first = Find(program, "P[1]", 0);
  const ProgramTarget* second = Find(program, "P[1]", 1);
  ASSERT_NE(first, nullptr);
  ASSERT_NE(second, nullptr);
  EXPECT_NE(first->values, second->values);
  EXPECT_EQ(program.motions.back().file, 1);
  EXPECT_EQ(*program.targets[program.motions.back().target].name, "PR[1]");
}

// ---- the rules, one by one ----

TEST(FanucLsReaderTest, ConfigLettersAndTurnNumbers) {
  const std::string text = Program("   1:L P[1] 100mm/sec FINE    ;\n   2:L P[2] 100mm/sec FINE    ;\n",
                                   CartesianBlock("P[1]", "F D B, 1, -1, 2") + CartesianBlock("P[2]", "N U T"));
  const ParsedProgram program = Read(text);
  ExpectConsistent({{"test.ls", text}}, program);
  ASSERT_EQ(program.targets.size(), 2u);
  const ProgramTarget& first = program.targets[0];
  EXPECT_EQ(first.configuration.wrist, 1);      // F: J5 > 0, robocal's noflip
  EXPECT_EQ(first.configuration.elbow, -1);     // D
  EXPECT_EQ(first.configuration.shoulder, -1);  // B
  ASSERT_EQ(first.turns.size(), 3u);
  const double expected[3][3] = {{3, 180, 540}, {4, -540, -180}, {5, 540, 900}};
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(first.turns[i].joint, expected[i][0]);
    EXPECT_NEAR(first.turns[i].min, expected[i][1] * kDeg, 1e-12);
    EXPECT_NEAR(first.turns[i].max, expected[i][2] * kDeg, 1e-12);
  }
  EXPECT_THAT(first.values, ElementsAre(100.0, -20.5, 300.25, 180.0, 0.0, -90.0));
  const ProgramTarget& second = program.targets[1];
  EXPECT_EQ(second.configuration, (ArmConfiguration{1, 1, -1}));  // N U T: front, up, (FANUC's) no flip
  EXPECT_TRUE(second.turns.empty());
  EXPECT_EQ(second.tool, "1");
  EXPECT_EQ(second.base, "");
}

TEST(FanucLsReaderTest, FramesAreTheirNumbers) {
  const std::string text = Program("   1:J P[1] 100% FINE ;\n   2:J P[2] 100% FINE ;\n",
                                   CartesianBlock("P[1]", "N U T, 0, 0, 0", "UF : 12, UT : 0") +
                                       "P[2]{\n   GP1:\n\tUF : 4, UT : 3,\n\tJ1= 1 deg, J2= 2 deg, J3= 3 deg, J4= 4 "
                                       "deg, J5= 5 deg, J6= 6 deg\n};\n");
  const ParsedProgram program = Read(text);
  ASSERT_EQ(program.targets.size(), 2u);
  EXPECT_EQ(program.targets[0].base, "12");
  EXPECT_EQ(program.targets[0].tool, "0");
  // A joint position does not depend on the user frame; the tool still says where the TCP is.
  EXPECT_EQ(program.targets[1].base, "");
  EXPECT_EQ(program.targets[1].tool, "3");
}

TEST(FanucLsReaderTest, MotionLinesAndTheirSpans) {
  const std::string mn =
      "   1:  !J P[1] in a comment is no motion ;\n"
      "   2:  JMP LBL[1] ;\n"
      "   3:J P[1:\"a]b\"] 100% FINE    ;\n"
      "   4:L P[ 2 ] 500mm/sec CNT100 ; ! trailing comment\n"
      "   5:  //L P[1] 100mm/sec FINE ;\n"
      "   6:J PR[3] 100% FINE ;\n"
      "   7:L P[9] 100mm/sec FINE ;\n"
      "   8:C P[2] Tool_Offset,PR[4]\n"
      "    :  P[1] 100mm/sec FINE    ;\n";
  const std::string text = Program(mn, JointBlock("P[1]") + CartesianBlock("P[2]", "N U T, 0, 0, 0"));
  const std::vector<ProgramFile> files = {{"test.ls", text}};
  const ParsedProgram program = FanucLsSyntax().read(files);
  ExpectConsistent(files, program);
  ASSERT_EQ(program.motions.size(), 4u);  // PR[3] and P[9] have no block
  const MotionStatement& first = program.motions[0];
  EXPECT_EQ(text.substr(first.begin, first.end - first.begin), "   3:J P[1:\"a]b\"] 100% FINE    ;");
  EXPECT_EQ(text.substr(first.reference_begin, first.reference_end - first.reference_begin), "P[1:\"a]b\"]");
  EXPECT_EQ(first.line, 8);
  const MotionStatement& second = program.motions[1];
  EXPECT_EQ(text.substr(second.reference_begin, second.reference_end - second.reference_begin), "P[ 2 ]");
  EXPECT_EQ(second.motion, Motion::kLinear);
  EXPECT_EQ(text.substr(second.begin, second.end - second.begin),
            "   4:L P[ 2 ] 500mm/sec CNT100 ; ! trailing comment");
  EXPECT_EQ(program.motions[2].motion, Motion::kCircular);
  EXPECT_EQ(program.targets[program.motions[2].target].name, "P[2]");
  EXPECT_EQ(program.targets[program.motions[3].target].name, "P[1]");
  EXPECT_EQ(program.motions[2].begin, program.motions[3].begin);
  EXPECT_EQ(program.targets[0].motion, Motion::kJoint);  // P[1]: J first, the circle's end later
}

TEST(FanucLsReaderTest, IncrementalPointsAreNotTargets) {
  const std::string text = Program("   1:L P[1] 100mm/sec FINE INC ;\n   2:L P[2:INC] 100mm/sec FINE ;\n",
                                   CartesianBlock("P[1]", "N U T") + CartesianBlock("P[2]", "N U T"));
  const ParsedProgram program = Read(text);
  ASSERT_EQ(program.targets.size(), 1u);  // P[2]'s comment saying INC is no increment
  EXPECT_EQ(program.targets[0].name, "P[2]");
  ASSERT_EQ(program.motions.size(), 1u);
  EXPECT_EQ(program.motions[0].target, 0);
}

TEST(FanucLsReaderTest, NoSectionsNoTargets) {
  EXPECT_TRUE(Read("").targets.empty());
  EXPECT_TRUE(Read("/PROG X\n/MN\n   1:J P[1] 100% FINE ;\n").motions.empty());
  EXPECT_TRUE(Read("/PROG X\n/POS\n/END\n").targets.empty());
  EXPECT_TRUE(Read("/PROG X\n/POS").targets.empty());
  EXPECT_TRUE(Read("J P[1] 100% FINE ;\nP[1]{ GP1: X = 1 mm };").targets.empty());
}

TEST(FanucLsReaderTest, OnlyAnotherGroupIsNoTarget) {
  const std::string text = Program("   1:J P[1] 100% FINE ;\n",
                                   "P[1]{\n   GP2:\n\tUF : 0, UT : 1,\n\tJ1= 10.000 deg,\tJ2= 20.000 deg\n};\n");
  EXPECT_TRUE(Read(text).targets.empty());
}

// ---- errors: file, line and column of what cannot be read ----

TEST(FanucLsErrorTest, MalformedNumber) {
  const std::string text = Program("", "P[1]{\n   GP1:\n\tUF : 0, UT : 1,\n\tJ1= 1.2.3 deg, J2= 0 deg\n};\n");
  ExpectProgramError(text, 10, 6, "expected a number for J1");
}

TEST(FanucLsErrorTest, MissingComponent) {
  std::string block = CartesianBlock("P[7]", "N U T, 0, 0, 0");
  block.erase(block.find(",\tR ="), std::string(",\tR =   -90.000 deg").size());
  ExpectProgramError(Program("", block), 7, 1, "P[7] has no R");
}

TEST(FanucLsErrorTest, UnknownConfigLetter) {
  ExpectProgramError(Program("", CartesianBlock("P[1]", "N Q T, 0, 0, 0")), 9, 31, "unknown configuration letter");
}

TEST(FanucLsErrorTest, ConfigTurnNotInteger) {
  ExpectProgramError(Program("", CartesianBlock("P[1]", "N U T, 0, 0.5, 0")), 9, 39, "turn number");
  ExpectProgramError(Program("", CartesianBlock("P[1]", "N U T, 0, 0, 0, 0")), 9, 45, "more than three");
}

TEST(FanucLsErrorTest, MixedJointAndCartesian) {
  ExpectProgramError(Program("", "P[1]{\n   GP1:\n\tX = 1 mm, J1 = 2 deg\n};\n"), 9, 12, "mixes joint and Cartesian");
}

TEST(FanucLsErrorTest, JointGap) {
  ExpectProgramError(Program("", "P[1]{\n   GP1:\n\tJ1 = 1 deg, J3 = 2 deg\n};\n"), 7, 1, "J3 without J2");
}

TEST(FanucLsErrorTest, DuplicateBlock) {
  ExpectProgramError(Program("", JointBlock("P[1]") + JointBlock("P[1]")), 13, 1, "P[1] is defined twice");
}

TEST(FanucLsErrorTest, UnterminatedBlock) {
  ExpectProgramError("/POS\nP[2]{\n   GP1:\n\tJ1 = 1 deg,\n", 2, 1, "no closing");
}

TEST(FanucLsErrorTest, WrongUnit) {
  ExpectProgramError(Program("", "P[1]{\n   GP1:\n\tX = 1 deg\n};\n"), 9, 8, "expected mm for x");
}

TEST(FanucLsErrorTest, CircleWithoutEnd) {
  ExpectProgramError(Program("   1:C P[1] 100mm/sec FINE ;\n   2:J P[1] 100% FINE ;\n", JointBlock("P[1]")), 6, 8,
                     "no end point");
  ExpectProgramError(Program("   1:C P[1]\n    :  Arc Start[1] ;\n", JointBlock("P[1]")), 7, 8, "end point");
}

TEST(FanucLsErrorTest, GarbageInPos) {
  ExpectProgramError(Program("", "P[1]{\n   GP1:\n\tJ1 = 1 deg\n};\nhello\n"), 11, 1, "expected a position");
}

TEST(FanucLsErrorTest, ErrorNamesTheFileOfTwo) {
  const std::vector<ProgramFile> files = {{"a.ls", Program("", JointBlock("P[1]"))},
                                          {"b.ls", Program("", "P[1]{\n   GP1:\n\tJ1 = x\n};\n")}};
  try {
    FanucLsSyntax().read(files);
    ADD_FAILURE() << "no error";
  } catch (const ProgramError& e) {
    EXPECT_EQ(e.file(), "b.ls");
    EXPECT_EQ(e.line(), 9);
  }
}

// ---- robustness: whatever the bytes, a result or a ProgramError ----

void ReadAnything(const std::string& text) {
  try {
    const std::vector<ProgramFile> files = {{"fuzz.ls", text}};
    ExpectConsistent(files, FanucLsSyntax().read(files));
  } catch (const ProgramError& e) {
    EXPECT_EQ(e.file(), "fuzz.ls");
    EXPECT_GE(e.line(), 1);
    EXPECT_GE(e.column(), 1);
  }
}

TEST(FanucLsRobustnessTest, EveryPrefixOfTheSamples) {
  for (const char* name : {"weld_cell.ls", "deburr.ls"}) {
    const std::string text = Sample(name);
    for (std::size_t size = 0; size <= text.size(); size += 7) ReadAnything(text.substr(0, size));
  }
}

TEST(FanucLsRobustnessTest, MutatedAndRandomInput) {
  std::mt19937 random(37);
  const std::string sample = Sample("deburr.ls");
  const std::string alphabet = "PR[]{}:;,'\"=.-+0123456789 \t\r\nJXYZWNUTFDBGE/MNPOSmdeg!";
  for (int trial = 0; trial < 300; ++trial) {
    std::string text = sample;
    for (int m = 0; m < 5; ++m) {
      const std::size_t at = random() % text.size();
      text[at] = alphabet[random() % alphabet.size()];
    }
    ReadAnything(text);
  }
  for (int trial = 0; trial < 300; ++trial) {
    std::string text = "/MN\n";
    const int size = static_cast<int>(random() % 400);
    for (int i = 0; i < size; ++i) text += alphabet[random() % alphabet.size()];
    if (trial % 2) text.insert(text.size() / 2, "\n/POS\n");
    ReadAnything(text);
  }
}

// 10,000 targets in one program, every one read with its motion (the reading time is the benchmark's:
// tests/bench/program_bench.cc, never a test's).
TEST(FanucLsLargeProgramTest, TenThousandTargets) {
  std::string mn, pos;
  for (int i = 1; i <= 10000; ++i) {
    mn += std::to_string(i) + ":L P[" + std::to_string(i) + "] 100mm/sec CNT100 ;\n";
    pos += CartesianBlock("P[" + std::to_string(i) + "]", "N U T, 0, 0, 0");
  }
  const ParsedProgram program = Read(Program(mn, pos));
  EXPECT_EQ(program.targets.size(), 10000u);
  EXPECT_EQ(program.motions.size(), 10000u);
  EXPECT_EQ(*program.targets.back().name, "P[10000]");
}

}  // namespace
}  // namespace robocal::programs
