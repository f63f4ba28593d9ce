// The URScript reader on its own: robocal's two sample programs (a controller-generated one and a hand-written one
// with CRLF and LF line ends), and small programs for each rule of docs/programs.md (what is a target, which
// assignment a motion reads, the tool set_tcp sets, errors with file, line and column), the inserted target's
// text, robustness on mutated and random input, and a 10,000-target program read whole.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "robocal/programs/program.h"
#include "robocal/programs/text_scan.h"

namespace robocal::programs {
const DialectSyntax& UrscriptSyntax();

namespace {

using ::testing::ElementsAre;
using ::testing::ElementsAreArray;
using ::testing::HasSubstr;

ParsedProgram Read(const std::string& text, const std::string& name = "test.script") {
  return UrscriptSyntax().read({ProgramFile{name, text}});
}

std::string Sample(const std::string& name) {
  std::ifstream in(std::string(ROBOCAL_PROGRAM_SAMPLES) + "/urscript/" + name, std::ios::binary);
  EXPECT_TRUE(in.good()) << name;
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string SpanText(const std::vector<ProgramFile>& files, const NumberSpan& span) {
  return files[span.file].text.substr(span.offset, span.length);
}

// The properties every result must have, whatever the input: spans inside their file that read back as the
// values, targets in the order of their text, motions that point at targets and lie on whole lines.
void ExpectConsistent(const std::vector<ProgramFile>& files, const ParsedProgram& program) {
  for (std::size_t t = 0; t < program.targets.size(); ++t) {
    const ProgramTarget& target = program.targets[t];
    ASSERT_EQ(target.values.size(), 6u);
    ASSERT_EQ(target.spans.size(), 6u);
    for (std::size_t k = 0; k < 6; ++k) {
      const NumberSpan& span = target.spans[k];
      ASSERT_EQ(span.file, target.file);
      ASSERT_LE(span.offset + span.length, files[span.file].text.size());
      const std::string text = SpanText(files, span);
      const std::optional<ScannedNumber> number = ScanNumber(text, 0);
      ASSERT_TRUE(number.has_value()) << text;
      EXPECT_EQ(number->length, text.size()) << text;
      EXPECT_EQ(number->value, target.values[k]) << text;
      if (k > 0) {
        EXPECT_GT(span.offset, target.spans[k - 1].offset);
      }
    }
    const SourceText source(files[target.file], target.file);
    EXPECT_EQ(target.line, source.LineOf(target.spans[0].offset));
    EXPECT_EQ(target.column, source.ColumnOf(target.spans[0].offset));
    EXPECT_FALSE(target.configuration_applies);
    EXPECT_EQ(target.configuration, ArmConfiguration{});
    EXPECT_TRUE(target.turns.empty());
    EXPECT_EQ(target.base, "");
    if (t > 0) {
      const ProgramTarget& before = program.targets[t - 1];
      EXPECT_TRUE(before.file < target.file ||
                  (before.file == target.file && before.spans[0].offset < target.spans[0].offset));
    }
  }
  std::vector<Motion> first_motion(program.targets.size(), Motion::kNone);
  for (const MotionStatement& m : program.motions) {
    ASSERT_GE(m.target, 0);
    ASSERT_LT(m.target, static_cast<int>(program.targets.size()));
    const std::string& text = files[m.file].text;
    ASSERT_LE(m.begin, m.reference_begin);
    ASSERT_LT(m.reference_begin, m.reference_end);
    ASSERT_LE(m.reference_end, m.end);
    ASSERT_LE(m.end, text.size());
    EXPECT_TRUE(m.begin == 0 || text[m.begin - 1] == '\n' || text[m.begin - 1] == '\r');
    EXPECT_TRUE(m.end == text.size() || text[m.end] == '\n' || text[m.end] == '\r');
    const SourceText source(files[m.file], m.file);
    EXPECT_EQ(m.line, source.LineOf(m.begin));
    // The reference holds the target's numbers (inline) or is a variable's name (declared).
    const ProgramTarget& target = program.targets[m.target];
    const std::string reference = text.substr(m.reference_begin, m.reference_end - m.reference_begin);
    if (target.name) {
      EXPECT_EQ(reference, *target.name);
    } else {
      EXPECT_EQ(reference.substr(0, target.kind == TargetKind::kCartesian ? 2 : 1),
                target.kind == TargetKind::kCartesian ? "p[" : "[");
      EXPECT_EQ(reference.back(), ']');
      EXPECT_LT(m.reference_begin, target.spans[0].offset);
      EXPECT_GE(m.reference_end, target.spans[5].offset + target.spans[5].length);
    }
    if (first_motion[m.target] == Motion::kNone) first_motion[m.target] = m.motion;
  }
  for (std::size_t t = 0; t < program.targets.size(); ++t) {
    EXPECT_EQ(program.targets[t].motion, first_motion[t]) << t;
  }
}

// "joint declared", "cartesian inline", ...: the four kinds of target a dialect with both may have.
std::string KindOf(const ProgramTarget& t) {
  return std::string(t.kind == TargetKind::kJoint ? "joint" : "cartesian") + (t.name ? " declared" : " inline");
}

const ProgramTarget* Named(const ParsedProgram& program, const std::string& name) {
  for (const ProgramTarget& t : program.targets) {
    if (t.name == name) return &t;
  }
  return nullptr;
}

int MotionsTo(const ParsedProgram& program, int target) {
  return static_cast<int>(std::count_if(program.motions.begin(), program.motions.end(),
                                        [&](const MotionStatement& m) { return m.target == target; }));
}

int IndexOf(const ParsedProgram& program, const ProgramTarget* target) {
  return static_cast<int>(target - program.targets.data());
}

// Line numbers of a text, counted as editors do.
int LineOfText(const std::string& text, const std::string& needle) {
  const std::size_t at = text.find(needle);
  EXPECT_NE(at, std::string::npos) << needle;
  return SourceText(ProgramFile{"x", text}, 0).LineOf(at);
}

std::string ErrorOf(const std::string& text, int* line = nullptr, int* column = nullptr) {
  try {
    Read(text, "bad.script");
  } catch (const ProgramError& e) {
    EXPECT_EQ(e.file(), "bad.script");
    if (line) *line = e.line();
    if (column) *column = e.column();
    return e.reason();
  }
  ADD_FAILURE() << "no ProgramError for:\n" << text;
  return "";
}

TEST(UrscriptSyntax, Row) {
  const DialectSyntax& row = UrscriptSyntax();
  EXPECT_EQ(row.dialect, Dialect::kUrscript);
  EXPECT_STREQ(row.name, "urscript");
  EXPECT_THAT(row.extensions, ElementsAre(".script"));
  EXPECT_EQ(row.rotation, RotationConvention::kRotationVectorRad);
  EXPECT_EQ(row.mm_per_length_unit, 1000.0);
  EXPECT_TRUE(row.joints_in_rad);
  EXPECT_NE(row.read, nullptr);
  EXPECT_NE(row.inline_target, nullptr);
}

// ---------------------------------------------------------------------------------------------------------------
// The samples

TEST(UrscriptSamples, GeneratedProgram) {
  const std::vector<ProgramFile> files = {{"pick_and_place.script", Sample("pick_and_place.script")}};
  const std::string& text = files[0].text;
  const ParsedProgram program = UrscriptSyntax().read(files);
  ExpectConsistent(files, program);

  std::map<std::string, int> kinds;
  for (const ProgramTarget& t : program.targets) {
    kinds[KindOf(t)]++;
  }
  // 8 Station_k_q, 16 Waypoint_k_p and the circle's two poses, 6 joint lists and 4 poses written inline.
  EXPECT_EQ(kinds["joint declared"], 8);
  EXPECT_EQ(kinds["cartesian declared"], 18);
  EXPECT_EQ(kinds["joint inline"], 6);
  EXPECT_EQ(kinds["cartesian inline"], 4);

  // qnear lists, the payload's inertia and the gravity vector are lists of numbers, not targets.
  for (const ProgramTarget& t : program.targets) {
    ASSERT_TRUE(!t.name || t.name->find("_q") == std::string::npos || t.name->rfind("Station_", 0) == 0) << *t.name;
    EXPECT_NE(t.line, LineOfText(text, "set_target_payload"));
    EXPECT_NE(t.line, LineOfText(text, "set_tcp"));
  }

  // A MoveJ waypoint as the controller writes it: a joint motion to the pose, through get_inverse_kin.
  const ProgramTarget* w1 = Named(program, "Waypoint_1_p");
  ASSERT_NE(w1, nullptr);
  EXPECT_EQ(w1->kind, TargetKind::kCartesian);
  EXPECT_EQ(w1->motion, Motion::kJoint);
  EXPECT_EQ(w1->line, LineOfText(text, "global Waypoint_1_p="));
  EXPECT_EQ(w1->column, static_cast<int>(std::string("  global Waypoint_1_p=p[").size()) + 1);
  EXPECT_EQ(SpanText(files, w1->spans[0]), "-.419279104578");
  EXPECT_DOUBLE_EQ(w1->values[0], -0.419279104578);
  EXPECT_EQ(w1->tool, "p[0.0,0.0,0.15,0.0,0.0,0.0]");
  EXPECT_EQ(MotionsTo(program, IndexOf(program, w1)), 1);

  // MoveL waypoints; MoveP after the tool change has the new tool.
  const ProgramTarget* w7 = Named(program, "Waypoint_7_p");
  ASSERT_NE(w7, nullptr);
  EXPECT_EQ(w7->motion, Motion::kLinear);
  EXPECT_EQ(w7->tool, "p[0.0,0.0,0.15,0.0,0.0,0.0]");
  const ProgramTarget* w13 = Named(program, "Waypoint_13_p");
  ASSERT_NE(w13, nullptr);
  EXPECT_EQ(w13->motion, Motion::kLinear);
  EXPECT_EQ(w13->tool, "p[0.0,0.0,0.2,0.0,0.0,0.0]");

  const ProgramTarget* station = Named(program, "Station_1_q");
  ASSERT_NE(station, nullptr);
  EXPECT_EQ(station->kind, TargetKind::kJoint);
  EXPECT_EQ(station->motion, Motion::kJoint);
  EXPECT_THAT(station->values, ElementsAre(-0.4176, -1.9901, 1.6572, -1.7723, 1.8825, -0.2156999999999999));

  // The circle: two entries of one statement, the via point first.
  const ProgramTarget* via = Named(program, "Circle_via_p");
  const ProgramTarget* end = Named(program, "Circle_end_p");
  ASSERT_TRUE(via && end);
  EXPECT_EQ(via->motion, Motion::kCircular);
  EXPECT_EQ(end->motion, Motion::kCircular);
  int circular = 0;
  for (std::size_t k = 0; k < program.motions.size(); ++k) {
    if (program.motions[k].motion != Motion::kCircular) continue;
    ++circular;
    ASSERT_LT(k + 1, program.motions.size());
    EXPECT_EQ(program.motions[k].target, IndexOf(program, via));
    EXPECT_EQ(program.motions[k + 1].target, IndexOf(program, end));
    EXPECT_EQ(program.motions[k].begin, program.motions[k + 1].begin);
    EXPECT_EQ(program.motions[k].end, program.motions[k + 1].end);
    EXPECT_EQ(text.substr(program.motions[k].begin, program.motions[k].end - program.motions[k].begin),
              "  movec(Circle_via_p, Circle_end_p, a=1.2, v=0.25, r=0, mode=0)");
    break;
  }
  EXPECT_EQ(circular, 1);
  // 8 station moves, 6 MoveJ and 6 MoveL waypoints, 6 inline joints, 2 circle points, 4 MoveP, 4 inline poses.
  EXPECT_EQ(program.motions.size(), 8u + 6 + 6 + 6 + 2 + 4 + 4);
}

TEST(UrscriptSamples, HandWrittenProgramWithMixedLineEnds) {
  const std::vector<ProgramFile> files = {{"palletize.script", Sample("palletize.script")}};
  const std::string& text = files[0].text;
  ASSERT_NE(text.find("\r\n"), std::string::npos);
  bool bare_lf = false;  // a line ending in LF alone among the CRLF ones
  for (std::size_t k = 1; k < text.size(); ++k) bare_lf = bare_lf || (text[k] == '\n' && text[k - 1] != '\r');
  ASSERT_TRUE(bare_lf);
  const ParsedProgram program = UrscriptSyntax().read(files);
  ExpectConsistent(files, program);

  std::map<std::string, int> kinds;
  for (const ProgramTarget& t : program.targets) {
    kinds[KindOf(t)]++;
  }
  EXPECT_EQ(kinds["joint declared"], 14);      // home and q_station_1..13
  EXPECT_EQ(kinds["cartesian declared"], 10);  // pick_*, place_*, via_1, end_1, wp_scan
  EXPECT_EQ(kinds["joint inline"], 16);
  EXPECT_EQ(kinds["cartesian inline"], 18);  // 7 movel, 1 movep, 3 movec x 2, 3 movej, 1 get_inverse_kin

  EXPECT_EQ(Named(program, "tcp_gripper"), nullptr);  // set_tcp takes it: a tool
  EXPECT_EQ(Named(program, "q_unused"), nullptr);     // no motion uses it

  // home: assigned after the function that moves to it (the first assignment after the motion).
  const ProgramTarget* home = Named(program, "home");
  ASSERT_NE(home, nullptr);
  EXPECT_EQ(home->kind, TargetKind::kJoint);
  EXPECT_THAT(home->values, ElementsAre(0, -1.5708, 1.5708, -1.5708, -1.5708, 0));
  EXPECT_EQ(SpanText(files, home->spans[0]), "0");
  EXPECT_EQ(home->line, LineOfText(text, "global home"));
  EXPECT_EQ(home->column, static_cast<int>(std::string("\tglobal home   =   [").size()) + 1);
  EXPECT_EQ(MotionsTo(program, IndexOf(program, home)), 2);
  for (const MotionStatement& m : program.motions) {
    if (m.target == IndexOf(program, home)) {
      EXPECT_EQ(m.line, LineOfText(text, "movej(home"));
      break;
    }
  }

  // A joint list that a movel or movep moves to is a joint target of a straight move; keywords name targets.
  EXPECT_EQ(Named(program, "q_station_11")->motion, Motion::kLinear);
  EXPECT_EQ(Named(program, "q_station_12")->motion, Motion::kLinear);
  EXPECT_EQ(Named(program, "q_station_13")->motion, Motion::kJoint);
  EXPECT_EQ(Named(program, "pick_2")->motion, Motion::kLinear);

  // Tools: the variable's name, then the literal without blanks after the second set_tcp.
  EXPECT_EQ(Named(program, "pick_1")->tool, "tcp_gripper");
  EXPECT_EQ(Named(program, "place_1")->tool, "p[0,0,0.2,0,0,0]");
  EXPECT_EQ(Named(program, "q_station_1")->tool, "tcp_gripper");

  // wp_scan: its literal is moved to once; the loop moves to a pose computed from it.
  const ProgramTarget* scan = Named(program, "wp_scan");
  ASSERT_NE(scan, nullptr);
  EXPECT_EQ(MotionsTo(program, IndexOf(program, scan)), 1);

  // The movec whose end point is computed is not a motion the reader lists; via_1 is moved to once (its movec).
  EXPECT_EQ(MotionsTo(program, IndexOf(program, Named(program, "via_1"))), 1);

  // A pose given to movej: a joint motion to a Cartesian target.
  const std::size_t movej_pose = text.find("movej(p[");
  ASSERT_NE(movej_pose, std::string::npos);
  bool found = false;
  for (const ProgramTarget& t : program.targets) {
    if (t.spans[0].offset == movej_pose + 8) {
      found = true;
      EXPECT_EQ(t.kind, TargetKind::kCartesian);
      EXPECT_EQ(t.motion, Motion::kJoint);
      EXPECT_FALSE(t.name.has_value());
    }
  }
  EXPECT_TRUE(found);

  // The statement over three lines (one ending in LF, the others CRLF) is one span of whole lines.
  const std::size_t split = text.find("\tmovel(p[-0.195098");
  ASSERT_NE(split, std::string::npos);
  found = false;
  for (const MotionStatement& m : program.motions) {
    if (m.begin != split) continue;
    found = true;
    EXPECT_EQ(text.substr(m.begin, m.end - m.begin),
              "\tmovel(p[-0.195098, -0.236606, -0.032767,\n\t      -1.753270, 1.586992, 0.917351],\r\n\t      a=0.3, "
              "v=0.05)");
    EXPECT_EQ(text.substr(m.reference_begin, m.reference_end - m.reference_begin),
              "p[-0.195098, -0.236606, -0.032767,\n\t      -1.753270, 1.586992, 0.917351]");
    const ProgramTarget& t = program.targets[m.target];
    EXPECT_EQ(t.line, m.line);
    EXPECT_EQ(SourceText(files[0], 0).LineOf(t.spans[3].offset), m.line + 1);
    EXPECT_EQ(SpanText(files, t.spans[3]), "-1.753270");
  }
  EXPECT_TRUE(found);

  // Nothing in comments and strings, nothing computed: no target on those lines.
  for (const ProgramTarget& t : program.targets) {
    EXPECT_NE(t.line, LineOfText(text, "textmsg("));
    EXPECT_NE(t.line, LineOfText(text, "movel(p[x_off"));
    EXPECT_NE(t.line, LineOfText(text, "set_gravity([0.0, 0.0, 9.82])"));
    EXPECT_NE(t.line, LineOfText(text, "d2r(0)"));
    EXPECT_NE(t.line, LineOfText(text, "pose_trans(pick_1"));
  }
}

TEST(UrscriptSamples, EnoughTargetsOfEveryKind) {
  std::map<std::string, int> kinds;
  for (const char* name : {"pick_and_place.script", "palletize.script"}) {
    for (const ProgramTarget& t : Read(Sample(name), name).targets) {
      kinds[KindOf(t)]++;
    }
  }
  for (const char* kind : {"joint declared", "joint inline", "cartesian declared", "cartesian inline"}) {
    EXPECT_GE(kinds[kind], 20) << kind;
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Rules, on small programs

TEST(UrscriptRead, NumbersAsWritten) {
  const std::string text = "movel(p[-.5, 0.25,+1 , -0, 2e-1, -3.0E+0], a=1.2, v=0.25, r=0.05)\n";
  const ParsedProgram program = Read(text);
  ASSERT_EQ(program.targets.size(), 1u);
  const ProgramTarget& t = program.targets[0];
  EXPECT_EQ(t.kind, TargetKind::kCartesian);
  EXPECT_EQ(t.motion, Motion::kLinear);
  EXPECT_FALSE(t.name.has_value());
  EXPECT_THAT(t.values, ElementsAre(-0.5, 0.25, 1.0, 0.0, 0.2, -3.0));
  std::vector<std::string> written;
  for (const NumberSpan& s : t.spans) written.push_back(text.substr(s.offset, s.length));
  EXPECT_THAT(written, ElementsAre("-.5", "0.25", "+1", "-0", "2e-1", "-3.0E+0"));
  EXPECT_EQ(t.line, 1);
  EXPECT_EQ(t.column, 9);
  EXPECT_EQ(t.tool, "");
  ASSERT_EQ(program.motions.size(), 1u);
  EXPECT_EQ(program.motions[0].begin, 0u);
  EXPECT_EQ(program.motions[0].end, text.size() - 1);
  EXPECT_EQ(text.substr(program.motions[0].reference_begin,
                        program.motions[0].reference_end - program.motions[0].reference_begin),
            "p[-.5, 0.25,+1 , -0, 2e-1, -3.0E+0]");
}

TEST(UrscriptRead, JointListsAreTargetsOnlyWhereAMotionTakesThem) {
  const std::string text =
      "def main():\n"
      "  set_gravity([0.0, 0.0, 9.82])\n"
      "  global ready = [0, -1.57, 1.57, -1.57, -1.57, 0]\n"
      "  qnear_only = [0.1, -1.2, 1.3, -1.4, 1.5, 0.6]\n"
      "  movej(ready, a=1.4, v=1.05)\n"
      "  movej(get_inverse_kin(p[0.3, 0.1, 0.4, 0, 3.14, 0], qnear=qnear_only))\n"
      "  inertia = [0.01, 0.01, 0.02]   # other lengths, where no motion takes them\n"
      "  set_payload(1.2, [0, 0, 0.05], [0.01, 0.01, 0.02, 0, 0, 0, 0])\n"
      "  movej(get_inverse_kin(p[0.3, 0.1, 0.4, 0, 3.14, 0], qnear=[0, 0, 0, 0, 0, 0, 0]), a=1)\n"
      "end\n";
  const ParsedProgram program = Read(text);
  ASSERT_EQ(program.targets.size(), 3u);
  EXPECT_EQ(program.targets[2].line, 9);
  EXPECT_EQ(program.targets[0].name, "ready");
  EXPECT_EQ(program.targets[0].kind, TargetKind::kJoint);
  EXPECT_EQ(program.targets[0].line, 3);
  EXPECT_FALSE(program.targets[1].name.has_value());
  EXPECT_EQ(program.targets[1].kind, TargetKind::kCartesian);
  EXPECT_EQ(program.targets[1].motion, Motion::kJoint);
  EXPECT_EQ(program.targets[1].line, 6);
  ASSERT_EQ(program.motions.size(), 3u);
  EXPECT_EQ(program.motions[1].line, 6);
}

TEST(UrscriptRead, PosesAssignedAreTargetsEvenUnused) {
  const std::string text =
      "spare = p[0.1, 0.2, 0.3, 0, 0, 0]\n"
      "offset = pose_trans(spare, p[0, 0, 0.1, 0, 0, 0])\n"
      "movel(offset)\n";
  const ParsedProgram program = Read(text);
  ASSERT_EQ(program.targets.size(), 1u);
  EXPECT_EQ(program.targets[0].name, "spare");
  EXPECT_EQ(program.targets[0].motion, Motion::kNone);
  EXPECT_TRUE(program.motions.empty());
}

TEST(UrscriptRead, AMotionReadsTheLastAssignmentBeforeIt) {
  const std::string text =
      "wp = p[0.1, 0.2, 0.3, 0, 3.14, 0]\n"
      "movel(wp)\n"
      "wp = p[0.4, 0.5, 0.6, 0, 3.14, 0]\n"
      "movej(wp)\n"
      "movel(wp)\n"
      "wp = pose_add(wp, p[0, 0, 0.01, 0, 0, 0])\n"
      "movel(wp)\n";
  const ParsedProgram program = Read(text);
  ASSERT_EQ(program.targets.size(), 2u);
  EXPECT_EQ(program.targets[0].line, 1);
  EXPECT_EQ(program.targets[0].motion, Motion::kLinear);
  EXPECT_EQ(program.targets[1].line, 3);
  EXPECT_EQ(program.targets[1].motion, Motion::kJoint);
  ASSERT_EQ(program.motions.size(), 3u);
  EXPECT_EQ(program.motions[0].target, 0);
  EXPECT_EQ(program.motions[1].target, 1);
  EXPECT_EQ(program.motions[2].target, 1);
  EXPECT_EQ(program.motions[2].line, 5);
}

TEST(UrscriptRead, ComputedPosesAndExpressionsAreNotTargets) {
  const std::string text =
      "x = 0.4\n"
      "movel(p[x, 0, 0.3, 0, 3.14, 0])\n"
      "movel(pose_trans(base_pose, p[0, 0, 0.1, 0, 0, 0]))\n"
      "movel(p[0.1, 0.2, 0.3, 0, 3.14, 0] , a=1)  # this one is\n"
      "movej([d2r(10), 0, 0, 0, 0, 0])\n"
      "q = get_inverse_kin(p[0.1, 0.2, 0.3, 0, 3.14, 0])\n"
      "movej(q)\n"
      "w = p[0.1, 0.2, 0.3, 0, 3.14, 0] # a comment: still a literal\n"
      "v = p[0.1, 0.2, 0.3, 0, 3.14, 0] + 1\n"
      "textmsg(\"movel(p[0.1, 0.2, 0.3, 0, 3.14, 0])\")\n"
      "# movel(p[0.1, 0.2, 0.3, 0, 3.14, 0])\n";
  const ParsedProgram program = Read(text);
  ASSERT_EQ(program.targets.size(), 2u);
  EXPECT_EQ(program.targets[0].line, 4);
  EXPECT_EQ(program.targets[1].line, 8);
  EXPECT_EQ(program.targets[1].name, "w");
  EXPECT_EQ(program.motions.size(), 1u);
}

TEST(UrscriptRead, ToolsFromSetTcp) {
  const std::string text =
      "tcp_long = p[0, 0, 0.2, 0, 0, 0]\n"
      "movel(p[0.1, 0.2, 0.3, 0, 3.14, 0])\n"
      "set_tcp(tcp_long)\n"
      "movel(p[0.2, 0.2, 0.3, 0, 3.14, 0])\n"
      "set_tcp( p[0, 0,  # the long cups\n  0.1, 0, 0, 0] )\n"
      "late = p[0.3, 0.2, 0.3, 0, 3.14, 0]\n"
      "movej(late)\n"
      "movel(tcp_long)\n";
  const ParsedProgram program = Read(text);
  ASSERT_EQ(program.targets.size(), 3u);
  EXPECT_EQ(program.targets[0].tool, "");
  EXPECT_EQ(program.targets[1].tool, "tcp_long");
  EXPECT_EQ(program.targets[2].name, "late");
  EXPECT_EQ(program.targets[2].tool, "p[0,0,0.1,0,0,0]");
  EXPECT_EQ(program.motions.size(), 3u);  // moving to the tool's pose is not read
}

TEST(UrscriptRead, MovecKeywordsAndPartialMovec) {
  const std::string text =
      "movec(pose_to=p[0.4, 0.1, 0.3, 0, 3.14, 0], pose_via=[0.1, -1.2, 1.3, -1.4, -1.5, 0.6], r=0.01)\n"
      "movec(p[0.3, 0.3, 0.3, 0, 3.14, 0], computed_end)\n";
  const ParsedProgram program = Read(text);
  ASSERT_EQ(program.targets.size(), 3u);
  ASSERT_EQ(program.motions.size(), 2u);
  // The via point first, whatever the order of the keywords.
  EXPECT_EQ(program.targets[program.motions[0].target].kind, TargetKind::kJoint);
  EXPECT_EQ(program.targets[program.motions[1].target].kind, TargetKind::kCartesian);
  EXPECT_EQ(program.targets[0].motion, Motion::kCircular);
  EXPECT_EQ(program.targets[1].motion, Motion::kCircular);
  // A movec with a computed end: its via point is a target no listed motion moves to.
  EXPECT_EQ(program.targets[2].line, 2);
  EXPECT_EQ(program.targets[2].motion, Motion::kNone);
}

TEST(UrscriptRead, LoneCarriageReturnsAndTabs) {
  const std::string text = "def f():\r\tmovel(p[0.1,\t0.2, 0.3, 0, 3.14, 0])\r\tmovej([1,2,3,4,5,6])\rend";
  const std::vector<ProgramFile> files = {{"cr.script", text}};
  const ParsedProgram program = UrscriptSyntax().read(files);
  ExpectConsistent(files, program);
  ASSERT_EQ(program.targets.size(), 2u);
  EXPECT_EQ(program.targets[0].line, 2);
  EXPECT_EQ(program.targets[0].column, 10);
  EXPECT_EQ(program.targets[1].line, 3);
  EXPECT_EQ(program.targets[1].column, 9);
  EXPECT_EQ(text.substr(program.motions[1].begin, program.motions[1].end - program.motions[1].begin),
            "\tmovej([1,2,3,4,5,6])");
}

TEST(UrscriptRead, SeveralFilesInRequestOrder) {
  const std::vector<ProgramFile> files = {
      {"poses.script", "global a = p[0.1, 0.2, 0.3, 0, 3.14, 0]\nglobal q0 = [0, -1, 1, -1, -1, 0]\n"},
      {"main.script", "movej(q0)\nmovel(a)\nmovel(p[0.2, 0.2, 0.3, 0, 3.14, 0])\n"},
  };
  const ParsedProgram program = UrscriptSyntax().read(files);
  ExpectConsistent(files, program);
  ASSERT_EQ(program.targets.size(), 3u);
  EXPECT_EQ(program.targets[0].name, "a");
  EXPECT_EQ(program.targets[0].file, 0);
  EXPECT_EQ(program.targets[1].name, "q0");
  EXPECT_EQ(program.targets[2].file, 1);
  EXPECT_EQ(program.targets[2].spans[0].file, 1);
  ASSERT_EQ(program.motions.size(), 3u);
  EXPECT_EQ(program.motions[0].file, 1);
  EXPECT_EQ(program.motions[0].target, 1);

  try {
    UrscriptSyntax().read({files[0], {"broken.script", "\n\nmovel(p[0.1, 0.2, 0.3, 0, 3.14, 0.0.1])\n"}});
    ADD_FAILURE() << "no error";
  } catch (const ProgramError& e) {
    EXPECT_EQ(e.file(), "broken.script");
    EXPECT_EQ(e.line(), 3);
    EXPECT_EQ(e.column(), 33);
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Errors

TEST(UrscriptErrors, MalformedNumberInAPose) {
  int line = 0, column = 0;
  EXPECT_THAT(ErrorOf("def f():\n  wp = p[0.1.2, 0, 0.3, 0, 3.14, 0]\nend\n", &line, &column),
              HasSubstr("malformed number '0.1.2'"));
  EXPECT_EQ(line, 2);
  EXPECT_EQ(column, 10);
  EXPECT_THAT(ErrorOf("movel(p[0.1, 0.2, 0.3, 0, 3.14, 12abc])", &line, &column), HasSubstr("'12abc'"));
  EXPECT_EQ(line, 1);
  EXPECT_EQ(column, 33);
}

TEST(UrscriptErrors, MissingNumberAndDetachedSign) {
  int line = 0, column = 0;
  EXPECT_THAT(ErrorOf("movel(p[0.1, , 0.3, 0, 3.14, 0])", &line, &column), HasSubstr("missing"));
  EXPECT_EQ(column, 14);
  EXPECT_THAT(ErrorOf("x = 1\nmovel(p[0.1, 0.2, - 0.3, 0, 3.14, 0])", &line, &column), HasSubstr("'- 0.3'"));
  EXPECT_EQ(line, 2);
  EXPECT_EQ(column, 19);
}

TEST(UrscriptErrors, MalformedJointListOnlyWhereItIsATarget) {
  int line = 0, column = 0;
  // Not a target (no motion uses it): not the reader's business.
  EXPECT_NO_THROW(Read("gains = [1.2.3, 0, 0, 0, 0, 0]\n"));
  EXPECT_THAT(ErrorOf("home = [0, -1.57, 1.57, -1.57.0, -1.57, 0]\nmovej(home)\n", &line, &column),
              HasSubstr("joint list"));
  EXPECT_EQ(line, 1);
  EXPECT_EQ(column, 26);
}

TEST(UrscriptErrors, PoseOrJointListOfOtherThanSixValuesWhereATargetMustBe) {
  int line = 0, column = 0;
  EXPECT_EQ(ErrorOf("x = 1\n  movel(p[0.3, 0.2, 0.3, 0, 3.14], a=0.3)\n", &line, &column),
            "a pose p[...] has 6 values, this one 5");
  EXPECT_EQ(line, 2);
  EXPECT_EQ(column, 9);
  EXPECT_EQ(ErrorOf("movep(p[0.3, 0.2, 0.3, 0, 3.14, 0, 1])\n", &line, &column),
            "a pose p[...] has 6 values, this one 7");
  EXPECT_EQ(column, 7);
  EXPECT_EQ(ErrorOf("movej([1, 2, 3, 4, 5])   # five joints\n", &line, &column),
            "a joint list [...] has 6 values (a UR arm has 6 joints), this one 5");
  EXPECT_EQ(column, 7);
  EXPECT_THAT(ErrorOf("movej(q=[0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7], a=1)\n", &line, &column), HasSubstr("this one 7"));
  EXPECT_EQ(column, 9);
  EXPECT_THAT(ErrorOf("movel([], a=1)\n", &line, &column), HasSubstr("this one 0"));
  EXPECT_EQ(column, 7);
  // movec: either point; get_inverse_kin's pose.
  EXPECT_THAT(ErrorOf("movec(p[0.1, 0.2, 0.3, 0, 3.14, 0], p[0.1, 0.2, 0.3, 0, 3.14])\n", &line, &column),
              HasSubstr("this one 5"));
  EXPECT_EQ(column, 37);
  EXPECT_THAT(ErrorOf("movej(get_inverse_kin(p[0.3, 0.1, 0.4, 0, 3.14], qnear=home), a=1)\n", &line, &column),
              HasSubstr("a pose p[...] has 6 values, this one 5"));
  EXPECT_EQ(column, 23);
  // Through a variable a motion moves to: at the assignment.
  EXPECT_THAT(ErrorOf("home = [0, -1.57, 1.57, -1.57, -1.57]\nmovej(home)\n", &line, &column),
              HasSubstr("joint list [...] has 6 values"));
  EXPECT_EQ(line, 1);
  EXPECT_EQ(column, 8);
  // A pose assigned to a variable is a target even unused, so it must be one.
  EXPECT_THAT(ErrorOf("spare = p[0.1, 0.2, 0.3, 0, 0, 0, 0]\n", &line, &column), HasSubstr("this one 7"));
  EXPECT_EQ(column, 9);
  // Not targets: other lengths elsewhere, a list no motion uses, a tool, an expression.
  EXPECT_NO_THROW(Read("gravity = [0, 0, 9.82]\nset_gravity(gravity)\nset_gravity([0, 0, 9.82])\n"));
  EXPECT_NO_THROW(Read("tcp = p[0, 0, 0.1, 0, 0]\nset_tcp(tcp)\n"));
  EXPECT_NO_THROW(Read("x = 1\nmovel(p[x, 0, 0.3, 0, 3.14])\nmovej([d2r(10), 0, 0])\n"));
}

TEST(UrscriptErrors, JunkBetweenTheNumbers) {
  int line = 0, column = 0;
  EXPECT_EQ(ErrorOf(std::string("movel(p[0.4, 0.1,\0 0.5, 0, 3.14, 0])\n", 38), &line, &column),
            "unexpected byte 0x00 in the pose");
  EXPECT_EQ(line, 1);
  EXPECT_EQ(column, 18);
  EXPECT_EQ(ErrorOf("movej([0, -1.57, 1.57 @, -1.57, -1.57, 0])\n", &line, &column),
            "unexpected '@' in the joint list");
  EXPECT_EQ(column, 23);
  // Even beside a variable: the text is no URScript.
  EXPECT_THAT(ErrorOf("movel(p[x, 0.1, 0.5\x01, 0, 3.14, 0])\n", &line, &column), HasSubstr("byte 0x01"));
  EXPECT_EQ(column, 20);
  // Through a variable, and after the literal.
  EXPECT_THAT(ErrorOf("wp = p[0.4, 0.1, 0.5, 0, 3.14, $0]\nmovel(wp)\n", &line, &column), HasSubstr("'$'"));
  EXPECT_EQ(column, 32);
  EXPECT_EQ(ErrorOf("\nwp = p[0.4, 0.1, 0.5, 0, 3.14, 0] ;\nmovel(wp)\n", &line, &column),
            "unexpected ';' after the pose");
  EXPECT_EQ(line, 2);
  EXPECT_EQ(column, 35);
  // Elsewhere in the call's arguments.
  EXPECT_EQ(ErrorOf("movel(wp, a=1.2\x7f)\n", &line, &column), "unexpected byte 0x7F in movel's arguments");
  EXPECT_EQ(column, 16);
  // A ',' lost between two numbers.
  EXPECT_EQ(ErrorOf("movel(p[0.4 0.1, 0.5, 0, 3.14, 0])\n", &line, &column),
            "a ',' is missing between '0.4' and '0.1' in the pose");
  EXPECT_EQ(column, 13);
  // Not a target: junk in a list no motion uses, or in a comment or string.
  EXPECT_NO_THROW(Read("gains = [1, 2 @ 3]\nmovel(p[0.4, 0.1, 0.5, 0, 3.14, 0])  # @ \x01\ntextmsg(\"$;\")\n"));
}

TEST(UrscriptErrors, FirstErrorInTheText) {
  int line = 0;
  ErrorOf("movel(p[1, 2, 3, 4, 5, 6.6.])\nhome = [1, 2, 3, 4, 5, 6..]\nmovej(home)\n", &line);
  EXPECT_EQ(line, 1);
  ErrorOf("home = [1, 2, 3, 4, 5, 6..]\nmovel(p[1, 2, 3, 4, 5, 6.6.])\nmovej(home)\n", &line);
  EXPECT_EQ(line, 1);
}

TEST(UrscriptErrors, UnclosedCallsAndPoses) {
  EXPECT_THAT(ErrorOf("wp = p[0.1, 0.2, 0.3, 0, 3.14, 0)\n"), HasSubstr("not closed"));
  EXPECT_THAT(ErrorOf("movel(wp]\n"), HasSubstr("not closed"));
  int line = 0, column = 0;
  EXPECT_THAT(ErrorOf("movel(p[0.1, 0.2, 0.3, 0, 3.14, 0],\n a=1.2\n", &line, &column), HasSubstr("not closed"));
  EXPECT_EQ(line, 1);
  EXPECT_EQ(column, 6);
  EXPECT_THAT(ErrorOf("\n  wp = p[0.1, 0.2\n", &line, &column), HasSubstr("not closed"));
  EXPECT_EQ(line, 2);
  EXPECT_EQ(column, 8);
}

// ---------------------------------------------------------------------------------------------------------------
// The inserted target

TEST(UrscriptInline, PoseLiteralThatReadsBack) {
  ProgramTarget like;
  like.kind = TargetKind::kCartesian;
  const std::string text =
      UrscriptSyntax().inline_target(like, {}, {0.1, -0.25, 1.0 / 3.0, 0.0, 3.14159265358979, -1e-9});
  EXPECT_EQ(text, "p[0.100000, -0.250000, 0.333333, 0.000000, 3.141593, 0.000000]");
  const ParsedProgram program = Read("movel(" + text + ", a=1.2, v=0.25)\n");
  ASSERT_EQ(program.targets.size(), 1u);
  EXPECT_THAT(program.targets[0].values, ElementsAreArray({0.1, -0.25, 0.333333, 0.0, 3.141593, 0.0}));

  like.kind = TargetKind::kJoint;
  EXPECT_EQ(UrscriptSyntax().inline_target(like, {}, {1, 2, 3, 4, 5, 6}), "");
}

// ---------------------------------------------------------------------------------------------------------------
// Robustness and time

// Reads `text`: a result that is consistent, or a ProgramError that names the file and a place in it.
void ExpectReadOrError(const std::string& text) {
  const std::vector<ProgramFile> files = {{"fuzz.script", text}};
  try {
    const ParsedProgram program = UrscriptSyntax().read(files);
    ExpectConsistent(files, program);
  } catch (const ProgramError& e) {
    EXPECT_EQ(e.file(), "fuzz.script");
    EXPECT_GE(e.line(), 1);
    EXPECT_GE(e.column(), 1);
  }
}

TEST(UrscriptRobustness, MutatedSamplesAndRandomBytes) {
  std::mt19937_64 random(37);
  const std::string sample = Sample("palletize.script");
  const std::string alphabet = "p[](),.-+=0123456789e#\"\r\n \tmovejlc_";
  for (int round = 0; round < 300; ++round) {
    std::string text = sample;
    const int edits = 1 + static_cast<int>(random() % 8);
    for (int e = 0; e < edits && !text.empty(); ++e) {
      const std::size_t at = random() % text.size();
      switch (random() % 3) {
        case 0:
          text[at] = alphabet[random() % alphabet.size()];
          break;
        case 1:
          text.erase(at, 1 + random() % 20);
          break;
        default:
          text.insert(at, 1, alphabet[random() % alphabet.size()]);
      }
    }
    if (round % 10 == 0) text.resize(random() % (text.size() + 1));  // cut anywhere
    ExpectReadOrError(text);
  }
  for (int round = 0; round < 300; ++round) {
    std::string text(random() % 200, '\0');
    for (char& c : text) c = static_cast<char>(round % 2 ? random() % 256 : alphabet[random() % alphabet.size()]);
    ExpectReadOrError(text);
  }
  for (const std::string& text :
       {std::string(), std::string("p"), std::string("p["), std::string("movel("), std::string("movel(p[1,2"),
        std::string("movec("), std::string("x ="), std::string("x = ["), std::string("set_tcp("),
        std::string(10000, '('), std::string(10000, '['), std::string("\"movel(p["), std::string("#"), std::string("-"),
        std::string("."), std::string("movel(p[1,2,3,4,5,6]") + std::string(5000, ')')}) {
    ExpectReadOrError(text);
  }
}

TEST(UrscriptLargeProgram, TenThousandTargetsReadWhole) {
  std::string text = "def big():\n";
  for (int k = 0; k < 5000; ++k) {
    const std::string n = std::to_string(k);
    text += "  global wp_" + n + " = p[0." + n + ", -0.2, .3, 0, 3.1416, 0]\n";
    text += "  movel(wp_" + n + ", a=1.2, v=0.25)\n";
    text += "  movej([0." + n + ", -1.57, 1.57, -1.57, -1.57, 0], a=1.4, v=1.05)  # station " + n + "\n";
  }
  text += "end\n";
  const ParsedProgram program = Read(text);
  EXPECT_EQ(program.targets.size(), 10000u);
  EXPECT_EQ(program.motions.size(), 10000u);
}

}  // namespace
}  // namespace robocal::programs
