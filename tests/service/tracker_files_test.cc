// Tracker export files: Spatial Analyzer style point exports and CSV read into points in mm, every bad line
// named by its number, and the points matched to a plan's configurations.
#include "robocal/api/tracker_files.h"

#include <gtest/gtest.h>

#include <algorithm>

namespace robocal::api {
namespace {

using nlohmann::json;

ImportMeasurementsRequest Request(const std::string& format, const std::string& text, const std::string& unit = "") {
  ImportMeasurementsRequest r;
  r.request_id = "t";
  EXPECT_TRUE(FromWireName(format, &r.format)) << format;
  r.text = text;
  if (!unit.empty()) {
    TrackerFileUnit u{};
    EXPECT_TRUE(FromWireName(unit, &u)) << unit;
    r.unit = u;
  }
  return r;
}

// The reasons recorded for `field`.
std::vector<std::string> Reasons(const Problems& problems, const std::string& field) {
  std::vector<std::string> out;
  for (const FieldViolation& v : problems.list()) {
    if (v.field == field) out.push_back(v.reason);
  }
  return out;
}

TEST(TrackerFilesTest, SaRowsWithCommasAndTheFilesUnit) {
  const std::string text =
      "// Point export\r\n"
      "// Units: Millimeters\r\n"
      "\r\n"
      "A,Robot,P001,1500.25,-20.5,300\r\n"
      "A,Robot,P001,1500.5,-20.25,300.125\r\n"
      "A,Robot,P002,1e3,0,-4.5e2\r\n";
  Problems problems;
  const std::vector<TrackerPoint> points = ReadTrackerPoints(Request("sa", text), &problems);
  ASSERT_TRUE(problems.empty()) << problems.list().front().reason;
  ASSERT_EQ(points.size(), 3u);
  EXPECT_EQ(points[0].line, 4);
  EXPECT_EQ(points[0].target, "P001");
  EXPECT_EQ(points[1].position_mm, Eigen::Vector3d(1500.5, -20.25, 300.125));
  EXPECT_EQ(points[2].line, 6);
  EXPECT_EQ(points[2].position_mm, Eigen::Vector3d(1000, 0, -450));
}

TEST(TrackerFilesTest, SaRowsWithWhiteSpaceInMetresAndInches) {
  const std::string rows = "A  G  T1   1.5\t-0.25  0.125\nA G T2 2 0 1\n";
  Problems problems;
  const auto metres = ReadTrackerPoints(Request("sa", "//Units = m\n" + rows), &problems);
  ASSERT_TRUE(problems.empty());
  EXPECT_EQ(metres[0].position_mm, Eigen::Vector3d(1500, -250, 125));
  // The request's unit where the file declares none; 1 in = 25.4 mm exactly.
  const auto inches = ReadTrackerPoints(Request("sa", rows, "in"), &problems);
  ASSERT_TRUE(problems.empty());
  EXPECT_EQ(inches[1].position_mm, Eigen::Vector3d(50.8, 0, 25.4));
}

TEST(TrackerFilesTest, SaUnitsMustBeKnownDeclaredAndAgree) {
  {
    Problems problems;
    ReadTrackerPoints(Request("sa", "A G T1 1 2 3\n"), &problems);
    EXPECT_EQ(Reasons(problems, "unit").size(), 1u);
  }
  {
    Problems problems;
    ReadTrackerPoints(Request("sa", "// Units: mm\nA G T1 1 2 3\n", "m"), &problems);
    ASSERT_EQ(Reasons(problems, "unit").size(), 1u);
    EXPECT_EQ(Reasons(problems, "unit")[0], "the request says m, the file declares mm (line 1)");
  }
  {
    Problems problems;
    ReadTrackerPoints(Request("sa", "// Units: feet\nA G T1 1 2 3\n"), &problems);
    ASSERT_FALSE(Reasons(problems, "text").empty());
    EXPECT_EQ(Reasons(problems, "text")[0], "line 1: unknown unit 'feet' (mm, m or in)");
  }
  {
    Problems problems;
    ReadTrackerPoints(Request("sa", "// Units: mm\n// UNITS: m\nA G T1 1 2 3\n"), &problems);
    ASSERT_FALSE(Reasons(problems, "text").empty());
    EXPECT_EQ(Reasons(problems, "text")[0], "line 2: declares m, line 1 declared mm");
  }
}

TEST(TrackerFilesTest, EveryBadSaLineIsNamedAndNoPointOfItKept) {
  const std::string text =
      "// Units: m\n"
      "A,G,P1,1,2,3\n"
      "A,G,P2,1,2\n"
      "A,G,P3,1,x,3\n"
      "A,G,P4,1,2,nan\n"
      "A,G,P5,2000,0,0\n"
      "A,G,P6,1,2,3,4\n";
  Problems problems;
  const auto points = ReadTrackerPoints(Request("sa", text), &problems);
  const std::vector<std::string> reasons = Reasons(problems, "text");
  ASSERT_EQ(reasons.size(), 5u);
  EXPECT_EQ(reasons[0], "line 3: expected 6 fields (collection group target x y z), got 5");
  EXPECT_EQ(reasons[1], "line 4: y 'x' is not a finite number");
  EXPECT_EQ(reasons[2], "line 5: z 'nan' is not a finite number");
  EXPECT_EQ(reasons[3], "line 7: expected 6 fields (collection group target x y z), got 7");
  // Checked after the unit: 2000 m.
  EXPECT_EQ(reasons[4], "line 6: the point is 2000 m from the tracker, beyond 1 km: a wrong unit or column?");
  ASSERT_EQ(points.size(), 1u);
  EXPECT_EQ(points[0].target, "P1");
}

TEST(TrackerFilesTest, CsvWithItsColumnsDelimiterAndQuotes) {
  ImportMeasurementsRequest r = Request("csv",
                                        "\xEF\xBB\xBF"
                                        "Name;Nest;X [in];Y [in];Z [in];RMS\n"
                                        "\"P;1\";smr1;1;2;3;0.001\n"
                                        "\"P \"\"2\"\"\";smr2; -1 ;0;10;0.002\n",
                                        "in");
  r.columns = {"name", "X [in]", "y [IN]", "Z [in]", "Nest"};
  Problems problems;
  const auto points = ReadTrackerPoints(r, &problems);
  ASSERT_TRUE(problems.empty()) << problems.list().front().field << " " << problems.list().front().reason;
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points[0].target, "P;1");
  EXPECT_EQ(points[0].reflector, "smr1");
  EXPECT_EQ(points[0].position_mm, Eigen::Vector3d(1, 2, 3) * 25.4);
  EXPECT_EQ(points[1].target, "P \"2\"");
  EXPECT_EQ(points[1].line, 3);
  EXPECT_EQ(points[1].position_mm, Eigen::Vector3d(-1, 0, 10) * 25.4);
}

TEST(TrackerFilesTest, CsvProblemsNameTheColumnOrTheLine) {
  {
    Problems problems;
    ReadTrackerPoints(Request("csv", "target,x,y\nP1,1,2\n"), &problems);
    EXPECT_EQ(Reasons(problems, "unit").size(), 1u);  // csv needs a unit
    ASSERT_EQ(Reasons(problems, "columns.z").size(), 1u);
    EXPECT_EQ(Reasons(problems, "columns.z")[0], "no column 'z' in the header (line 1: 'target,x,y')");
  }
  {
    Problems problems;
    ReadTrackerPoints(Request("csv", "target,x,y,z\nP1,1,2,3\n\"P2,1,2,3\nP3,1,2\nP4,1,2,3e999\n", "mm"), &problems);
    const auto reasons = Reasons(problems, "text");
    ASSERT_EQ(reasons.size(), 3u);
    EXPECT_EQ(reasons[0], "line 3: a quote is not closed");
    EXPECT_EQ(reasons[1], "line 4: no value in column 'z' (3 fields)");
    EXPECT_EQ(reasons[2], "line 5: column 'z': '3e999' is not a finite number");
  }
  {
    Problems problems;
    ReadTrackerPoints(Request("csv", "target x y z\n", "mm"), &problems);
    EXPECT_EQ(Reasons(problems, "text")[0], "line 1: the header has no ',', ';' or tab between column names");
  }
  {
    Problems problems;
    ReadTrackerPoints(Request("csv", "target,x,y,z\n\n", "mm"), &problems);
    EXPECT_EQ(Reasons(problems, "text")[0], "no points");
  }
}

// What real exports do: lone CR line ends, comment lines that start with "Unit", units with a note after them,
// quoted headers holding the other delimiter, tiny and huge numbers; hex is no coordinate.
TEST(TrackerFilesTest, ExportsAsTheyComeOutOfTrackerPrograms) {
  {
    Problems problems;
    const auto points = ReadTrackerPoints(
        Request("sa", "// Unitless comment\r// Units: Millimeters (mm)\r// Unit test 12:30 ok\rA G P1 1 2 3\rA G P2 4e-320 0 1\r"),
        &problems);
    ASSERT_TRUE(problems.empty()) << problems.list().front().reason;
    ASSERT_EQ(points.size(), 2u);
    EXPECT_EQ(points[0].line, 4);
    EXPECT_EQ(points[1].position_mm, Eigen::Vector3d(4e-320, 0, 1));
  }
  {
    Problems problems;
    ReadTrackerPoints(Request("sa", "// Units: Meters, Degrees\nA G P1 0x10 2 3\nA G P2 1e308 1e308 1\n"
                                    "A G P3 1e305 1e305 1\n"),
                      &problems);
    const auto reasons = Reasons(problems, "text");
    ASSERT_EQ(reasons.size(), 3u);
    EXPECT_EQ(reasons[0], "line 2: x '0x10' is not a finite number");
    EXPECT_EQ(reasons[1], "line 3: the point is too far from the tracker for a double: a wrong unit or column?");
    EXPECT_EQ(reasons[2], "line 4: the point is 1.41421e+305 m from the tracker, beyond 1 km: a wrong unit or column?");
  }
  {
    ImportMeasurementsRequest r = Request("csv", "Punkt;\"X, mm\";\"Y, mm\";\"Z, mm\"\nP1;1;2;3\n", "mm");
    r.columns = {"Punkt", "X, mm", "Y, mm", "Z, mm", ""};
    Problems problems;
    const auto points = ReadTrackerPoints(r, &problems);
    ASSERT_TRUE(problems.empty()) << problems.list().front().field << ": " << problems.list().front().reason;
    EXPECT_EQ(points[0].position_mm, Eigen::Vector3d(1, 2, 3));
  }
  {
    // A 4 MiB line of commas is one bad line, not four million fields.
    Problems problems;
    ReadTrackerPoints(Request("sa", "// Units: mm\n" + std::string(1 << 22, ',')), &problems);
    EXPECT_EQ(Reasons(problems, "text")[0], "line 2: expected 6 fields (collection group target x y z), got 7");
  }
}

TEST(TrackerFilesTest, TargetNamesEndInTheirConfigurationNumber) {
  EXPECT_EQ(ConfigurationOfTarget("P007"), 6);
  EXPECT_EQ(ConfigurationOfTarget("12"), 11);
  EXPECT_EQ(ConfigurationOfTarget("pose_3"), 2);
  EXPECT_EQ(ConfigurationOfTarget("A"), -1);
  EXPECT_EQ(ConfigurationOfTarget("P0"), -1);
  EXPECT_EQ(ConfigurationOfTarget(""), -1);
  EXPECT_EQ(ConfigurationOfTarget("P1234567890"), -1);
  EXPECT_EQ(ConfigurationOfTarget("P000000000000001"), 0);
  // Two numbers: a shot or a decimal may follow the configuration.
  EXPECT_EQ(ConfigurationOfTarget("P001_2"), -2);
  EXPECT_EQ(ConfigurationOfTarget("P7.8"), -2);
  EXPECT_EQ(ConfigurationOfTarget("Pose8_shot2"), -2);
}

std::vector<TrackerPoint> Points(const std::vector<std::string>& targets) {
  std::vector<TrackerPoint> points;
  for (std::size_t k = 0; k < targets.size(); ++k) {
    points.push_back({static_cast<int>(k) + 2, targets[k], "", Eigen::Vector3d(k, 0, 1)});
  }
  return points;
}

TEST(TrackerFilesTest, PointsTakeTheJointsOfTheirConfiguration) {
  const std::vector<std::vector<double>> configurations = {{10, 20}, {30, 40}, {50, 60}};
  ImportMeasurementsRequest r = Request("sa", "-");
  r.role = MeasurementRole::kValidation;
  Problems problems;
  const MeasurementBatchRequest by_name =
      MatchToConfigurations(r, Points({"P3", "P1", "P1", "P2"}), configurations, &problems);
  ASSERT_TRUE(problems.empty());
  ASSERT_EQ(by_name.measurements.size(), 4u);
  EXPECT_EQ(by_name.role, MeasurementRole::kValidation);
  EXPECT_EQ(by_name.request_id, "t");
  EXPECT_EQ(by_name.measurements[0].joints, configurations[2]);
  EXPECT_EQ(by_name.measurements[2].joints, configurations[0]);
  EXPECT_EQ(by_name.measurements[3].pose.position_mm, (std::array<double, 3>{3, 0, 1}));
  EXPECT_FALSE(by_name.measurements[3].pose.has_orientation);

  r.match = TrackerFileMatch::kOrder;
  const MeasurementBatchRequest by_order =
      MatchToConfigurations(r, Points({"a", "b", "c", "d", "e", "f"}), configurations, &problems);
  ASSERT_TRUE(problems.empty());
  EXPECT_EQ(by_order.measurements[1].joints, configurations[0]);
  EXPECT_EQ(by_order.measurements[2].joints, configurations[1]);
  EXPECT_EQ(by_order.measurements[5].joints, configurations[2]);
}

TEST(TrackerFilesTest, MatchingProblemsNameTheLine) {
  const std::vector<std::vector<double>> configurations = {{10, 20}, {30, 40}};
  ImportMeasurementsRequest r = Request("sa", "-");
  Problems problems;
  MatchToConfigurations(r, Points({"P1", "P3", "Q", "P1_2"}), configurations, &problems);
  const auto reasons = Reasons(problems, "text");
  ASSERT_EQ(reasons.size(), 3u);
  EXPECT_EQ(reasons[2], "line 5: target 'P1_2' holds more than one number: name a point by its configuration "
                        "alone (P007), or match by order");
  EXPECT_EQ(reasons[0], "line 3: target 'P3' is configuration 3; the plan has 2");
  EXPECT_EQ(reasons[1], "line 4: target 'Q' has no configuration number (its trailing digits, 1...2)");

  r.match = TrackerFileMatch::kOrder;
  Problems order;
  const auto batch = MatchToConfigurations(r, Points({"a", "b", "c"}), configurations, &order);
  EXPECT_TRUE(batch.measurements.empty());
  ASSERT_EQ(Reasons(order, "text").size(), 1u);
  r.shots_per_configuration = 2;
  Problems shots;
  MatchToConfigurations(r, Points({"a", "b", "c"}), configurations, &shots);
  EXPECT_EQ(Reasons(shots, "text")[0], "3 points for the plan's 2 configurations at 2 shots each (match \"order\")");
}

// The fields an import request is refused for, in order (none: accepted).
std::vector<std::string> RefusedFields(const json& body) {
  std::vector<std::string> out;
  try {
    ParseImportMeasurementsRequest(body);
  } catch (const ApiError& e) {
    for (const FieldViolation& v : e.details()) out.push_back(v.field);
  }
  return out;
}

TEST(TrackerFilesTest, RequestFieldsAreChecked) {
  const auto fields = RefusedFields;
  EXPECT_EQ(fields({{"request_id", "a"}, {"format", "sa"}, {"text", "A G P1 1 2 3"}}), std::vector<std::string>{});
  EXPECT_EQ(fields({{"request_id", "a"}, {"format", "dxf"}, {"text", "x"}}), std::vector<std::string>{"format"});
  // The table's rules: the format is required, and the idempotency key is a batch's (no control characters).
  EXPECT_EQ(fields({{"request_id", "a"}, {"text", "x"}}), std::vector<std::string>{"format"});
  EXPECT_EQ(fields({{"request_id", "a\x01"}, {"format", "sa"}, {"text", "x"}}), std::vector<std::string>{"request_id"});
  EXPECT_EQ(fields({{"request_id", "a"}, {"format", "sa"}, {"text", "x"}, {"plan", std::string(65, 'p')}}),
            std::vector<std::string>{"plan"});
  EXPECT_EQ(fields({{"request_id", "a"}, {"format", "sa"}, {"text", " \n "}}), std::vector<std::string>{"text"});
  EXPECT_EQ(fields({{"request_id", "a"}, {"format", "sa"}, {"text", "x"}, {"unit", "ft"}}),
            std::vector<std::string>{"unit"});
  EXPECT_EQ(fields({{"request_id", "a"}, {"format", "sa"}, {"text", "x"}, {"shots_per_configuration", 2}}),
            std::vector<std::string>{"shots_per_configuration"});
  EXPECT_EQ(fields({{"request_id", "a"}, {"format", "sa"}, {"text", "x"}, {"columns", {{"x", "X"}}}}),
            std::vector<std::string>{"columns"});
  EXPECT_EQ(fields({{"request_id", "a"}, {"format", "csv"}, {"text", "x"}, {"columns", {{"x", ""}, {"w", 1}}}}),
            (std::vector<std::string>{"columns.x", "columns.w"}));
  EXPECT_EQ(fields({{"format", "csv"}, {"text", "x"}, {"extra", 1}}), (std::vector<std::string>{"request_id", "extra"}));
  // The request survives its own JSON form.
  ImportMeasurementsRequest r = Request("csv", "target,x,y,z\n", "m");
  r.plan = "p1";
  r.match = TrackerFileMatch::kOrder;
  r.shots_per_configuration = 3;
  r.columns.reflector = "Nest";
  const ImportMeasurementsRequest back = ParseImportMeasurementsRequest(json(r));
  EXPECT_EQ(json(back), json(r));
}


// Euler angles against rotations worked by hand: R1(a) R2(b) R3(c) about the turning axes (intrinsic), R3 R2 R1
// about the fixed ones (extrinsic).
TEST(TrackerFilesTest, EulerAnglesAgainstHandWorkedRotations) {
  const double q = M_PI / 2.0;
  // Rx(90) takes y to z.
  EXPECT_TRUE(EulerToRotation("XYZ", true, q, 0, 0).isApprox(
      (Eigen::Matrix3d() << 1, 0, 0, 0, 0, -1, 0, 1, 0).finished(), 1e-15));
  // Intrinsic X then Y, 90 deg each: Rx(90) Ry(90) takes x to Rx(90) (0, 0, -1) = (0, 1, 0).
  EXPECT_TRUE((EulerToRotation("XYZ", true, q, q, 0) * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-15));
  // Extrinsic X then Y: Ry(90) Rx(90) takes x to Ry(90) (1, 0, 0) = (0, 0, -1).
  EXPECT_TRUE((EulerToRotation("XYZ", false, q, q, 0) * Eigen::Vector3d::UnitX())
                  .isApprox(-Eigen::Vector3d::UnitZ(), 1e-15));
  // Intrinsic XYZ (a, b, c) is extrinsic ZYX (c, b, a); lower case axes read as upper case; ZXZ is a sequence.
  const Eigen::Matrix3d r = EulerToRotation("xyz", true, 0.3, -0.7, 1.9);
  EXPECT_TRUE(r.isApprox(EulerToRotation("ZYX", false, 1.9, -0.7, 0.3), 1e-14));
  EXPECT_TRUE(r.isApprox(Eigen::Matrix3d(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()) *
                                         Eigen::AngleAxisd(-0.7, Eigen::Vector3d::UnitY()) *
                                         Eigen::AngleAxisd(1.9, Eigen::Vector3d::UnitZ())),
                         1e-14));
  EXPECT_NO_THROW(EulerToRotation("ZXZ", true, 0.1, 0.2, 0.3));
  for (const char* bad : {"XXY", "XY", "XYW", "XYZX", ""}) {
    EXPECT_THROW(EulerToRotation(bad, true, 0, 0, 0), std::invalid_argument) << bad;
  }
}

