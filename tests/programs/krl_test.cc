// The KUKA KRL reader: the samples of tests/data/programs/krl read with exact number spans, the frames, motions,
// flags and turns each target gets, errors that name file, line and column, the inserted target's text, and
// robustness on damaged and random input.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "robocal/programs/program.h"
#include "robocal/programs/text_scan.h"

namespace robocal::programs {
const DialectSyntax& KrlSyntax();

namespace {

using ::testing::HasSubstr;

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string ReadSample(const std::string& name) {
  std::ifstream in(std::string(ROBOCAL_PROGRAM_SAMPLES) + "/krl/" + name, std::ios::binary);
  EXPECT_TRUE(in.good()) << name;
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::vector<ProgramFile> Sample(const std::string& program) {
  return {{program + ".src", ReadSample(program + ".src")}, {program + ".dat", ReadSample(program + ".dat")}};
}

ParsedProgram Read(const std::vector<ProgramFile>& files) { return KrlSyntax().read(files); }

ParsedProgram ReadOne(const std::string& text, const std::string& name = "t.src") { return Read({{name, text}}); }

// The error reading `text` throws, or a failure when it throws none.
ProgramError ErrorOf(const std::vector<ProgramFile>& files) {
  try {
    Read(files);
  } catch (const ProgramError& e) {
    return e;
  }
  ADD_FAILURE() << "no ProgramError";
  return ProgramError("", 0, 0, "");
}
ProgramError ErrorOf(const std::string& text) { return ErrorOf({{"t.src", text}}); }

const ProgramTarget& Named(const ParsedProgram& program, const std::string& name) {
  for (const ProgramTarget& t : program.targets) {
    if (t.name && *t.name == name) return t;
  }
  ADD_FAILURE() << "no target " << name;
  static const ProgramTarget none;
  return none;
}

int IndexOf(const ParsedProgram& program, const std::string& name) {
  for (std::size_t i = 0; i < program.targets.size(); ++i) {
    if (program.targets[i].name && *program.targets[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

std::string_view SpanText(const std::vector<ProgramFile>& files, const NumberSpan& span) {
  return std::string_view(files[span.file].text).substr(span.offset, span.length);
}

// Everything a reader promises of any program it reads: spans that hold exactly the numbers listed, targets in
// file and text order at the line and column of their first number, motions whose statements are whole lines
// and whose references name their targets.
void ExpectConsistent(const std::vector<ProgramFile>& files, const ParsedProgram& program) {
  std::vector<SourceText> sources;
  for (std::size_t f = 0; f < files.size(); ++f) sources.emplace_back(files[f], static_cast<int>(f));
  std::pair<int, std::size_t> previous{-1, 0};
  for (const ProgramTarget& t : program.targets) {
    ASSERT_EQ(t.values.size(), 6u);
    ASSERT_EQ(t.spans.size(), 6u);
    std::size_t first = std::numeric_limits<std::size_t>::max();
    for (std::size_t i = 0; i < 6; ++i) {
      const NumberSpan& span = t.spans[i];
      ASSERT_EQ(span.file, t.file);
      ASSERT_LE(span.offset + span.length, files[span.file].text.size());
      const std::string_view written = SpanText(files, span);
      const std::optional<ScannedNumber> number = ScanNumber(written, 0);
      ASSERT_TRUE(number) << written;
      EXPECT_EQ(number->length, written.size()) << written;
      EXPECT_EQ(number->value, t.values[i]) << written;
      first = std::min(first, span.offset);
    }
    EXPECT_EQ(t.line, sources[t.file].LineOf(first));
    EXPECT_EQ(t.column, sources[t.file].ColumnOf(first));
    const std::pair<int, std::size_t> here{t.file, first};
    EXPECT_LT(previous, here) << "targets in file, then text order";
    previous = here;
    if (t.kind == TargetKind::kJoint) {
      EXPECT_TRUE(t.configuration.empty());
      EXPECT_FALSE(t.configuration_applies);
    }
    if (!t.configuration_applies) {
      EXPECT_TRUE(t.turns.empty());
    } else {
      EXPECT_EQ(t.motion, Motion::kJoint);
    }
  }
  std::vector<bool> moved(program.targets.size(), false);
  for (const MotionStatement& m : program.motions) {
    ASSERT_GE(m.target, 0);
    ASSERT_LT(m.target, static_cast<int>(program.targets.size()));
    const SourceText& source = sources[m.file];
    EXPECT_EQ(m.begin, source.LineStart(m.line));
    EXPECT_EQ(m.end, m.begin + source.Line(m.line).size());
    EXPECT_LE(m.begin, m.reference_begin);
    EXPECT_LT(m.reference_begin, m.reference_end);
    EXPECT_LE(m.reference_end, m.end);
    const ProgramTarget& target = program.targets[m.target];
    const std::string_view reference =
        std::string_view(files[m.file].text).substr(m.reference_begin, m.reference_end - m.reference_begin);
    if (target.name) {
      EXPECT_TRUE(EqualsNoCase(reference, *target.name)) << reference;
    } else {
      EXPECT_EQ(reference.front(), '{');
      EXPECT_EQ(reference.back(), '}');
      EXPECT_EQ(target.file, m.file);
      EXPECT_GT(target.spans[0].offset, m.reference_begin);
      EXPECT_LT(target.spans[0].offset, m.reference_end);
    }
    if (!moved[m.target]) {
      EXPECT_EQ(target.motion, m.motion) << "a target takes its first motion";
    }
    moved[m.target] = true;
  }
  for (std::size_t i = 0; i < program.targets.size(); ++i) {
    if (!moved[i]) {
      EXPECT_EQ(program.targets[i].motion, Motion::kNone);
    }
  }
}

TEST(KrlSyntax, RowNamesTheDialect) {
  const DialectSyntax& row = KrlSyntax();
  EXPECT_EQ(row.dialect, Dialect::kKrl);
  EXPECT_STREQ(row.name, "krl");
  EXPECT_THAT(row.extensions, ::testing::ElementsAre(".src", ".dat"));
  EXPECT_EQ(row.rotation, RotationConvention::kZyxIntrinsicDeg);
  EXPECT_EQ(row.mm_per_length_unit, 1.0);
  EXPECT_FALSE(row.joints_in_rad);
  EXPECT_NE(row.read, nullptr);
  EXPECT_NE(row.inline_target, nullptr);
}

TEST(KrlSamples, HaveEnoughTargetsOfEveryKind) {
  int declared_joint = 0, declared_cartesian = 0, inline_joint = 0, inline_cartesian = 0;
  std::map<Motion, int> motions;
  for (const std::string program : {"pick_place", "weld_expert"}) {
    const std::vector<ProgramFile> files = Sample(program);
    const ParsedProgram parsed = Read(files);
    ExpectConsistent(files, parsed);
    for (const ProgramTarget& t : parsed.targets) {
      const bool joint = t.kind == TargetKind::kJoint;
      (t.name ? (joint ? declared_joint : declared_cartesian) : (joint ? inline_joint : inline_cartesian))++;
      if (!t.name) ++motions[t.motion];
    }
  }
  EXPECT_GE(declared_joint, 20);
  EXPECT_GE(declared_cartesian, 20);
  EXPECT_GE(inline_joint, 20);
  EXPECT_GE(inline_cartesian, 20);
  EXPECT_GE(motions[Motion::kJoint], 10);
  EXPECT_GE(motions[Motion::kLinear], 5);
  EXPECT_GE(motions[Motion::kCircular], 4);
}

// The inline-form program: FDAT_ACT before each motion, spline motions with STOOL2 / SBASE, CRLF and LF mixed.
TEST(KrlSamples, PickPlaceFramesMotionsAndFlags) {
  const std::vector<ProgramFile> files = Sample("pick_place");
  const ParsedProgram p = Read(files);
  // 14 E6POS and 10 E6AXIS in the .dat, nothing inline in the .src.
  ASSERT_EQ(p.targets.size(), 24u);
  for (const ProgramTarget& t : p.targets) EXPECT_EQ(t.file, 1);

  const ProgramTarget& p1 = Named(p, "XP1");
  EXPECT_EQ(p1.kind, TargetKind::kCartesian);
  EXPECT_EQ(p1.motion, Motion::kJoint);
  EXPECT_EQ(p1.tool, "1");
  EXPECT_EQ(p1.base, "1");
  // S 2: basic area, A3 beyond stretched (robocal's elbow down on KUKA's axes: A1 turns about -z), A5 > 0.
  EXPECT_EQ(p1.configuration, (ArmConfiguration{1, -1, 1}));
  EXPECT_TRUE(p1.configuration_applies);
  // T 35 = 100011: A1, A2 and A6 negative.
  ASSERT_EQ(p1.turns.size(), 6u);
  const bool negative[6] = {true, true, false, false, false, true};
  for (int j = 0; j < 6; ++j) {
    EXPECT_EQ(p1.turns[j].joint, j);
    EXPECT_EQ(p1.turns[j].min, negative[j] ? -kInf : 0.0);
    EXPECT_EQ(p1.turns[j].max, negative[j] ? 0.0 : kInf);
  }
  // The line of XP1 in the .dat, and its first number right after "{X ".
  const std::string& dat = files[1].text;
  const std::size_t decl = dat.find("DECL E6POS XP1=");
  ASSERT_NE(decl, std::string::npos);
  EXPECT_EQ(p1.spans[0].offset, decl + std::string("DECL E6POS XP1={X ").size());
  EXPECT_EQ(p1.line, SourceText(files[1], 1).LineOf(decl));
  EXPECT_EQ(p1.column, static_cast<int>(std::string("DECL E6POS XP1={X ").size()) + 1);

  // XP4 has S 6: A5 <= 0 is a flipped wrist; XP7 has S 3: overhead area.
  EXPECT_EQ(Named(p, "XP4").configuration, (ArmConfiguration{1, -1, -1}));
  EXPECT_EQ(Named(p, "XP4").motion, Motion::kLinear);
  EXPECT_FALSE(Named(p, "XP4").configuration_applies) << "LIN keeps the configuration the robot has";
  EXPECT_TRUE(Named(p, "XP4").turns.empty());
  EXPECT_EQ(Named(p, "XP7").configuration, (ArmConfiguration{-1, 1, 1}));

  // Spline inline forms: the frames come from STOOL2(FP6) / SBASE(FP6.BASE_NO) of the WITH clause.
  const ProgramTarget& p6 = Named(p, "XP6");
  EXPECT_EQ(p6.motion, Motion::kLinear);
  EXPECT_EQ(p6.tool, "2");
  EXPECT_EQ(p6.base, "2");
  const ProgramTarget& p8 = Named(p, "XP8");
  EXPECT_EQ(p8.motion, Motion::kJoint);
  EXPECT_TRUE(p8.configuration_applies) << "SPTP takes S and T";
  EXPECT_EQ(p8.turns.size(), 6u);

  // CIRC XP9, XP10: via first, both with the statement's span; the frames of FP10 (FDAT_ACT=FP10).
  const int via = IndexOf(p, "XP9"), end = IndexOf(p, "XP10");
  const auto circ =
      std::find_if(p.motions.begin(), p.motions.end(), [&](const MotionStatement& m) { return m.target == via; });
  ASSERT_NE(circ, p.motions.end());
  ASSERT_NE(circ + 1, p.motions.end());
  EXPECT_EQ((circ + 1)->target, end);
  EXPECT_EQ(circ->motion, Motion::kCircular);
  EXPECT_EQ(circ->begin, (circ + 1)->begin);
  EXPECT_EQ(circ->end, (circ + 1)->end);
  EXPECT_EQ(files[0].text.substr(circ->begin, circ->end - circ->begin), "CIRC XP9, XP10");
  EXPECT_FALSE(p.targets[via].configuration_applies);
  EXPECT_EQ(p.targets[via].tool, "1");

  // XP14 runs with tool 3 in base 2; XP13 in base 0, which is the robot's base ("").
  EXPECT_EQ(Named(p, "XP14").tool, "3");
  EXPECT_EQ(Named(p, "XP14").base, "2");
  EXPECT_EQ(Named(p, "XP13").base, "");

  // Axis points: values A1..A6, the external axes left out; XP17 with tool 2.
  const ProgramTarget& p15 = Named(p, "XP15");
  EXPECT_EQ(p15.kind, TargetKind::kJoint);
  EXPECT_EQ(p15.motion, Motion::kJoint);
  EXPECT_EQ(p15.tool, "1");
  EXPECT_EQ(p15.base, "");
  EXPECT_EQ(Named(p, "XP17").tool, "2");
  // The spares are declared and never moved to.
  EXPECT_EQ(Named(p, "XP23").motion, Motion::kNone);
  EXPECT_EQ(Named(p, "XP23").tool, "");

  // XP2 is moved to twice (LIN there and back): two motions, the first one's kind. XHOME is $config.dat's.
  EXPECT_EQ(std::count_if(p.motions.begin(), p.motions.end(),
                          [&](const MotionStatement& m) { return m.target == IndexOf(p, "XP2"); }),
            2);
  EXPECT_EQ(p.motions.size(), 23u);
  for (const MotionStatement& m : p.motions) EXPECT_EQ(m.file, 0);
}

// The expert program: $TOOL / $BASE, BAS(#TOOL / #BASE), WITH clauses for one motion, typed and reordered
// aggregates, binary and hexadecimal S / T, relative motions and geometric operations left alone.
TEST(KrlSamples, WeldExpertFramesAndInlineTargets) {
  const std::vector<ProgramFile> files = Sample("weld_expert");
  const ParsedProgram p = Read(files);
  ExpectConsistent(files, p);
  const std::string& src = files[0].text;
  auto inline_at = [&](const std::string& needle) -> const ProgramTarget& {
    const std::size_t at = src.find(needle);
    EXPECT_NE(at, std::string::npos) << needle;
    for (const MotionStatement& m : p.motions) {
      if (m.file == 0 && m.reference_begin <= at && at < m.reference_end) return p.targets[m.target];
    }
    ADD_FAILURE() << needle;
    static const ProgramTarget none;
    return none;
  };
  // Home, in tool 4 (torch) and base 2 (fixture).
  const ProgramTarget& home = inline_at("{A1 0, A2 -90, A3 90, A4 0, A5 35, A6 0}");
  EXPECT_FALSE(home.name);
  EXPECT_EQ(home.kind, TargetKind::kJoint);
  EXPECT_EQ(home.values, (std::vector<double>{0, -90, 90, 0, 35, 0}));
  EXPECT_EQ(home.tool, "4");
  EXPECT_EQ(home.base, "2");
  EXPECT_EQ(home.line, 14);
  EXPECT_EQ(home.column, static_cast<int>(std::string("\tPTP {A1 ").size()) + 1);

  // Typed aggregate with binary S and T: 'B010' front / down / noflip; 'B100010' A2 and A6 negative.
  const ProgramTarget& typed = inline_at("{E6POS: X -747.4");
  EXPECT_EQ(typed.kind, TargetKind::kCartesian);
  EXPECT_EQ(typed.values, (std::vector<double>{-747.4, 2164.98, 993.9, 88.5, 41.32, 31.9}));
  EXPECT_EQ(typed.configuration, (ArmConfiguration{1, -1, 1}));
  EXPECT_TRUE(typed.configuration_applies);
  ASSERT_EQ(typed.turns.size(), 6u);
  EXPECT_EQ(typed.turns[1].max, 0.0);
  EXPECT_EQ(typed.turns[5].max, 0.0);
  EXPECT_EQ(typed.turns[0].min, 0.0);
  EXPECT_EQ(typed.tool, "5");
  EXPECT_EQ(typed.base, "2");
  const ProgramTarget& pos = inline_at("{POS: X 5.6");
  EXPECT_EQ(pos.configuration, (ArmConfiguration{1, -1, -1}));  // S 6

  // Components in another order: values still X Y Z A B C, each span on its own number.
  const ProgramTarget& clean = Named(p, "pTorchClean");
  EXPECT_EQ(clean.spans[0].file, 1);
  const std::string& dat = files[1].text;
  const std::size_t x = dat.find(",X ", dat.find("pTorchClean")) + 3;
  EXPECT_EQ(clean.spans[0].offset, x);
  EXPECT_LT(clean.spans[5].offset, clean.spans[0].offset) << "C is written first";
  EXPECT_EQ(clean.column, static_cast<int>(clean.spans[5].offset - dat.rfind('\n', clean.spans[5].offset)));
  EXPECT_EQ(clean.tool, "5");  // after BAS(#TOOL, 5)
  EXPECT_EQ(clean.base, "");   // BAS(#BASE, 0)

  // WITH $TOOL / $BASE hold for their own motion only.
  const std::size_t with = src.find("WITH $TOOL = TOOL_DATA[6]");
  for (const MotionStatement& m : p.motions) {
    if (m.begin <= with && with < m.end) {
      EXPECT_EQ(p.targets[m.target].tool, "6");
      EXPECT_EQ(p.targets[m.target].base, "3");
    }
  }
  EXPECT_EQ(Named(p, "pTorchCut").tool, "5");
  EXPECT_EQ(Named(p, "pTorchCut").base, "");
  EXPECT_EQ(Named(p, "pTorchCut").configuration, (ArmConfiguration{1, -1, -1}));
  // The wire targets: 'B010' and a hexadecimal-free binary T; SLIN keeps the configuration.
  EXPECT_EQ(Named(p, "pWire1").motion, Motion::kLinear);
  EXPECT_FALSE(Named(p, "pWire1").configuration_applies);

  // Declarations without DECL, with GLOBAL, in lower case; AXIS and E6AXIS; FRAME without flags.
  for (int i = 1; i <= 8; ++i) EXPECT_EQ(Named(p, "jSeam" + std::to_string(i)).kind, TargetKind::kJoint);
  EXPECT_EQ(Named(p, "jSeam2").motion, Motion::kJoint);  // "ptp   jSeam2  c_ptp"
  EXPECT_EQ(Named(p, "jSeam6").motion, Motion::kNone);
  EXPECT_EQ(Named(p, "jTrack2").motion, Motion::kJoint);
  EXPECT_EQ(Named(p, "fSeamRef1").motion, Motion::kLinear);
  EXPECT_TRUE(Named(p, "fSeamRef1").configuration.empty());
  EXPECT_EQ(IndexOf(p, "fSeamRef2"), -1) << "an operand of a geometric operation is a frame, not a target";
  EXPECT_EQ(Named(p, "fSeamRef3").motion, Motion::kNone);
  EXPECT_EQ(Named(p, "pSeam3").motion, Motion::kCircular);
  EXPECT_EQ(Named(p, "pSeam5").motion, Motion::kLinear);  // SPL

  // Relative motions are no targets; $BASE = $NULLFRAME is the robot's base.
  for (const MotionStatement& m : p.motions) {
    const std::string statement = src.substr(m.begin, m.end - m.begin);
    EXPECT_THAT(statement, ::testing::Not(HasSubstr("_REL")));
    EXPECT_THAT(statement, ::testing::Not(HasSubstr("$POS_ACT")));
  }
  EXPECT_EQ(p.targets[p.motions.back().target].base, "");
  EXPECT_EQ(p.targets[p.motions.back().target].tool, "5");
}

TEST(KrlFlags, StatusBitsMapOntoRobocalsFlags) {
  // bit 0: overhead area -> back; bit 1: A3 beyond stretched -> elbow down in the basic area, up in the overhead
  // area (robocal's elbow is seen along A1's axis, which on a KUKA points down, with the wrist outward);
  // bit 2: A5 <= 0 -> flip.
  for (int s = 0; s < 8; ++s) {
    const ParsedProgram p = ReadOne("PTP {X 1000,Y 0,Z 900,A 0,B 90,C 0,S " + std::to_string(s) + "}\n");
    ASSERT_EQ(p.targets.size(), 1u);
    const int shoulder = (s & 1) ? -1 : 1;
    const ArmConfiguration expected{shoulder, ((s & 2) ? -1 : 1) * shoulder, (s & 4) ? -1 : 1};
    EXPECT_EQ(p.targets[0].configuration, expected) << "S " << s;
    EXPECT_TRUE(p.targets[0].configuration_applies);
    EXPECT_TRUE(p.targets[0].turns.empty()) << "no T, no turns";
  }
  // Bits above bit 2 (bit 4: taught on an absolutely accurate robot) do not change the flags.
  EXPECT_EQ(ReadOne("PTP {X 1,Y 0,Z 9,A 0,B 9,C 0,S 'B10010'}").targets[0].configuration, (ArmConfiguration{1, -1, 1}));
}

TEST(KrlFlags, TurnBitsGiveJointSigns) {
  for (int t : {0, 1, 2, 4, 8, 16, 32, 63, 42}) {
    const ParsedProgram p = ReadOne("PTP {X 1000,Y 0,Z 900,A 0,B 90,C 0,S 2,T " + std::to_string(t) + "}\r\n");
    ASSERT_EQ(p.targets[0].turns.size(), 6u);
    for (int j = 0; j < 6; ++j) {
      const JointRange& r = p.targets[0].turns[j];
      EXPECT_EQ(r.joint, j);
      if ((t >> j) & 1) {
        EXPECT_EQ(r.min, -kInf);
        EXPECT_EQ(r.max, 0.0);
      } else {
        EXPECT_EQ(r.min, 0.0);
        EXPECT_EQ(r.max, kInf);
      }
    }
  }
  // Binary, hexadecimal and decimal name the same bits.
  const ParsedProgram p = ReadOne(
      "PTP {X 1,Y 2,Z 3,A 4,B 5,C 6,S 2,T 'B100010'}\nPTP {X 1,Y 2,Z 3,A 4,B 5,C 6,S 2,T 'H22'}\n"
      "PTP {X 1,Y 2,Z 3,A 4,B 5,C 6,S 2,T 34}\n");
  ASSERT_EQ(p.targets.size(), 3u);
  EXPECT_EQ(p.targets[0].turns.size(), 6u);
  for (int j = 0; j < 6; ++j) {
    EXPECT_EQ(p.targets[0].turns[j].max, p.targets[1].turns[j].max);
    EXPECT_EQ(p.targets[0].turns[j].max, p.targets[2].turns[j].max);
  }
  EXPECT_EQ(p.targets[0].turns[1].max, 0.0);
  EXPECT_EQ(p.targets[0].turns[5].max, 0.0);
}

TEST(KrlFlags, OnlyPtpTakesStatusAndTurn) {
  const ParsedProgram p = ReadOne(
      "DECL E6POS XA={X 1,Y 2,Z 3,A 4,B 5,C 6,S 6,T 1}\n"
      "DECL POS XB={X 1,Y 2,Z 3,A 4,B 5,C 6,S 6,T 1}\n"
      "DECL POS XC={X 1,Y 2,Z 3,A 4,B 5,C 6}\n"
      "LIN XA\nPTP XA\nSPTP XB\nPTP XC\n");
  EXPECT_FALSE(Named(p, "XA").configuration_applies) << "its first motion is a LIN";
  EXPECT_EQ(Named(p, "XA").configuration, (ArmConfiguration{1, -1, -1})) << "the flags are still reported";
  EXPECT_TRUE(Named(p, "XA").turns.empty());
  EXPECT_TRUE(Named(p, "XB").configuration_applies);
  EXPECT_EQ(Named(p, "XB").turns.size(), 6u);
  EXPECT_FALSE(Named(p, "XC").configuration_applies) << "no S";
  EXPECT_TRUE(Named(p, "XC").configuration.empty());
}

TEST(KrlFrames, FdatActSetsToolAndBaseForTheFollowingMotions) {
  const std::vector<ProgramFile> files = {
      {"cell.src", "DEF cell()\nFDAT_ACT=FP1\nPTP XP1\nLIN XP2\nFDAT_ACT = FQ\nLIN XP3\nEND\n"},
      {"cell.dat",
       "DEFDAT cell\nDECL FDAT FP1={TOOL_NO 7,BASE_NO 3,IPO_FRAME #BASE,POINT2[] \" \",TQ_STATE FALSE}\n"
       "DECL FDAT FQ={TOOL_NO 2,BASE_NO 0}\n"
       "DECL E6POS XP1={X 1,Y 2,Z 3,A 4,B 5,C 6}\nDECL E6POS XP2={X 1,Y 2,Z 3,A 4,B 5,C 6}\n"
       "DECL E6POS XP3={X 1,Y 2,Z 3,A 4,B 5,C 6}\nENDDAT\n"}};
  const ParsedProgram p = Read(files);
  ExpectConsistent(files, p);
  EXPECT_EQ(Named(p, "XP1").tool, "7");
  EXPECT_EQ(Named(p, "XP1").base, "3");
  EXPECT_EQ(Named(p, "XP2").tool, "7") << "FDAT_ACT holds until the next one";
  EXPECT_EQ(Named(p, "XP3").tool, "2");
  EXPECT_EQ(Named(p, "XP3").base, "");
  EXPECT_EQ(Named(p, "XP1").file, 1);
  EXPECT_EQ(p.motions[0].file, 0);
  EXPECT_EQ(p.motions[0].line, 3);
}

TEST(KrlFrames, PointAndFdatPairedByNameWhenNothingSetsTheFrames) {
  const std::string dat =
      "DECL FDAT FP1={TOOL_NO 4,BASE_NO 5}\nDECL FDAT FP2={TOOL_NO 6,BASE_NO 0}\n"
      "DECL E6POS XP1={X 1,Y 2,Z 3,A 4,B 5,C 6}\nDECL E6POS XP2={X 1,Y 2,Z 3,A 4,B 5,C 6}\n"
      "DECL E6POS XP3={X 1,Y 2,Z 3,A 4,B 5,C 6}\n";
  // No frame statement: XP1 <-> FP1.
  ParsedProgram p = Read({{"a.src", "PTP XP1\nPTP XP3\n"}, {"a.dat", dat}});
  EXPECT_EQ(Named(p, "XP1").tool, "4");
  EXPECT_EQ(Named(p, "XP1").base, "5");
  EXPECT_EQ(Named(p, "XP3").tool, "") << "no FP3: the robot's own tool";
  // An explicit FDAT_ACT wins over the pairing, and so does $TOOL.
  p = Read({{"a.src", "FDAT_ACT=FP2\nPTP XP1\n"}, {"a.dat", dat}});
  EXPECT_EQ(Named(p, "XP1").tool, "6");
  EXPECT_EQ(Named(p, "XP1").base, "");
  p = Read({{"a.src", "$TOOL=TOOL_DATA[9]\nPTP XP1\n"}, {"a.dat", dat}});
  EXPECT_EQ(Named(p, "XP1").tool, "9");
  EXPECT_EQ(Named(p, "XP1").base, "5") << "the base was not set: FP1's";
}

TEST(KrlFrames, ToolAndBaseStatements) {
  const ParsedProgram p = ReadOne(
      "$TOOL = TOOL_DATA[ 3 ]\n$BASE=BASE_DATA[12]\nPTP {A1 1,A2 2,A3 3,A4 4,A5 5,A6 6}\n"
      "BAS (#TOOL ,0)\nBAS(#BASE,4)\nPTP {A1 1,A2 2,A3 3,A4 4,A5 5,A6 6}\n"
      "$TOOL=$NULLFRAME\n$BASE=$NULLFRAME\nPTP {A1 1,A2 2,A3 3,A4 4,A5 5,A6 6}\n"
      "$BASE=EK(MACHINE_DEF[2].ROOT,MACHINE_DEF[2].MECH_TYPE,TRUE) ; a kinematic base\n"
      "PTP {A1 1,A2 2,A3 3,A4 4,A5 5,A6 6}\n"
      "SLIN {X 1,Y 2,Z 3,A 4,B 5,C 6} WITH $VEL = SVEL_CP(0.2, , LDEFAULT), $BASE = BASE_DATA[1], $TOOL=TOOL_DATA[8]\n"
      "PTP {A1 1,A2 2,A3 3,A4 4,A5 5,A6 6}\n");
  ASSERT_EQ(p.targets.size(), 6u);
  EXPECT_EQ(p.targets[0].tool, "3");
  EXPECT_EQ(p.targets[0].base, "12");
  EXPECT_EQ(p.targets[1].tool, "0");
  EXPECT_EQ(p.targets[1].base, "4");
  EXPECT_EQ(p.targets[2].tool, "0");
  EXPECT_EQ(p.targets[2].base, "");
  EXPECT_EQ(p.targets[3].base, "EK(MACHINE_DEF[2].ROOT,MACHINE_DEF[2].MECH_TYPE,TRUE)")
      << "a base the reader cannot number is named as written, for the request to give";
  EXPECT_EQ(p.targets[4].tool, "8");
  EXPECT_EQ(p.targets[4].base, "1");
  EXPECT_EQ(p.targets[5].tool, "0") << "WITH holds for its own motion only";
}

TEST(KrlFrames, ValuesUsedAsFramesAreNotTargets) {
  const std::vector<ProgramFile> files = {
      {"f.src",
       "$BASE = fFixture\nLIN XP1:{X 0,Y 0,Z -20.0,A 0,B 0,C 0}\nLIN XP1\nPTP fRef : XP2\n"
       "SLIN XP3 WITH $TOOL = fGun\nPTP XP4\n"},
      {"f.dat",
       "DECL FRAME fFixture={X 100,Y 200,Z 0,A 90,B 0,C 0}\nDECL FRAME fRef={X 1,Y 2,Z 3,A 4,B 5,C 6}\n"
       "DECL FRAME fGun={X 0,Y 0,Z 250,A 0,B 0,C 0}\nDECL FRAME fSpare={X 1,Y 2,Z 3,A 4,B 5,C 6}\n"
       "DECL E6POS XP1={X 1,Y 2,Z 3,A 4,B 5,C 6}\nDECL E6POS XP2={X 1,Y 2,Z 3,A 4,B 5,C 6}\n"
       "DECL E6POS XP3={X 1,Y 2,Z 3,A 4,B 5,C 6}\nDECL E6POS XP4={X 1,Y 2,Z 3,A 4,B 5,C 6}\n"}};
  const ParsedProgram p = Read(files);
  ExpectConsistent(files, p);
  EXPECT_EQ(IndexOf(p, "fFixture"), -1);
  EXPECT_EQ(IndexOf(p, "fRef"), -1);
  EXPECT_EQ(IndexOf(p, "fGun"), -1);
  EXPECT_EQ(IndexOf(p, "XP2"), -1) << "only reached through a geometric operation";
  EXPECT_EQ(Named(p, "fSpare").motion, Motion::kNone) << "unused: a target another module may move to";
  // XP1 is moved to directly, and also used with an approach offset: it stays a target.
  EXPECT_EQ(Named(p, "XP1").motion, Motion::kLinear);
  EXPECT_EQ(Named(p, "XP1").base, "fFixture") << "a base the reader cannot number is named as written";
  EXPECT_EQ(Named(p, "XP3").tool, "fGun");
  EXPECT_EQ(Named(p, "XP4").tool, "");
  ASSERT_EQ(p.motions.size(), 3u);
  EXPECT_EQ(p.targets[p.motions[0].target].name, "XP1");
  EXPECT_EQ(p.motions[0].line, 3);
  EXPECT_EQ(p.targets[p.motions[2].target].name, "XP4");
}

TEST(KrlFrames, ExternalTcpIsRefused) {
  ProgramError e = ErrorOf({{"x.src", "FDAT_ACT=FP1\nLIN XP1\n"},
                            {"x.dat",
                             "DECL FDAT FP1={TOOL_NO 1,BASE_NO 1,IPO_FRAME #TCP}\n"
                             "DECL E6POS XP1={X 1,Y 2,Z 3,A 4,B 5,C 6}\n"}});
  EXPECT_EQ(e.file(), "x.src");
  EXPECT_EQ(e.line(), 2);
  EXPECT_EQ(e.column(), 5);
  EXPECT_THAT(e.reason(), HasSubstr("external TCP"));
  e = ErrorOf("$IPO_MODE = #TCP\nPTP {A1 1,A2 2,A3 3,A4 4,A5 5,A6 6}\n");
  EXPECT_EQ(e.line(), 2);
  // Back to #BASE, it reads.
  EXPECT_EQ(ReadOne("$IPO_MODE = #TCP\n$IPO_MODE = #BASE\nPTP {A1 1,A2 2,A3 3,A4 4,A5 5,A6 6}\n").targets.size(), 1u);
}

TEST(KrlMotions, StatementAndReferenceSpans) {
  const std::string text =
      "DEF m()\r\n  LIN {X 1,Y 2,Z 3,A 4,B 5,C 6} C_DIS ; to {X 9}\r\n\tCIRC XV ,  {X 1,Y 2,Z 3,A 4,B 5,C 6}, CA 45\r\n"
      "  PTP XV\nEND\n";
  const std::vector<ProgramFile> files = {{"m.src", text}, {"m.dat", "DECL POS XV={X 10,Y 20,Z 30,A 40,B 50,C 60}\n"}};
  const ParsedProgram p = Read(files);
  ExpectConsistent(files, p);
  ASSERT_EQ(p.motions.size(), 4u);
  const auto statement = [&](const MotionStatement& m) { return text.substr(m.begin, m.end - m.begin); };
  const auto reference = [&](const MotionStatement& m) {
    return text.substr(m.reference_begin, m.reference_end - m.reference_begin);
  };
  EXPECT_EQ(statement(p.motions[0]), "  LIN {X 1,Y 2,Z 3,A 4,B 5,C 6} C_DIS ; to {X 9}");
  EXPECT_EQ(reference(p.motions[0]), "{X 1,Y 2,Z 3,A 4,B 5,C 6}");
  EXPECT_EQ(p.motions[0].line, 2);
  EXPECT_EQ(statement(p.motions[1]), "\tCIRC XV ,  {X 1,Y 2,Z 3,A 4,B 5,C 6}, CA 45");
  EXPECT_EQ(reference(p.motions[1]), "XV");
  EXPECT_EQ(reference(p.motions[2]), "{X 1,Y 2,Z 3,A 4,B 5,C 6}");
  EXPECT_EQ(p.motions[1].motion, Motion::kCircular);
  EXPECT_EQ(p.motions[2].motion, Motion::kCircular);
  EXPECT_EQ(p.motions[3].motion, Motion::kJoint);
  EXPECT_EQ(p.motions[3].line, 4);
  // Targets: the two inline ones of m.src, then XV of m.dat.
  ASSERT_EQ(p.targets.size(), 3u);
  EXPECT_FALSE(p.targets[0].name);
  EXPECT_EQ(p.targets[0].line, 2);
  EXPECT_EQ(p.targets[0].column, 10);
  EXPECT_EQ(p.targets[1].line, 3);
  EXPECT_EQ(*p.targets[2].name, "XV");
  EXPECT_EQ(p.targets[2].motion, Motion::kCircular) << "its first motion is the circle";
  EXPECT_FALSE(p.targets[2].configuration_applies);
}

TEST(KrlMotions, CommentsStringsAndFoldsAreNotCode) {
  const ParsedProgram p = ReadOne(
      ";FOLD PTP P1 Vel=100 % PDAT1 Tool[1] Base[0];%{PE}\n"
      "PTP {A1 1,A2 2,A3 3,A4 4,A5 5,A6 6}\n"
      ";ENDFOLD\n"
      "; PTP {A1 9,A2 9,A3 9,A4 9,A5 9,A6 9}\n"
      "MsgText[] = \"; PTP {A1 9}\" ; a string with a semicolon\n"
      "DECL CHAR S[8]\n"
      "S[]=\"LIN {X\"\n"
      "  ;LIN {X 1,Y 2,Z 3,A 4,B 5,C 6}\n"
      "PTP_REL {A1 10}\nLIN_REL {Z 5} #TOOL\nSPTP_REL {A6 1}\nASYPTP {E1 5}\nPTP $AXIS_ACT\nPTP XHOME\n"
      "PTP BASE_DATA[1]:{X 1,Y 2,Z 3,A 4,B 5,C 6}\nLIN XUNDECLARED\n");
  ASSERT_EQ(p.targets.size(), 1u);
  EXPECT_EQ(p.targets[0].line, 2);
  EXPECT_EQ(p.motions.size(), 1u);
}

TEST(KrlMotions, CrlfAndLfReadAlike) {
  const std::string lf = Sample("weld_expert")[0].text;
  std::string crlf;
  for (char c : lf) {
    if (c == '\n') crlf += '\r';
    crlf += c;
  }
  const std::string dat = Sample("weld_expert")[1].text;
  const ParsedProgram a = Read({{"w.src", lf}, {"w.dat", dat}});
  const ParsedProgram b = Read({{"w.src", crlf}, {"w.dat", dat}});
  ASSERT_EQ(a.targets.size(), b.targets.size());
  for (std::size_t i = 0; i < a.targets.size(); ++i) {
    EXPECT_EQ(a.targets[i].values, b.targets[i].values);
    EXPECT_EQ(a.targets[i].line, b.targets[i].line);
    EXPECT_EQ(a.targets[i].column, b.targets[i].column);
    EXPECT_EQ(a.targets[i].tool, b.targets[i].tool);
    EXPECT_EQ(a.targets[i].base, b.targets[i].base);
  }
  ASSERT_EQ(a.motions.size(), b.motions.size());
  for (std::size_t i = 0; i < a.motions.size(); ++i) EXPECT_EQ(a.motions[i].line, b.motions[i].line);
}

TEST(KrlNames, ResolvedInTheirOwnModuleFirst) {
  const std::vector<ProgramFile> files = {{"a.src", "PTP XP\n"},
                                          {"b.src", "PTP XP\n"},
                                          {"b.dat", "DECL AXIS XP={A1 2,A2 2,A3 2,A4 2,A5 2,A6 2}\n"},
                                          {"a.dat", "DECL AXIS xp={A1 1,A2 1,A3 1,A4 1,A5 1,A6 1}\n"}};
  const ParsedProgram p = Read(files);
  ExpectConsistent(files, p);
  ASSERT_EQ(p.motions.size(), 2u);
  EXPECT_EQ(p.targets[p.motions[0].target].values[0], 1.0) << "a.src sees a.dat's XP (names without case)";
  EXPECT_EQ(p.targets[p.motions[1].target].values[0], 2.0);
}

TEST(KrlErrors, PartialAggregateNamesTargetAndComponent) {
  ProgramError e = ErrorOf({{"p.src", "PTP XP1\n"}, {"p.dat", "DEFDAT p\n  DECL E6AXIS XP1={A1 45}\nENDDAT\n"}});
  EXPECT_EQ(e.file(), "p.dat");
  EXPECT_EQ(e.line(), 2);
  EXPECT_EQ(e.column(), 19);  // the '{'
  EXPECT_THAT(e.reason(), HasSubstr("XP1"));
  EXPECT_THAT(e.reason(), HasSubstr("A2"));
  EXPECT_THAT(e.reason(), HasSubstr("whole targets"));
  e = ErrorOf("\n\n   LIN {X 1,Y 2,Z 3,A 4,B 5}\n");
  EXPECT_EQ(e.file(), "t.src");
  EXPECT_EQ(e.line(), 3);
  EXPECT_EQ(e.column(), 8);
  EXPECT_THAT(e.reason(), HasSubstr("has no C"));
  EXPECT_THAT(ErrorOf("DECL FRAME F1={X 1,Y 2,Z 3,A 4,C 6}").reason(), HasSubstr("has no B"));
}

TEST(KrlErrors, MalformedTargetsNameLineAndColumn) {
  // Each case: the text, the line of the error, and the bytes its column points at (their first occurrence).
  struct Case {
    std::string text;
    int line;
    std::string at;
    std::string reason;
  };
  const std::vector<Case> cases = {
      {"DECL E6POS XP1={X 1.2.3,Y 2,Z 3,A 4,B 5,C 6}", 1, "1.2.3", "X is not a number"},
      {"x\nDECL POS XP1={X 1,Y 2,Z abc,A 4,B 5,C 6}", 2, "abc", "Z is not a number"},
      {"DECL E6POS XP1={X 1,Y 2,Z 3,A 4,B 5,C 6,Q 1}", 1, "Q 1", "component Q"},
      {"DECL FRAME F1={X 1,Y 2,Z 3,A 4,B 5,C 6,S 2}", 1, "S 2", "component S"},
      {"DECL POS P1={X 1,Y 2,Z 3,A 4,B 5,C 6,E1 0}", 1, "E1", "component E1"},
      {"DECL E6POS XP1={X 1,Y 2,Z 3,A 4,B 5,C 6,X 7}", 1, "X 7", "X twice"},
      {"DECL E6POS XP1={X 1,Y 2,Z 3,A 4,B 5,C 6,S 2,S 3}", 1, "S 3", "S twice"},
      {"DECL E6POS XP1={X 1,Y 2,Z 3,A 4,B 5,C 6,S 'B012'}", 1, "'B012'", "S is not an integer"},
      {"DECL E6POS XP1={X 1,Y 2,Z 3,A 4,B 5,C 6,T -1}", 1, "-1", "T is not an integer"},
      {"DECL E6POS XP1={X 1,Y 2,Z 3,A 4,B 5,C 6", 1, "{", "no closing"},
      {"DECL E6POS XP1={X 1,Y 2,Z 3,A 4,B 5,C 6,}", 1, "}", "name"},
      {"DECL E6POS XP1={X 1,Y 2,Z 3,A 4,B 5,C}", 1, "C}", "C has no value"},
      {"DECL E6AXIS XA={A1 1,A2 2,A3 3,A4 4,A5 5,A6 6,E1 x}", 1, "x}", "E1 is not a number"},
      {"DECL E6POS XP1=XP2", 1, "XP2", "not an aggregate"},
      {"  PTP {A1 1,A2 2,A3 3,A4 4,A5 5,A6 6", 1, "{", "no closing"},
      {"PTP {QUAT: A1 1}", 1, "{", "type QUAT"},
      {"LIN {X1,Y 2,Z 3,A 4,B 5,C 6}", 1, "X1", "no value"},
      {"CIRC {X 1,Y 2,Z 3,A 4,B 5,C 6}, {X 1,Y 2,Z 3,A 4,B 5}", 1, "{X 1,Y 2,Z 3,A 4,B 5}", "has no C"},
      {"\r\n\r\nPTP {A1 1,A2 2,A3 3,A4 4,A5 5,A6 6,A7 7}", 3, "A7", "component A7"},
  };
  for (const Case& c : cases) {
    const ProgramError e = ErrorOf(c.text);
    const ProgramFile file{"t.src", c.text};
    const SourceText source(file, 0);
    const std::size_t at = c.text.find(c.at, source.LineStart(c.line));
    ASSERT_NE(at, std::string::npos);
    EXPECT_EQ(e.file(), "t.src") << c.text;
    EXPECT_EQ(e.line(), c.line) << c.text;
    EXPECT_EQ(e.column(), source.ColumnOf(at)) << c.text << ": " << e.what();
    EXPECT_THAT(e.reason(), HasSubstr(c.reason)) << c.text;
  }
}

TEST(KrlErrors, StatementsTheReaderDoesNotNeedAreNotErrors) {
  // A malformed FDAT, an aggregate of another type, an array of targets, a declaration without value.
  const ParsedProgram p = ReadOne(
      "DECL FDAT FP1={TOOL_NO 1,BASE_NO\nDECL LDAT L1={VEL 2.0,ORI_TYP #VAR}\nDECL E6POS XA[10]\nDECL E6POS XB\n"
      "XA[1]={X 1}\n$VEL={CP 0.2,ORI1 200}\nIF X==1 THEN\nENDIF\n{\n}}}\n\"\n");
  EXPECT_TRUE(p.targets.empty());
  EXPECT_TRUE(p.motions.empty());
}

TEST(KrlInlineTarget, WritesTheValuesWithTheFlagsOfLike) {
  const std::vector<ProgramFile> files = {
      {"i.src", "PTP XP1\nLIN {X 5,Y 6,Z 7,A 8,B 9,C 10}\nPTP {A1 1,A2 2,A3 3,A4 4,A5 5,A6 6}\n"},
      {"i.dat", "DECL E6POS XP1={X 1,Y 2,Z 3,A 4,B 5,C 6,S 'B110',T 35,E1 250.5,E2 0.0}\n"}};
  const ParsedProgram p = Read(files);
  ASSERT_EQ(p.targets.size(), 3u);
  const std::vector<double> values = {1000.12345, -2.5, 300.0, 179.99999, -0.00001, 90.5};
  const std::string text = KrlSyntax().inline_target(Named(p, "XP1"), files, values);
  EXPECT_EQ(text, "{X 1000.123,Y -2.500,Z 300.000,A 180.0000,B 0.0000,C 90.5000,S 'B110',T 35,E1 250.5,E2 0.0}");
  // It reads back as a target with those values and the same flags.
  const ParsedProgram again = ReadOne("PTP " + text + "\n");
  ASSERT_EQ(again.targets.size(), 1u);
  EXPECT_EQ(again.targets[0].configuration, Named(p, "XP1").configuration);
  EXPECT_EQ(again.targets[0].turns.size(), 6u);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(again.targets[0].values[i], values[i], 1e-3);
  // Without flags none are written; a joint target has no inline Cartesian form.
  EXPECT_EQ(KrlSyntax().inline_target(p.targets[0], files, {1, 2, 3, 4, 5, 6}),
            "{X 1.000,Y 2.000,Z 3.000,A 4.0000,B 5.0000,C 6.0000}");
  EXPECT_EQ(KrlSyntax().inline_target(p.targets[1], files, {1, 2, 3, 4, 5, 6}), "");
}

// A 10,000-target .dat reads whole (the time is measured in the benchmark, not asserted here).
TEST(KrlScale, TenThousandTargets) {
  std::string dat = "DEFDAT big\n", src = "DEF big()\n$TOOL=TOOL_DATA[1]\n";
  for (int i = 0; i < 10000; ++i) {
    const std::string n = std::to_string(i);
    dat += "DECL E6POS XP" + n + "={X " + std::to_string(1000 + i % 300) + ".5,Y -" + n +
           ".25,Z 800.0,A 0.0,B 90.0,C 0.0,S 2,T 35,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}\n";
    dat += "DECL FDAT FP" + n + "={TOOL_NO 1,BASE_NO 2,IPO_FRAME #BASE}\n";
    src += "FDAT_ACT=FP" + n + "\n" + (i % 2 ? "LIN XP" : "PTP XP") + n + "\n";
  }
  dat += "ENDDAT\n";
  src += "END\n";
  const ParsedProgram p = Read({{"big.src", src}, {"big.dat", dat}});
  ASSERT_EQ(p.targets.size(), 10000u);
  ASSERT_EQ(p.motions.size(), 10000u);
  EXPECT_EQ(p.targets[9999].values[1], -9999.25);
  EXPECT_EQ(p.targets[9999].base, "2");
  EXPECT_EQ(p.targets[9998].motion, Motion::kJoint);
  EXPECT_EQ(p.targets[9999].motion, Motion::kLinear);
}

// Whatever the bytes, the reader returns what it found or throws ProgramError at a place inside the file.
void ExpectReadsOrRefuses(const std::vector<ProgramFile>& files) {
  try {
    const ParsedProgram p = Read(files);
    ExpectConsistent(files, p);
  } catch (const ProgramError& e) {
    bool known = false;
    for (const ProgramFile& f : files) known = known || f.name == e.file();
    EXPECT_TRUE(known);
    EXPECT_GE(e.line(), 1);
    EXPECT_GE(e.column(), 1);
  }
}

TEST(KrlRobustness, TruncatedAndMutatedSamples) {
  std::mt19937 random(37);
  for (const std::string program : {"pick_place", "weld_expert"}) {
    const std::vector<ProgramFile> files = Sample(program);
    for (std::size_t cut = 0; cut < files[1].text.size(); cut += 97) {
      ExpectReadsOrRefuses({files[0], {files[1].name, files[1].text.substr(0, cut)}});
    }
    for (std::size_t cut = 0; cut < files[0].text.size(); cut += 89) {
      ExpectReadsOrRefuses({{files[0].name, files[0].text.substr(0, cut)}, files[1]});
    }
    static const char kBytes[] = "{},;:\"'[]() \t\r\n-+.eE0123456789XYZABCSTAE#$";
    for (int trial = 0; trial < 300; ++trial) {
      std::vector<ProgramFile> mutated = files;
      ProgramFile& f = mutated[trial % 2];
      for (int k = 0; k < 4; ++k) {
        const std::size_t at = random() % f.text.size();
        f.text[at] = kBytes[random() % (sizeof kBytes - 1)];
      }
      ExpectReadsOrRefuses(mutated);
    }
  }
}

TEST(KrlRobustness, RandomBytes) {
  std::mt19937 random(7);
  for (int trial = 0; trial < 2000; ++trial) {
    std::string text(random() % 200, '\0');
    for (char& c : text) c = static_cast<char>(random() % 256);
    if (trial % 3 == 0) text = "PTP {" + text;
    if (trial % 3 == 1) text = "DECL E6POS XP={X " + text;
    ExpectReadsOrRefuses({{"r.src", text}, {"r.dat", text.substr(text.size() / 2)}});
  }
  ExpectReadsOrRefuses({});
  ExpectReadsOrRefuses({{"e.src", ""}});
}

}  // namespace
}  // namespace robocal::programs
