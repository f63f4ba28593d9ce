// The ABB RAPID reader (programs/src/rapid.cc) on robocal's own sample modules and on small programs written
// here: exact number spans, values, confdata mapped to flags and turns, motions with their statement and
// reference spans, tools and work objects, ConfJ / ConfL, errors with file, line and column, the inline target
// text, and robustness on damaged input.
#include <gtest/gtest.h>

#include <algorithm>
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

const DialectSyntax& RapidSyntax();

namespace {

constexpr double kQuadrant = std::numbers::pi / 2.0;

ProgramFile Sample(const std::string& name) {
  std::ifstream in(std::string(ROBOCAL_PROGRAM_SAMPLES) + "/rapid/" + name, std::ios::binary);
  EXPECT_TRUE(in.good()) << name;
  std::ostringstream text;
  text << in.rdbuf();
  return {name, text.str()};
}

std::vector<ProgramFile> Samples() { return {Sample("CellMain.mod"), Sample("Weld.mod")}; }

ParsedProgram Read(const std::vector<ProgramFile>& files) { return RapidSyntax().read(files); }

ParsedProgram ReadOne(const std::string& text, const std::string& name = "t.mod") { return Read({{name, text}}); }

const ProgramTarget* Named(const ParsedProgram& program, const std::string& name) {
  for (const ProgramTarget& target : program.targets) {
    if (target.name && *target.name == name) return &target;
  }
  return nullptr;
}

std::string_view SpanText(const std::vector<ProgramFile>& files, const NumberSpan& span) {
  return std::string_view(files[span.file].text).substr(span.offset, span.length);
}

std::string_view StatementText(const std::vector<ProgramFile>& files, const MotionStatement& m) {
  return std::string_view(files[m.file].text).substr(m.begin, m.end - m.begin);
}

std::string_view ReferenceText(const std::vector<ProgramFile>& files, const MotionStatement& m) {
  return std::string_view(files[m.file].text).substr(m.reference_begin, m.reference_end - m.reference_begin);
}

int MotionIndexOf(const ParsedProgram& program, const ProgramTarget* target) {
  for (std::size_t i = 0; i < program.motions.size(); ++i) {
    if (&program.targets[program.motions[i].target] == target) return static_cast<int>(i);
  }
  return -1;
}

// What every read must satisfy whatever the text: spans inside their file that read back as their values,
// the first span at the target's line and column, targets in file and offset order, motions naming targets
// with statement spans that hold their reference and end before a line end.
void ExpectConsistent(const std::vector<ProgramFile>& files, const ParsedProgram& program) {
  std::vector<SourceText> sources;
  for (std::size_t i = 0; i < files.size(); ++i) sources.emplace_back(files[i], static_cast<int>(i));
  std::pair<int, std::size_t> previous{-1, 0};
  for (const ProgramTarget& target : program.targets) {
    ASSERT_EQ(target.values.size(), target.kind == TargetKind::kJoint ? 6u : 7u);
    ASSERT_EQ(target.spans.size(), target.values.size());
    for (std::size_t i = 0; i < target.spans.size(); ++i) {
      const NumberSpan& span = target.spans[i];
      ASSERT_GE(span.file, 0);
      ASSERT_LT(span.file, static_cast<int>(files.size()));
      ASSERT_LE(span.offset + span.length, files[span.file].text.size());
      const auto number = ScanNumber(files[span.file].text, span.offset);
      ASSERT_TRUE(number.has_value());
      EXPECT_EQ(number->length, span.length);
      EXPECT_EQ(number->value, target.values[i]);
    }
    const NumberSpan& first = target.spans[0];
    EXPECT_EQ(target.file, first.file);
    EXPECT_EQ(target.line, sources[first.file].LineOf(first.offset));
    EXPECT_EQ(target.column, sources[first.file].ColumnOf(first.offset));
    const std::pair<int, std::size_t> here{first.file, first.offset};
    EXPECT_LT(previous, here) << "targets in file and offset order";
    previous = here;
    for (int flag : {target.configuration.shoulder, target.configuration.elbow, target.configuration.wrist}) {
      EXPECT_TRUE(flag >= -1 && flag <= 1);
    }
    for (const JointRange& range : target.turns) EXPECT_LT(range.min, range.max);
    if (target.kind == TargetKind::kJoint) {
      EXPECT_FALSE(target.configuration_applies);
      EXPECT_TRUE(target.turns.empty());
    }
  }
  for (const MotionStatement& m : program.motions) {
    ASSERT_GE(m.target, 0);
    ASSERT_LT(m.target, static_cast<int>(program.targets.size()));
    ASSERT_LE(m.begin, m.reference_begin);
    ASSERT_LT(m.reference_begin, m.reference_end);
    ASSERT_LE(m.reference_end, m.end);
    const std::string& text = files[m.file].text;
    ASSERT_LE(m.end, text.size());
    EXPECT_TRUE(m.begin == 0 || text[m.begin - 1] == '\n' || text[m.begin - 1] == '\r');
    EXPECT_TRUE(m.end == text.size() || text[m.end] == '\n' || text[m.end] == '\r');
    EXPECT_EQ(m.line, sources[m.file].LineOf(m.begin));
  }
}

TEST(RapidSyntaxTest, RowDescribesRapid) {
  const DialectSyntax& row = RapidSyntax();
  EXPECT_EQ(row.dialect, Dialect::kRapid);
  EXPECT_STREQ(row.name, "rapid");
  EXPECT_EQ(row.rotation, RotationConvention::kQuaternionWxyz);
  EXPECT_EQ(row.mm_per_length_unit, 1.0);
  EXPECT_FALSE(row.joints_in_rad);
  EXPECT_NE(std::find(row.extensions.begin(), row.extensions.end(), ".mod"), row.extensions.end());
  EXPECT_NE(std::find(row.extensions.begin(), row.extensions.end(), ".prg"), row.extensions.end());
  EXPECT_NE(row.read, nullptr);
  EXPECT_NE(row.inline_target, nullptr);
}

TEST(RapidSamplesTest, CountsEveryKindOfTarget) {
  const auto files = Samples();
  const ParsedProgram program = Read(files);
  int declared_cartesian = 0, declared_joint = 0, inline_cartesian = 0, inline_joint = 0;
  for (const ProgramTarget& t : program.targets) {
    const bool cartesian = t.kind == TargetKind::kCartesian;
    if (t.name) {
      (cartesian ? declared_cartesian : declared_joint)++;
    } else {
      (cartesian ? inline_cartesian : inline_joint)++;
      EXPECT_NE(t.motion, Motion::kNone) << "an inline target is in a motion";
    }
  }
  EXPECT_EQ(declared_cartesian, 26);
  EXPECT_EQ(declared_joint, 22);
  EXPECT_EQ(inline_cartesian, 22);
  EXPECT_EQ(inline_joint, 21);
  EXPECT_EQ(program.motions.size(), 88u);
  ExpectConsistent(files, program);
  // Neither the SearchL target without value, nor a routine's parameters, nor the text of a string are targets.
  EXPECT_EQ(Named(program, "pSearch"), nullptr);
  EXPECT_EQ(Named(program, "jCurrent"), nullptr);
  EXPECT_EQ(Named(program, "pts{1}"), nullptr);
}

TEST(RapidSamplesTest, DeclaredRobtargetValuesAndSpans) {
  const auto files = Samples();
  const ParsedProgram program = Read(files);
  const ProgramTarget* p10 = Named(program, "p10");
  ASSERT_NE(p10, nullptr);
  EXPECT_EQ(p10->kind, TargetKind::kCartesian);
  EXPECT_EQ(p10->values, (std::vector<double>{555.87, 643.86, 1062.91, -0.328014, 0.372044, 0.866026, -0.063160}));
  EXPECT_EQ(SpanText(files, p10->spans[0]), "555.87");
  EXPECT_EQ(SpanText(files, p10->spans[6]), "-0.063160");
  EXPECT_EQ(p10->file, 0);
  EXPECT_EQ(p10->line, 15);
  EXPECT_EQ(p10->column, 26);
  // The declaration over four lines: position on its first line, orientation on the next.
  const ProgramTarget* p50 = Named(program, "p50");
  ASSERT_NE(p50, nullptr);
  EXPECT_EQ(p50->line, 19);
  EXPECT_EQ(p50->column, 27);
  EXPECT_EQ(SpanText(files, p50->spans[2]), "1780.13");
  EXPECT_EQ(SpanText(files, p50->spans[3]), "0.617262");
  SourceText cell(files[0], 0);
  EXPECT_EQ(cell.LineOf(p50->spans[3].offset), 20);
  // Blanks and a tab between the words, a blank after every comma.
  const ProgramTarget* p80 = Named(program, "p80");
  ASSERT_NE(p80, nullptr);
  EXPECT_EQ(SpanText(files, p80->spans[1]), "1872.51");
  EXPECT_EQ(p80->values[1], 1872.51);
  // Quaternions of 5 and 7 decimals in the CRLF module.
  const ProgramTarget* wp1 = Named(program, "wp1");
  const ProgramTarget* wp2 = Named(program, "wp2");
  ASSERT_NE(wp1, nullptr);
  ASSERT_NE(wp2, nullptr);
  EXPECT_EQ(wp1->file, 1);
  EXPECT_EQ(SpanText(files, wp1->spans[3]), "-0.5011314");
  EXPECT_EQ(SpanText(files, wp2->spans[6]), "0.35547");
  EXPECT_EQ(wp1->line, 8);
}

TEST(RapidSamplesTest, ArraysAreNamedByTheirOneBasedIndexes) {
  const auto files = Samples();
  const ParsedProgram program = Read(files);
  const double path_xy[4][2] = {{400.91, -1351.11}, {1091.94, -1171.16}, {288.14, -465.64}, {727.35, -286.50}};
  for (int i = 1; i <= 4; ++i) {
    const ProgramTarget* p = Named(program, "pPath{" + std::to_string(i) + "}");
    ASSERT_NE(p, nullptr) << i;
    EXPECT_EQ(p->values[0], path_xy[i - 1][0]);
    EXPECT_EQ(p->values[1], path_xy[i - 1][1]);
  }
  EXPECT_EQ(Named(program, "pPath{5}"), nullptr);
  const ProgramTarget* g12 = Named(program, "wGrid{1,2}");
  const ProgramTarget* g21 = Named(program, "wGrid{2,1}");
  const ProgramTarget* g22 = Named(program, "wGrid{2,2}");
  ASSERT_NE(g12, nullptr);
  ASSERT_NE(g21, nullptr);
  ASSERT_NE(g22, nullptr);
  EXPECT_EQ((std::vector<double>{g12->values[0], g12->values[1]}), (std::vector<double>{-1346.55, 628.42}));
  EXPECT_EQ((std::vector<double>{g21->values[0], g21->values[1]}), (std::vector<double>{190.50, 1600.28}));
  EXPECT_EQ(g12->motion, Motion::kCircular);
  EXPECT_EQ(g21->motion, Motion::kLinear);
  EXPECT_EQ(g22->motion, Motion::kNone);
}

TEST(RapidSamplesTest, JointTargetsListTheRobotAxesOnly) {
  const auto files = Samples();
  const ParsedProgram program = Read(files);
  const ProgramTarget* home = Named(program, "jHome");
  ASSERT_NE(home, nullptr);
  EXPECT_EQ(home->kind, TargetKind::kJoint);
  EXPECT_EQ(home->values, (std::vector<double>{0, 0, 0, 0, 30, 0}));
  EXPECT_EQ(home->motion, Motion::kJoint);
  EXPECT_EQ(home->tool, "tool0");
  EXPECT_EQ(home->base, "");
  EXPECT_FALSE(home->configuration_applies);
  // The external axis value 1250.5 stays as written: not among the spans.
  const ProgramTarget* j5 = Named(program, "jPose5");
  ASSERT_NE(j5, nullptr);
  EXPECT_EQ(j5->spans.size(), 6u);
  EXPECT_EQ(SpanText(files, j5->spans[5]), "175.94");
  EXPECT_EQ(j5->tool, "tGripper");
  const ProgramTarget* j6 = Named(program, "jPose6");
  ASSERT_NE(j6, nullptr);
  EXPECT_EQ(j6->motion, Motion::kNone);
  EXPECT_EQ(j6->line, 47);
  const ProgramTarget* jw4 = Named(program, "jw4");
  ASSERT_NE(jw4, nullptr);
  EXPECT_EQ(jw4->values, (std::vector<double>{72.55, -39.57, 55.62, -46.13, -88.92, 10.32}));
  EXPECT_EQ(jw4->motion, Motion::kJoint);
  EXPECT_EQ(jw4->tool, "tTorch");
}

TEST(RapidSamplesTest, ConfdataMapsToFlagsAndQuadrants) {
  const auto files = Samples();
  const ParsedProgram program = Read(files);
  struct Case {
    const char* name;
    ArmConfiguration flags;
    int cf1, cf4, cf6;
  };
  // cfx: bit 2 behind axis 1, bit 1 behind the lower arm, bit 0 axis 5 negative. Behind axis 1 the elbow
  // flag is the lower-arm bit read from the other side of the arm plane.
  const Case cases[] = {
      {"p10", {1, 1, 1}, 0, 0, 0},       // cfx 0
      {"p30", {1, 1, -1}, -1, 0, -1},    // cfx 1
      {"p40", {1, -1, 1}, 0, 1, 0},      // cfx 2
      {"p100", {1, -1, -1}, 0, 0, 1},    // cfx 3
      {"p60", {-1, -1, 1}, 0, 0, -1},    // cfx 4
      {"p110", {-1, -1, -1}, 1, -1, 0},  // cfx 5
      {"wp4", {-1, 1, 1}, 0, 0, -1},     // cfx 6
      {"wp5", {-1, 1, -1}, -1, 0, 0},    // cfx 7
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const ProgramTarget* t = Named(program, c.name);
    ASSERT_NE(t, nullptr);
    EXPECT_EQ(t->configuration, c.flags) << t->configuration.ToString();
    ASSERT_EQ(t->turns.size(), 3u);
    const int joints[] = {0, 3, 5};
    const int quadrants[] = {c.cf1, c.cf4, c.cf6};
    for (int i = 0; i < 3; ++i) {
      EXPECT_EQ(t->turns[i].joint, joints[i]);
      EXPECT_DOUBLE_EQ(t->turns[i].min, quadrants[i] * kQuadrant);
      EXPECT_DOUBLE_EQ(t->turns[i].max, (quadrants[i] + 1) * kQuadrant);
    }
  }
}

TEST(RapidSamplesTest, MotionsInProgramOrderWithTheirSpans) {
  const auto files = Samples();
  const ParsedProgram program = Read(files);
  ASSERT_GE(program.motions.size(), 2u);
  const MotionStatement& first = program.motions[0];
  EXPECT_EQ(StatementText(files, first), "    MoveAbsJ jHome\\NoEOffs, v1000, fine, tool0;");
  EXPECT_EQ(ReferenceText(files, first), "jHome");
  EXPECT_EQ(first.motion, Motion::kJoint);
  EXPECT_EQ(first.line, 57);
  EXPECT_EQ(*program.targets[first.target].name, "jHome");
  const MotionStatement& second = program.motions[1];
  EXPECT_EQ(*program.targets[second.target].name, "p10");
  EXPECT_EQ(second.motion, Motion::kJoint);
  // Files in request order, statements in text order.
  for (std::size_t i = 1; i < program.motions.size(); ++i) {
    const MotionStatement& a = program.motions[i - 1];
    const MotionStatement& b = program.motions[i];
    EXPECT_TRUE(a.file < b.file || (a.file == b.file && a.reference_begin < b.reference_begin)) << i;
  }
}

TEST(RapidSamplesTest, CircleIsTwoEntriesViaPointFirst) {
  const auto files = Samples();
  const ParsedProgram program = Read(files);
  const ProgramTarget* p50 = Named(program, "p50");
  const ProgramTarget* p60 = Named(program, "p60");
  const int via = MotionIndexOf(program, p50);
  ASSERT_GE(via, 0);
  const MotionStatement& a = program.motions[via];
  const MotionStatement& b = program.motions[via + 1];
  EXPECT_EQ(&program.targets[b.target], p60);
  EXPECT_EQ(a.motion, Motion::kCircular);
  EXPECT_EQ(b.motion, Motion::kCircular);
  EXPECT_EQ(a.begin, b.begin);
  EXPECT_EQ(a.end, b.end);
  EXPECT_EQ(ReferenceText(files, a), "p50");
  EXPECT_EQ(ReferenceText(files, b), "p60");
  EXPECT_EQ(p50->motion, Motion::kCircular);
  EXPECT_EQ(p60->base, "wFixture");
}

TEST(RapidSamplesTest, ToolsAndWorkObjects) {
  const auto files = Samples();
  const ParsedProgram program = Read(files);
  struct Case {
    const char* name;
    Motion motion;
    const char* tool;
    const char* base;
  };
  const Case cases[] = {
      {"p10", Motion::kJoint, "tGripper", ""},
      {"p20", Motion::kLinear, "tGripper", "wFixture"},  // also moved to from Weld.mod, later
      {"p30", Motion::kLinear, "tGripper", "wFixture"},  // \Conc before the target
      {"p40", Motion::kLinear, "tGripper", "wFixture"},  // Offs(p40, ...) before it is no move to p40
      {"p70", Motion::kLinear, "tGripper", "wFixture"},  // MoveLDO
      {"p80", Motion::kLinear, "tGripper", "wFixture"},  // TriggL: the tool after the trigger data and zone
      {"p90", Motion::kJoint, "tGripper", ""},           // \WObj:=wobj0
      {"p100", Motion::kJoint, "tGripper", ""},          // after IF ... THEN
      {"p110", Motion::kJoint, "tGripper", ""},
      {"p120", Motion::kNone, "", ""},
      {"wp4", Motion::kLinear, "tTorch", "wobjRot"},  // MoveLSync
      {"wp5", Motion::kJoint, "tTorch", ""},          // MOVEJ in capitals
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const ProgramTarget* t = Named(program, c.name);
    ASSERT_NE(t, nullptr);
    EXPECT_EQ(t->motion, c.motion);
    EXPECT_EQ(t->tool, c.tool);
    EXPECT_EQ(t->base, c.base);
  }
  // pPath{i} (a computed index) is no move; pPath{1} and "pPath{ 2 }" are.
  const ProgramTarget* path2 = Named(program, "pPath{2}");
  ASSERT_NE(path2, nullptr);
  const int m = MotionIndexOf(program, path2);
  ASSERT_GE(m, 0);
  EXPECT_EQ(ReferenceText(files, program.motions[m]), "pPath{ 2 }");
  EXPECT_EQ(&program.targets[program.motions[m - 1].target], Named(program, "pPath{1}"));
  // The move to p20 from the other module is a motion of its own, in Weld.mod.
  int moves_to_p20 = 0;
  for (const MotionStatement& s : program.motions) {
    if (&program.targets[s.target] == Named(program, "p20")) {
      ++moves_to_p20;
      if (s.file == 1) {
        EXPECT_EQ(StatementText(files, s), "    MoveL p20, v50, fine, tTorch;   ! declared in CellMain");
      }
    }
  }
  EXPECT_EQ(moves_to_p20, 2);
}

TEST(RapidSamplesTest, ConfJAndConfLDecideWhetherFlagsApply) {
  const auto files = Samples();
  const ParsedProgram program = Read(files);
  EXPECT_FALSE(Named(program, "wp1")->configuration_applies);  // ConfJ\Off
  EXPECT_TRUE(Named(program, "wp2")->configuration_applies);   // ConfJ\On again
  EXPECT_TRUE(Named(program, "wp3")->configuration_applies);
  EXPECT_TRUE(Named(program, "p120")->configuration_applies);  // no motion: its own flags
  // PROC Place: linear moves under ConfL \Off, joint moves still monitored.
  int linear_off = 0, joint_on = 0;
  for (const MotionStatement& m : program.motions) {
    const ProgramTarget& t = program.targets[m.target];
    if (t.name || t.kind != TargetKind::kCartesian || m.file != 0) continue;
    if (m.motion == Motion::kJoint) {
      EXPECT_TRUE(t.configuration_applies);
      ++joint_on;
    } else {
      EXPECT_FALSE(t.configuration_applies);
      ++linear_off;
    }
  }
  EXPECT_EQ(joint_on, 5);
  EXPECT_EQ(linear_off, 7);
}

TEST(RapidSamplesTest, InlineTargetsAreTheirOwnReference) {
  const auto files = Samples();
  const ParsedProgram program = Read(files);
  int inline_motions = 0;
  for (const MotionStatement& m : program.motions) {
    const ProgramTarget& t = program.targets[m.target];
    if (t.name) continue;
    ++inline_motions;
    const std::string_view reference = ReferenceText(files, m);
    EXPECT_EQ(reference.substr(0, 2), "[[");
    EXPECT_EQ(reference.back(), ']');
    EXPECT_GE(t.spans.front().offset, m.reference_begin);
    EXPECT_LE(t.spans.back().offset + t.spans.back().length, m.reference_end);
  }
  EXPECT_EQ(inline_motions, 43);
  // "ToPoint:=[...]": the reference is the literal, not the argument's name.
  const ProgramTarget* last_inline = nullptr;
  for (const ProgramTarget& t : program.targets) {
    if (!t.name && t.kind == TargetKind::kCartesian) last_inline = &t;
  }
  ASSERT_NE(last_inline, nullptr);
  EXPECT_EQ(last_inline->values[0], -942.3);
  EXPECT_EQ(last_inline->tool, "tTorch");
  EXPECT_EQ(last_inline->base, "wTable");
  const MotionStatement& m = program.motions[MotionIndexOf(program, last_inline)];
  EXPECT_EQ(std::string_view(files[1].text).substr(m.reference_begin - 9, 9), "ToPoint:=");
  // The statement over two lines (CRLF): from its first line to the end of the second, no line end.
  const ProgramTarget* split = nullptr;
  for (const ProgramTarget& t : program.targets) {
    if (!t.name && t.file == 1 && t.kind == TargetKind::kJoint && t.values[0] == 107.048) split = &t;
  }
  ASSERT_NE(split, nullptr);
  const MotionStatement& s = program.motions[MotionIndexOf(program, split)];
  const std::string_view statement = StatementText(files, s);
  EXPECT_EQ(statement.substr(0, 13), "    MoveAbsJ ");
  const std::string_view tail = "]]\r\n      \\NoEOffs, v1000, z50, tTorch;";
  ASSERT_GT(statement.size(), tail.size());
  EXPECT_EQ(statement.substr(statement.size() - tail.size()), tail);
  EXPECT_EQ(files[1].text.substr(s.end, 2), "\r\n");
}

// --- small programs -------------------------------------------------------------------------------------------

constexpr const char* kEax = "[9E9,9E9,9E9,9E9,9E9,9E9]";

TEST(RapidReaderTest, ReadsOneDeclarationExactly) {
  const std::string text = std::string("MODULE M\n  CONST robtarget p1 := [ [ +1.5 , -2 , .25 ] , [1,0,0,0], ") +
                           "[-2,1,-1,5], " + kEax + " ] ;\nENDMODULE\n";
  const ParsedProgram program = ReadOne(text);
  ASSERT_EQ(program.targets.size(), 1u);
  const ProgramTarget& t = program.targets[0];
  EXPECT_EQ(t.values, (std::vector<double>{1.5, -2, 0.25, 1, 0, 0, 0}));
  EXPECT_EQ(text.substr(t.spans[0].offset, t.spans[0].length), "+1.5");
  EXPECT_EQ(text.substr(t.spans[2].offset, t.spans[2].length), ".25");
  EXPECT_EQ(t.line, 2);
  EXPECT_EQ(t.column, 29);
  EXPECT_EQ(t.configuration, (ArmConfiguration{-1, -1, -1}));
  ASSERT_EQ(t.turns.size(), 3u);
  EXPECT_DOUBLE_EQ(t.turns[0].min, -std::numbers::pi);
  EXPECT_DOUBLE_EQ(t.turns[0].max, -kQuadrant);
  EXPECT_EQ(t.motion, Motion::kNone);
  EXPECT_TRUE(program.motions.empty());
}

TEST(RapidReaderTest, CfxOutsideTheSerialRobotTableLeavesFlagsFree) {
  const ParsedProgram program = ReadOne(std::string("VAR robtarget p:=[[1,2,3],[1,0,0,0],[0,0,0,9],") + kEax + "];");
  ASSERT_EQ(program.targets.size(), 1u);
  EXPECT_TRUE(program.targets[0].configuration.empty());
  EXPECT_EQ(program.targets[0].turns.size(), 3u);
}

TEST(RapidReaderTest, CommentsStringsAndOtherDataAreSkipped) {
  const std::string text = std::string(
      "MODULE M\n"
      "  ! CONST robtarget c1 := [[1,2,3],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n"
      "  CONST string s := \"MoveL p, v1, z1, t; \"\" ! still a string\";\n"
      "  PERS num n := 3;\n"
      "  VAR robtarget p0;\n"
      "  VAR robtarget p1 := p0;\n"
      "  VAR robtarget p2 := Offs(p0, 0, 0, 10);\n"
      "  PROC r(VAR robtarget a, PERS jointtarget b{*})\n"
      "    p0.trans.x := 5;\n"
      "    MoveL p1, v100, z1, tool0; ! p1 has no literal value\n"
      "  ENDPROC\n"
      "ENDMODULE\n");
  const ParsedProgram program = ReadOne(text);
  EXPECT_TRUE(program.targets.empty());
  EXPECT_TRUE(program.motions.empty());
}

TEST(RapidReaderTest, UnbalancedStatementEndsAtItsSemicolon) {
  // A typo in one statement must not hide the targets after it.
  const std::string text = std::string("MoveL Offs(p1, 0, 0, 10, v100, z1, tool0;\nMoveL [[1,2,3],[1,0,0,0],") +
                           "[0,0,0,0]," + kEax + "], v1, z1, tool0;\n";
  const ParsedProgram program = ReadOne(text);
  ASSERT_EQ(program.targets.size(), 1u);
  ASSERT_EQ(program.motions.size(), 1u);
  EXPECT_EQ(program.motions[0].line, 2);
  EXPECT_EQ(program.targets[0].line, 2);
}

TEST(RapidReaderTest, NamesAreCaseInsensitiveAndResolvedAcrossFiles) {
  const std::vector<ProgramFile> files = {
      {"A.mod", "MODULE A\n  PROC go()\n    movel PHOME, v100, fine, tool1\\WObj:=WOBJ0;\n  ENDPROC\nENDMODULE\n"},
      {"B.prg",
       std::string("MODULE B\n  PERS robtarget pHome := [[1,2,3],[1,0,0,0],[0,0,0,0],") + kEax + "];\nENDMODULE\n"},
  };
  const ParsedProgram program = Read(files);
  ASSERT_EQ(program.targets.size(), 1u);
  ASSERT_EQ(program.motions.size(), 1u);
  EXPECT_EQ(program.motions[0].file, 0);
  EXPECT_EQ(program.motions[0].line, 3);
  EXPECT_EQ(program.targets[0].file, 1);
  EXPECT_EQ(program.targets[0].motion, Motion::kLinear);
  EXPECT_EQ(program.targets[0].tool, "tool1");
  EXPECT_EQ(program.targets[0].base, "");
  EXPECT_EQ(ReferenceText(files, program.motions[0]), "PHOME");
}

TEST(RapidReaderTest, SameFileDeclarationHidesAnotherModulesOne) {
  const std::string decl = std::string(" robtarget p := [[1,2,3],[1,0,0,0],[0,0,0,0],") + kEax + "];\n";
  const std::vector<ProgramFile> files = {
      {"A.mod", "MODULE A\n  PERS" + decl + "ENDMODULE\n"},
      {"B.mod",
       "MODULE B\n  LOCAL CONST" + decl + "  PROC go()\n    MoveJ p, v100, z1, tool0;\n  ENDPROC\nENDMODULE\n"},
  };
  const ParsedProgram program = Read(files);
  ASSERT_EQ(program.targets.size(), 2u);
  ASSERT_EQ(program.motions.size(), 1u);
  EXPECT_EQ(program.motions[0].target, 1);
  EXPECT_EQ(program.targets[0].motion, Motion::kNone);
}

TEST(RapidReaderTest, KindOfTheInstructionDecidesTheTarget) {
  // MoveAbsJ to a robtarget's name or MoveJ to a jointtarget's is no move to a target robocal knows.
  const std::string text = std::string("CONST robtarget p := [[1,2,3],[1,0,0,0],[0,0,0,0],") + kEax +
                           "];\nCONST jointtarget j := [[1,2,3,4,5,6]," + kEax +
                           "];\nMoveAbsJ p, v1, z1, tool0;\nMoveJ j, v1, z1, tool0;\nMoveJ p, v1, z1, tool0;\n";
  const ParsedProgram program = ReadOne(text);
  ASSERT_EQ(program.targets.size(), 2u);
  ASSERT_EQ(program.motions.size(), 1u);
  EXPECT_EQ(program.motions[0].target, 0);
  EXPECT_EQ(program.motions[0].line, 5);
  EXPECT_EQ(program.targets[1].motion, Motion::kNone);
}

TEST(RapidReaderTest, MultiLineStatementSpanAndLoneCarriageReturns) {
  const std::string text = std::string("PROC p()\r  MoveL\r    [[1,2,3],[1,0,0,0],[0,0,0,0],") + kEax +
                           "],\r    v100, z1, tool0;\r  MoveL p9, v1, z1, tool0;\rENDPROC\r";
  const ParsedProgram program = ReadOne(text);
  ASSERT_EQ(program.motions.size(), 1u);
  const MotionStatement& m = program.motions[0];
  EXPECT_EQ(m.line, 2);
  EXPECT_EQ(text.substr(m.begin, m.end - m.begin),
            std::string("  MoveL\r    [[1,2,3],[1,0,0,0],[0,0,0,0],") + kEax + "],\r    v100, z1, tool0;");
  EXPECT_EQ(program.targets[0].line, 3);
  EXPECT_EQ(program.targets[0].column, 7);
}

struct BadCase {
  const char* text;
  int line;
  int column;
  const char* reason_part;
};

TEST(RapidReaderTest, MalformedTargetsNameFileLineAndColumn) {
  const BadCase cases[] = {
      {"MODULE M\n  CONST robtarget p := [[1,2,x],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n", 2, 30,
       "expected a number"},
      {"CONST robtarget p := [[1,2,3],[1,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];", 1, 37, "has 3 values"},
      {"CONST robtarget p := [[1,2,3,4],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];", 1, 29, "more than 3"},
      {"CONST robtarget p := [[1,2,3],[1,0,0,0],[0,0.5,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];", 1, 44, "integer"},
      {"CONST robtarget p := [[1,2,3],[1,0,0,0],[0,0,0,0]];", 1, 50, "expected ','"},
      {"CONST robtarget p := [[1,2,3],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]\nVAR num n;", 2, 1,
       "expected ';'"},
      {"VAR jointtarget j := [[1,2,3,4,5,6],[9E9,9E9]];", 1, 45, "has 2 values"},
      {"VAR jointtarget j{2} := [[[1,2,3,4,5,6],[9E9,9E9,9E9,9E9,9E9,9E9]]];", 1, 67, "array has 1 elements"},
      {"VAR robtarget p{0};", 1, 17, "array dimension"},
      {"PERS robtarget := [[1,2,3]];", 1, 16, "name"},
      {"CONST robtarget p = [[1,2,3]];", 1, 19, "':='"},
      {"PROC a()\n\tMoveL [[1,2,3],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9],v100, z1, tool0;\n", 2, 62,
       "expected ']'"},
      {"PROC a()\n  MoveL [[1,2,3],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]] + x, v1, z1, t;\n", 2, 64,
       "unexpected text"},
      {"MoveAbsJ [[1,2,3,4,5,1e],[9E9,9E9,9E9,9E9,9E9,9E9]], v1, z1, t;", 1, 22, "expected a number"},
  };
  for (const BadCase& c : cases) {
    SCOPED_TRACE(c.text);
    try {
      ReadOne(c.text, "Bad.mod");
      ADD_FAILURE() << "no error";
    } catch (const ProgramError& e) {
      EXPECT_EQ(e.file(), "Bad.mod");
      EXPECT_EQ(e.line(), c.line);
      EXPECT_EQ(e.column(), c.column);
      EXPECT_NE(e.reason().find(c.reason_part), std::string::npos) << e.reason();
    }
  }
}

TEST(RapidReaderTest, ConfdataBeyondIntRangeNamesTheRange) {
  const BadCase cases[] = {
      {"CONST robtarget p := [[1,2,3],[1,0,0,0],[0,0,0,99999999999],[9E9,9E9,9E9,9E9,9E9,9E9]];", 1, 48,
       "a confdata value must be an integer within +-2^31"},
      {"CONST robtarget p := [[1,2,3],[1,0,0,0],[2147483648,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];", 1, 42,
       "a confdata value must be an integer within +-2^31"},
      {"CONST robtarget p := [[1,2,3],[1,0,0,0],[0,-2147483649,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];", 1, 44,
       "within +-2^31"},
      {"PROC a()\n  MoveL [[1,2,3],[1,0,0,0],[0,0,1e300,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v1, z1, t;\n", 2, 33,
       "within +-2^31"},
  };
  for (const BadCase& c : cases) {
    SCOPED_TRACE(c.text);
    try {
      ReadOne(c.text, "Bad.mod");
      ADD_FAILURE() << "no error";
    } catch (const ProgramError& e) {
      EXPECT_EQ(e.file(), "Bad.mod");
      EXPECT_EQ(e.line(), c.line);
      EXPECT_EQ(e.column(), c.column);
      EXPECT_NE(e.reason().find(c.reason_part), std::string::npos) << e.reason();
    }
  }
  // The ends of the range are integers the reader takes.
  const ParsedProgram program =
      ReadOne(std::string("VAR robtarget p:=[[1,2,3],[1,0,0,0],[-2147483648,0,2147483647,0],") + kEax + "];");
  ASSERT_EQ(program.targets.size(), 1u);
  EXPECT_DOUBLE_EQ(program.targets[0].turns[0].min, -2147483648.0 * kQuadrant);
  EXPECT_DOUBLE_EQ(program.targets[0].turns[2].max, 2147483648.0 * kQuadrant);
}

// "CONST robtarget p{2} := [a, b];" then `body`, one module.
std::string WithArrayP(const std::string& body) {
  const std::string element = std::string("[[1,2,3],[1,0,0,0],[0,0,0,0],") + kEax + "]";
  return "MODULE M\n  CONST robtarget p{2} := [" + element + ", " + element + "];\n  PROC go()\n" + body +
         "  ENDPROC\nENDMODULE\n";
}

TEST(RapidReaderTest, ElementOutsideTheDeclaredArrayIsAnError) {
  const BadCase cases[] = {
      {"    MoveJ p{3}, v100, z1, tool0;\n", 4, 11, "p{3} is outside p{2}"},
      {"    MoveJ p{0}, v100, z1, tool0;\n", 4, 11, "p{0} is outside p{2}"},
      {"    MoveJ p{-1}, v100, z1, tool0;\n", 4, 11, "p{-1} is outside p{2}"},
      {"    MoveJ p{99999999999999999999}, v100, z1, tool0;\n", 4, 11, "p{99999999999999999999} is outside p{2}"},
      {"    MoveL P{ 3 }, v100, z1, tool0;\n", 4, 11, "P{3} is outside p{2}"},
      {"    MoveL p{1}, v100, z1, tool0;\n    MoveC p{2}, p{3}, v100, z1, tool0;\n", 5, 17, "p{3} is outside p{2}"},
      {"    MoveL \\Conc, ToPoint:=p{5}, v100, z1, tool0;\n", 4, 27, "p{5} is outside p{2}"},
      {"    MoveJ p, v100, z1, tool0;\n", 4, 11, "p is the array p{2}"},
      {"    MoveJ p{1,1}, v100, z1, tool0;\n", 4, 11, "p{1,1} has 2 index(es), p{2} has 1 dimension(s)"},
  };
  for (const BadCase& c : cases) {
    SCOPED_TRACE(c.text);
    try {
      ReadOne(WithArrayP(c.text), "Bad.mod");
      ADD_FAILURE() << "no error";
    } catch (const ProgramError& e) {
      EXPECT_EQ(e.file(), "Bad.mod");
      EXPECT_EQ(e.line(), c.line);
      EXPECT_EQ(e.column(), c.column);
      EXPECT_NE(e.reason().find(c.reason_part), std::string::npos) << e.reason();
    }
  }
}

TEST(RapidReaderTest, ArrayShapesOfOtherDeclarationsAndFiles) {
  const BadCase cases[] = {
      // Two dimensions.
      {"VAR robtarget g{2,2};\nMoveJ g{2,3}, v1, z1, t;", 2, 7, "g{2,3} is outside g{2,2}"},
      {"VAR robtarget g{2,2};\nMoveJ g{2}, v1, z1, t;", 2, 7, "g{2} has 1 index(es), g{2,2} has 2 dimension(s)"},
      // Declared without a value: still an array of that size.
      {"VAR robtarget s{3};\nMoveL s{4}, v1, z1, t;", 2, 7, "s{4} is outside s{3}"},
      // A scalar indexed.
      {"PERS robtarget q := [[1,2,3],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\nMoveL q{1}, v1, z1, t;", 2, 7,
       "q{1} indexes q, which is not an array"},
      {"CONST jointtarget j{1} := [[[1,2,3,4,5,6],[9E9,9E9,9E9,9E9,9E9,9E9]]];\nMoveAbsJ j{2}, v1, z1, t;", 2, 10,
       "j{2} is outside j{1}"},
  };
  for (const BadCase& c : cases) {
    SCOPED_TRACE(c.text);
    try {
      ReadOne(c.text, "Bad.mod");
      ADD_FAILURE() << "no error";
    } catch (const ProgramError& e) {
      EXPECT_EQ(e.file(), "Bad.mod");
      EXPECT_EQ(e.line(), c.line);
      EXPECT_EQ(e.column(), c.column);
      EXPECT_NE(e.reason().find(c.reason_part), std::string::npos) << e.reason();
    }
  }
  // Across modules: the error names the file of the motion.
  const std::string element = std::string("[[1,2,3],[1,0,0,0],[0,0,0,0],") + kEax + "]";
  try {
    Read({{"A.mod", "MODULE A\n  PROC go()\n    MoveL pPath{3}, v1, z1, t;\n  ENDPROC\nENDMODULE\n"},
          {"B.mod", "MODULE B\n  PERS robtarget pPath{2} := [" + element + "," + element + "];\nENDMODULE\n"}});
    ADD_FAILURE() << "no error";
  } catch (const ProgramError& e) {
    EXPECT_EQ(e.file(), "A.mod");
    EXPECT_EQ(e.line(), 3);
    EXPECT_EQ(e.column(), 11);
    EXPECT_EQ(e.reason(), "pPath{3} is outside pPath{2} (indexes run from 1)");
  }
}

TEST(RapidReaderTest, ElementsInsideTheArrayOrDeclaredElsewhereStayAsBefore) {
  const std::string text = WithArrayP(
      "    MoveJ p{1}, v100, z1, tool0;\n"
      "    MoveL p{02}, v100, z1, tool0;\n"  // RAPID reads 02 as 2
      "    MoveL p{ +1 }, v100, z1, tool0;\n"
      "    MoveL q{7}, v100, z1, tool0;\n"     // declared in no file of the request: another module's
      "    MoveAbsJ p{3}, v100, z1, tool0;\n"  // p is no jointtarget: not a target of this motion
      "    MoveL p{i}, v100, z1, tool0;\n");   // computed index: not read
  const std::vector<ProgramFile> files = {{"t.mod", text}};
  const ParsedProgram program = Read(files);
  ASSERT_EQ(program.targets.size(), 2u);
  ASSERT_EQ(program.motions.size(), 3u);
  EXPECT_EQ(program.motions[0].target, 0);
  EXPECT_EQ(program.motions[1].target, 1);
  EXPECT_EQ(program.motions[2].target, 0);
  EXPECT_EQ(ReferenceText(files, program.motions[1]), "p{02}");
  EXPECT_EQ(program.targets[1].motion, Motion::kLinear);
  ExpectConsistent(files, program);

  // A routine's array parameter of any size, with or without VAR / PERS, hides the module's p{2}; so does a
  // scalar parameter for a motion to `p`. An element of an array declared without a value moves to no target.
  const std::string params = WithArrayP(
      "  ENDPROC\n"
      "  PROC a(PERS robtarget p{*})\n    MoveJ p{3}, v100, z1, tool0;\n  ENDPROC\n"
      "  PROC b(robtarget p{*,*}, INOUT robtarget r)\n    MoveJ p{3,9}, v100, z1, tool0;\n  ENDPROC\n"
      "  PROC c(robtarget p)\n    MoveJ p, v100, z1, tool0;\n"
      "    VAR robtarget s{3};\n    MoveL s{3}, v1, z1, t;\n");
  const ParsedProgram with_params = ReadOne(params);
  EXPECT_EQ(with_params.targets.size(), 2u);
  EXPECT_TRUE(with_params.motions.empty());
}

// --- inline_target --------------------------------------------------------------------------------------------

TEST(RapidInlineTargetTest, CopiesConfdataAndExternalAxesOfTheDeclaration) {
  const auto files = Samples();
  const ParsedProgram program = Read(files);
  const ProgramTarget* p50 = Named(program, "p50");  // declared over four lines
  ASSERT_NE(p50, nullptr);
  const std::vector<double> values = {1000.25, -20.5, 300, 0.7071068, 0, 0.7071068, 0};
  const std::string literal = RapidSyntax().inline_target(*p50, files, values);
  EXPECT_EQ(literal,
            "[[1000.250,-20.500,300.000],[0.7071068,0.0000000,0.7071068,0.0000000],[1,0,0,0],"
            "[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]");
  // The text reads back as the same target in a motion statement.
  const std::string statement = "PROC p()\n  MoveL " + literal + ", v100, z1, tGripper;\nENDPROC\n";
  const ParsedProgram again = ReadOne(statement);
  ASSERT_EQ(again.targets.size(), 1u);
  for (int i = 0; i < 7; ++i) EXPECT_NEAR(again.targets[0].values[i], values[i], 1e-7);
  EXPECT_EQ(again.targets[0].configuration, p50->configuration);
  // A jointtarget has no inline Cartesian form.
  EXPECT_EQ(RapidSyntax().inline_target(*Named(program, "jHome"), files, values), "");
}

TEST(RapidInlineTargetTest, CopiesFromAnInlineLiteralWithExternalAxes) {
  const std::string text =
      "PROC p()\n  MoveL [[1,2,3],[1,0,0,0],[ -1 , 2,-3,  5 ],[ 120.5, 9E9,9E9,9E9,9E9,9E9 ]], v1, z1, t;\nENDPROC";
  const std::vector<ProgramFile> files = {{"x.mod", text}};
  const ParsedProgram program = Read(files);
  ASSERT_EQ(program.targets.size(), 1u);
  const std::string literal = RapidSyntax().inline_target(program.targets[0], files, {1, 2, 3, 1, 0, 0, 0});
  EXPECT_EQ(literal,
            "[[1.000,2.000,3.000],[1.0000000,0.0000000,0.0000000,0.0000000],[-1,2,-3,5],[120.5,9E9,9E9,9E9,9E9,9E9]]");
}

// --- robustness and size --------------------------------------------------------------------------------------

// Reads damaged text: a ProgramError or a consistent result, nothing else.
void ReadDamaged(const std::vector<ProgramFile>& files) {
  try {
    const ParsedProgram program = Read(files);
    ExpectConsistent(files, program);
  } catch (const ProgramError& e) {
    EXPECT_GE(e.line(), 1);
    EXPECT_GE(e.column(), 1);
  }
}

TEST(RapidRobustnessTest, EveryPrefixOfTheSamples) {
  const auto files = Samples();
  for (const ProgramFile& file : files) {
    for (std::size_t n = 0; n <= file.text.size(); n += 7) ReadDamaged({{file.name, file.text.substr(0, n)}});
  }
}

TEST(RapidRobustnessTest, RandomMutationsOfTheSamples) {
  const auto files = Samples();
  std::mt19937 random(37);
  const std::string alphabet = "[],;:=\\!\"{}()0123456789.eE+- \r\nMoveLJCAbsrobtargetjointPERS*";
  for (int round = 0; round < 400; ++round) {
    std::vector<ProgramFile> damaged = files;
    for (ProgramFile& file : damaged) {
      const int edits = 1 + static_cast<int>(random() % 8);
      for (int e = 0; e < edits && !file.text.empty(); ++e) {
        const std::size_t at = random() % file.text.size();
        switch (random() % 3) {
          case 0:
            file.text[at] = alphabet[random() % alphabet.size()];
            break;
          case 1:
            file.text.erase(at, 1 + random() % 20);
            break;
          default:
            file.text.insert(at, 1, static_cast<char>(random() % 256));
        }
      }
    }
    ReadDamaged(damaged);
  }
}

TEST(RapidRobustnessTest, RandomBytes) {
  std::mt19937 random(38);
  for (int round = 0; round < 300; ++round) {
    std::string text(random() % 400, '\0');
    for (char& c : text) c = static_cast<char>(random() % 256);
    ReadDamaged({{"r.mod", text}});
  }
  ReadDamaged({{"deep.mod", "CONST robtarget p{3,3,3} := " + std::string(100000, '[')}});
  ReadDamaged({{"open.mod", "MoveL " + std::string(100000, '(')}});
}

TEST(RapidLargeProgramTest, TenThousandTargetsReadWhole) {
  std::string text = "MODULE Big\n";
  for (int i = 0; i < 5000; ++i) {
    text += "  CONST robtarget p" + std::to_string(i) + ":=[[" + std::to_string(i) +
            ".125,-250.5,900.75],[0.7071068,0,0.7071068,0],[0,-1,1,1],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];\n";
  }
  text += "  PROC main()\n";
  for (int i = 0; i < 5000; ++i) {
    text += "    MoveL p" + std::to_string(i) + ", v1000, z10, tool1\\WObj:=wobj1;\n";
    text += "    MoveAbsJ [[" + std::to_string(i % 170) +
            ",10,20,30,40,50],[9E9,9E9,9E9,9E9,9E9,9E9]], v1000, z10, tool1;\n";
  }
  text += "  ENDPROC\nENDMODULE\n";
  const ParsedProgram program = ReadOne(text, "Big.mod");
  EXPECT_EQ(program.targets.size(), 10000u);
  EXPECT_EQ(program.motions.size(), 10000u);
}

}  // namespace
}  // namespace robocal::programs