// An export with joints, as the IPA files are: ';' between fields, decimal commas, CRLF, joints in rad, the
// probe's orientation as intrinsic X-Y-Z Euler angles in degrees.
const char* const kEuropeanExport =
    "Stamp;j1;j2;x;y;z;rx;ry;rz;temp\r\n"
    "1;0,5;-1,25;383,5;-3240,25;201,75;-90,5;-20,25;-90;21,8\r\n"
    "2;0,5;-1,25;383,75;-3240;202;-90,5;-20,25;-90;21,8\r\n"
    "3;1;0;1000;2000;3000;0;0;45;21,9\r\n";

ImportMeasurementsRequest EuropeanRequest() {
  ImportMeasurementsRequest r = Request("csv", kEuropeanExport, "mm");
  r.decimal = TrackerFileDecimal::kComma;
  r.joints = {{"j1", "j2"}, AngleUnit::kRad};
  r.orientation = {.representation = OrientationRepresentation::kEuler,
                   .columns = {"rx", "ry", "rz"},
                   .sequence = "XYZ",
                   .convention = EulerConvention::kIntrinsic,
                   .unit = AngleUnit::kDeg};
  return r;
}

TEST(TrackerFilesTest, AnExportWithJointsAndEulerAnglesInEuropeanCsv) {
  Problems problems;
  const std::vector<TrackerPoint> points = ReadTrackerPoints(EuropeanRequest(), &problems);
  ASSERT_TRUE(problems.empty()) << problems.list().front().field << ": " << problems.list().front().reason;
  ASSERT_EQ(points.size(), 3u);
  EXPECT_EQ(points[0].line, 2);
  EXPECT_EQ(points[0].position_mm, Eigen::Vector3d(383.5, -3240.25, 201.75));
  ASSERT_EQ(points[0].joints_deg.size(), 2u);
  EXPECT_NEAR(points[0].joints_deg[0], 0.5 * 180.0 / M_PI, 1e-12);
  EXPECT_NEAR(points[0].joints_deg[1], -1.25 * 180.0 / M_PI, 1e-12);
  ASSERT_TRUE(points[0].has_orientation);
  const double d = M_PI / 180.0;
  const Eigen::Quaterniond q(points[0].quaternion[0], points[0].quaternion[1], points[0].quaternion[2],
                             points[0].quaternion[3]);
  EXPECT_TRUE(q.toRotationMatrix().isApprox(EulerToRotation("XYZ", true, -90.5 * d, -20.25 * d, -90 * d), 1e-12));
  EXPECT_GE(points[0].quaternion[0], 0.0);  // one sign per rotation
  // 45 deg about z: (cos 22.5, 0, 0, sin 22.5).
  EXPECT_NEAR(points[2].quaternion[0], std::cos(M_PI / 8), 1e-12);
  EXPECT_NEAR(points[2].quaternion[3], std::sin(M_PI / 8), 1e-12);

  // The batch: every row at its own joints, with its orientation, nothing matched to a plan.
  const MeasurementBatchRequest batch = PointsWithJoints(EuropeanRequest(), points, &problems);
  ASSERT_TRUE(problems.empty());
  ASSERT_EQ(batch.measurements.size(), 3u);
  EXPECT_EQ(batch.measurements[1].joints, points[1].joints_deg);
  EXPECT_TRUE(batch.measurements[1].pose.has_orientation);
  EXPECT_EQ(batch.measurements[1].pose.position_mm, (std::array<double, 3>{383.75, -3240, 202}));

  // The same file with quaternions, scalar last, in degrees for the joints.
  ImportMeasurementsRequest quaternions = Request("csv",
                                                  "a,b,x,y,z,qx,qy,qz,qw\n"
                                                  "10,20,1,2,3,0,0,0.7071067811865476,0.7071067811865476\n",
                                                  "m");
  quaternions.joints = {{"a", "b"}, AngleUnit::kDeg};
  quaternions.orientation = {.representation = OrientationRepresentation::kQuaternion,
                             .columns = {"qx", "qy", "qz", "qw"},
                             .order = QuaternionOrder::kXyzw};
  const auto q_points = ReadTrackerPoints(quaternions, &problems);
  ASSERT_TRUE(problems.empty());
  EXPECT_EQ(q_points[0].joints_deg, (std::vector<double>{10, 20}));
  EXPECT_EQ(q_points[0].position_mm, Eigen::Vector3d(1000, 2000, 3000));
  EXPECT_NEAR(q_points[0].quaternion[0], std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(q_points[0].quaternion[3], std::sqrt(0.5), 1e-15);
}

TEST(TrackerFilesTest, BadValuesOfAnExportWithJointsAreNamedByLineAndColumn) {
  // A decimal-comma file read with decimal points: the first bad field says what to give.
  ImportMeasurementsRequest points_request = EuropeanRequest();
  points_request.decimal = TrackerFileDecimal::kPoint;
  Problems problems;
  EXPECT_EQ(ReadTrackerPoints(points_request, &problems).size(), 1u);  // line 4 has no decimal commas
  ASSERT_FALSE(problems.empty());
  EXPECT_EQ(problems.list().front().reason,
            "line 2: column 'x': '383,5' is not a finite number (decimal commas: give decimal \",\")");

  ImportMeasurementsRequest r = EuropeanRequest();
  r.text = "Stamp;j1;j2;x;y;z;rx;ry;rz\n1;0,5;abc;1;2;3;0;0;0\n2;0,5;0;1;2;3;0;0;0\n";
  Problems one;
  const auto kept = ReadTrackerPoints(r, &one);
  ASSERT_EQ(Reasons(one, "text").size(), 1u);
  EXPECT_EQ(Reasons(one, "text")[0], "line 2: column 'j2': 'abc' is not a finite number");
  EXPECT_EQ(kept.size(), 1u);  // the service stores nothing when any line is bad (it throws on problems)

  // A column the header lacks is named by its field.
  r = EuropeanRequest();
  r.joints.columns = {"j1", "j9"};
  Problems missing;
  ReadTrackerPoints(r, &missing);
  ASSERT_EQ(Reasons(missing, "joints.columns[1]").size(), 1u);
  EXPECT_EQ(Reasons(missing, "joints.columns[1]")[0].substr(0, 34), "no column 'j9' in the header (line");

  // A quaternion that is not one.
  ImportMeasurementsRequest q = Request("csv", "a,x,y,z,qw,qx,qy,qz\n1,0,0,0,1,1,0,0\n", "mm");
  q.joints = {{"a"}, AngleUnit::kDeg};
  q.orientation = {.representation = OrientationRepresentation::kQuaternion,
                   .columns = {"qw", "qx", "qy", "qz"},
                   .order = QuaternionOrder::kWxyz};
  Problems norm;
  ReadTrackerPoints(q, &norm);
  ASSERT_EQ(Reasons(norm, "text").size(), 1u);
  EXPECT_EQ(Reasons(norm, "text")[0],
            "line 2: the quaternion's norm is 1.41421, not 1: are the columns and their order right?");

  // A delimiter that splits nothing.
  ImportMeasurementsRequest tab = EuropeanRequest();
  tab.delimiter = TrackerFileDelimiter::kTab;
  Problems header;
  ReadTrackerPoints(tab, &header);
  ASSERT_EQ(Reasons(header, "text").size(), 1u);
  EXPECT_EQ(Reasons(header, "text")[0], "line 1: the header has 1 column(s) at delimiter '?': is the delimiter right?");
}

TEST(TrackerFilesTest, RequestFieldsOfAnExportWithJointsAreChecked) {
  const auto fields = RefusedFields;
  const json base = {{"request_id", "a"}, {"format", "csv"}, {"text", "x"}, {"unit", "mm"}};
  const json joints = {{"columns", {"j1", "j2"}}, {"unit", "rad"}};
  const json euler = {{"representation", "euler"}, {"columns", {"a", "b", "c"}}, {"sequence", "XYZ"},
                      {"convention", "intrinsic"}, {"unit", "deg"}};
  json ok = base;
  ok["joints"] = joints;
  ok["orientation"] = euler;
  ok["decimal"] = ",";
  ok["delimiter"] = ";";
  EXPECT_EQ(fields(ok), std::vector<std::string>{});
  json with_plan = ok;
  with_plan["plan"] = "p";
  with_plan["match"] = "order";
  EXPECT_EQ(fields(with_plan), (std::vector<std::string>{"plan", "match"}));
  json no_joints = base;
  no_joints["orientation"] = euler;
  EXPECT_EQ(fields(no_joints), std::vector<std::string>{"orientation"});
  json bad = ok;
  bad["joints"] = {{"columns", {"j1", "j1"}}};
  bad["orientation"] = {{"representation", "euler"}, {"columns", {"a", "b"}}, {"sequence", "XXY"},
                        {"convention", "inward"}, {"unit", "grad"}};
  bad["delimiter"] = ",";
  EXPECT_EQ(fields(bad), (std::vector<std::string>{"decimal", "joints.columns[1]", "joints.unit", "orientation.columns",
                                                   "orientation.sequence", "orientation.convention",
                                                   "orientation.unit"}));
  json quaternion = ok;
  quaternion["orientation"] = {{"representation", "quaternion"}, {"columns", {"w", "x", "y", "z"}}};
  EXPECT_EQ(fields(quaternion), std::vector<std::string>{"orientation.order"});
  json sa = ok;
  sa["format"] = "sa";
  EXPECT_EQ(fields(sa), (std::vector<std::string>{"delimiter", "joints"}));
  // The request survives its own JSON form.
  const ImportMeasurementsRequest r = EuropeanRequest();
  EXPECT_EQ(json(ParseImportMeasurementsRequest(json(r))), json(r));
}

// The data rows an import's `rows` counts: lines ended by LF, CRLF or a lone CR, blank ones and the header (the
// first line that is not blank) left out; a split of them is a partition, the same for the same seed.
TEST(TrackerFilesTest, DataRowLinesAndTheirSplit) {
  const std::vector<int> data = DataRowLines("\n x;y;z \r\n\r\n1;2;3\n4;5;6\r7;8;9\r\n \t\n10;11;12");
  EXPECT_EQ(data, (std::vector<int>{4, 5, 6, 8}));
  const DataRowSplit split = SplitDataRows(data, 3, 7);
  ASSERT_EQ(split.calibration.size(), 3u);
  ASSERT_EQ(split.validation.size(), 1u);
  std::vector<int> all = split.calibration;
  all.insert(all.end(), split.validation.begin(), split.validation.end());
  std::sort(all.begin(), all.end());
  EXPECT_EQ(all, data);
  EXPECT_TRUE(std::is_sorted(split.calibration.begin(), split.calibration.end()));
  const DataRowSplit again = SplitDataRows(data, 3, 7);
  EXPECT_EQ(again.calibration, split.calibration);
  EXPECT_EQ(SplitDataRows(data, 10, 7).calibration, data);  // at most all
}

}  // namespace
}  // namespace robocal::api
