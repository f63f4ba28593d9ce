// Field tables: every kind of row writes and reads what its comment in wire.h says, and the shapes whose keys
// depend on their form (a target's kind, a joint's convention, an operation's kind, an import's format) write
// exactly the keys of their form.
#include <gtest/gtest.h>

#include "robocal/api/calibration.h"
#include "robocal/api/json_reader.h"
#include "robocal/api/operations.h"
#include "robocal/api/robots.h"
#include "robocal/api/stored.h"
#include "robocal/api/tracker_files.h"

namespace robocal::api {

// A shape with a row of every kind (named, not in an anonymous namespace: the table's to_json is found by
// argument-dependent lookup in robocal::api).
struct FieldTableProbe {
  int count = 0;
  std::string note = "default";
  double weight = 2.5;
  bool newer_switch = true;
  std::string id;
  std::optional<std::string> server_note;
  std::string form = "a";
  int only_a = 7;
  int only_b = 8;
  int extra_b = 0;  // a key of form b alone
  int twice = 0;  // written doubled, read halved
  int inner = 0;  // under "group"
};
template <>
struct WireFields<FieldTableProbe> {
  using S = FieldTableProbe;
  static constexpr auto fields = std::make_tuple(
      Field{"count", &S::count},
      Field{"note", &S::note, Presence::kOmitEmpty},
      Field{"weight", &S::weight, Presence::kOptionalOnRead},
      Field{"newer_switch", &S::newer_switch, Presence::kAbsentIsEmpty},
      Field{"id", &S::id, Presence::kSetByServer},
      Field{"server_note", &S::server_note, Presence::kServerOnly},
      Field{"form", &S::form},
      Field{"only", &S::only_a}.When(+[](const S& s) { return s.form == "a"; }),
      Field{"only", &S::only_b}.When(+[](const S& s) { return s.form == "b"; }),
      Field{"extra_b", &S::extra_b, Presence::kOmitEmpty}.When(+[](const S& s) { return s.form == "b"; }),
      Computed<S>{"twice",
                  +[](const S& s, nlohmann::json* value) {
                    *value = 2 * s.twice;
                    return s.twice != 0;
                  },
                  +[](const nlohmann::json* value, const std::string& path, S* s) {
                    if (value == nullptr) return;
                    int doubled = 0;
                    ReadWire(*value, path, &doubled);
                    if (doubled % 2 != 0) detail::ThrowWire(path, "odd");
                    s->twice = doubled / 2;
                  }},
      Nested{"group", std::make_tuple(Field{"inner", &S::inner})});
  static void Check(const S& s) {
    if (s.count < 0) throw WireError("count", "negative");
  }
};

namespace {

using nlohmann::json;

// The path and reason of the WireError reading `j` as T throws ("" if none).
template <typename T>
std::string ReadError(const json& j) {
  try {
    T value;
    ReadFields(j, &value);
  } catch (const WireError& e) {
    return e.path() + ": " + e.reason();
  }
  return "";
}

std::vector<std::string> Keys(const std::vector<const char*>& names) { return {names.begin(), names.end()}; }

TEST(FieldTableTest, WritesEachPresenceAsDocumented) {
  FieldTableProbe p;
  p.count = 3;
  p.note = "";
  p.weight = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(json(p), json::parse(R"({"count": 3, "weight": null, "newer_switch": true, "form": "a", "only": 7,
                                     "group": {"inner": 0}})"));
  p.note = "n";
  p.id = "x1";
  p.server_note = "kept";
  p.form = "b";
  p.twice = 5;
  p.inner = 4;
  EXPECT_EQ(json(p), json::parse(R"({"count": 3, "note": "n", "weight": null, "newer_switch": true, "id": "x1",
                                     "server_note": "kept", "form": "b", "only": 8, "twice": 10,
                                     "group": {"inner": 4}})"));
}

TEST(FieldTableTest, ReadsEachPresenceAsDocumented) {
  const FieldTableProbe p = json::parse(R"({"count": 1, "id": "x", "form": "b", "only": 9, "twice": 6,
                                            "group": {"inner": 2}})")
                                .get<FieldTableProbe>();
  EXPECT_EQ(p.note, "default");     // kOmitEmpty absent: the member's default
  EXPECT_EQ(p.weight, 2.5);         // kOptionalOnRead absent: the member's default
  EXPECT_FALSE(p.newer_switch);     // kAbsentIsEmpty absent: false, not the member's default true
  EXPECT_EQ(p.only_a, 7);           // the other form's row is not read
  EXPECT_EQ(p.only_b, 9);
  EXPECT_EQ(p.twice, 3);
  EXPECT_EQ(p.inner, 2);
  EXPECT_FALSE(p.server_note.has_value());
}

TEST(FieldTableTest, ReadingNamesTheMemberAtFault) {
  const json good = json::parse(R"({"count": 1, "id": "x", "form": "a", "only": 1, "group": {"inner": 2}})");
  EXPECT_EQ(ReadError<FieldTableProbe>(good), "");
  json j = good;
  j.erase("count");
  EXPECT_EQ(ReadError<FieldTableProbe>(j), "count: required");
  j = good;
  j.erase("id");  // kSetByServer: the resource always has it
  EXPECT_EQ(ReadError<FieldTableProbe>(j), "id: required");
  j = good;
  j.erase("only");  // required in its form
  EXPECT_EQ(ReadError<FieldTableProbe>(j), "only: required");
  j = good;
  j["twice"] = 3;
  EXPECT_EQ(ReadError<FieldTableProbe>(j), "twice: odd");
  j = good;
  j["group"] = json::object();
  EXPECT_EQ(ReadError<FieldTableProbe>(j), "group.inner: required");
  j = good;
  j["count"] = -1;
  EXPECT_EQ(ReadError<FieldTableProbe>(j), "count: negative");  // the table's Check
}

TEST(FieldTableTest, RequestKeysLeaveOutTheServersAndRepeatNone) {
  EXPECT_EQ(Keys(WireFieldNames<FieldTableProbe>()),
            (std::vector<std::string>{"count", "note", "weight", "newer_switch", "id", "form", "only", "extra_b",
                                      "twice", "group"}));
  FieldTableProbe b;
  b.form = "b";
  EXPECT_EQ(Keys(WireFieldNamesOf(b)), Keys(WireFieldNames<FieldTableProbe>()));
  const FieldTableProbe a;  // form a: without form b's key
  EXPECT_EQ(Keys(WireFieldNamesOf(a)),
            (std::vector<std::string>{"count", "note", "weight", "newer_switch", "id", "form", "only", "twice",
                                      "group"}));
}

// ------------------------------------------------------------------------------------------------ the shapes

TEST(FieldTableTest, FitRequestModelIsAutoOrAnObject) {
  FitRequest auto_fit;
  auto_fit.model_auto = true;
  auto_fit.cross_validation = {4, 9};
  const json a = auto_fit;
  EXPECT_EQ(a["model"], "auto");
  EXPECT_EQ(a["cross_validation"], json::parse(R"({"folds": 4, "seed": 9})"));
  const FitRequest back = a.get<FitRequest>();
  EXPECT_TRUE(back.model_auto);
  EXPECT_EQ(back.cross_validation.folds, 4);
  EXPECT_EQ(back.cross_validation.seed, 9u);

  FitRequest compliant;
  compliant.model.compliance = true;
  const json c = compliant;
  EXPECT_EQ(c["model"], json::parse(R"({"compliance": true, "joint_harmonics": 0})"));
  EXPECT_FALSE(c.contains("cross_validation"));

  json no_cv = a;
  no_cv.erase("cross_validation");
  EXPECT_EQ(ReadError<FitRequest>(no_cv), "cross_validation: required");
}

TEST(FieldTableTest, FitRequestStoredBeforeItsSwitchesReadsThemOff) {
  // A fit request stored before the robust fit, the model error's estimate and joint models: those were off.
  const FitRequest old =
      json::parse(R"({"parameters": [], "register_base": true, "max_iterations": 50, "async": false})")
          .get<FitRequest>();
  EXPECT_FALSE(old.reject_outliers);
  EXPECT_FALSE(old.estimate_model_error);
  EXPECT_FALSE(old.model_auto);
  EXPECT_FALSE(old.model.compliance);
  EXPECT_EQ(old.scope, FitScope::kAll);
  EXPECT_EQ(old.max_iterations, 50);
}

TEST(FieldTableTest, CompensationTargetWritesTheKeysOfItsKind) {
  CompensationTargetWire joints;
  joints.joints = {1, 2, 3};
  EXPECT_EQ(json(joints), json::parse(R"({"joints": [1.0, 2.0, 3.0]})"));

  CompensationTargetWire pose;
  pose.pose = PoseWire{};
  pose.frame = TargetFrame::kBase;
  EXPECT_EQ(json(pose),
            json::parse(R"({"pose": {"position_mm": [0.0, 0.0, 0.0], "quaternion": [1.0, 0.0, 0.0, 0.0]},
                            "frame": "base"})"));
  pose.configuration.elbow = -1;
  pose.start_joints = {0, 0};
  const json j = pose;
  EXPECT_EQ(j["configuration"], json::parse(R"({"elbow": "down"})"));
  const CompensationTargetWire back = j.get<CompensationTargetWire>();
  EXPECT_EQ(back.configuration, pose.configuration);
  EXPECT_EQ(back.frame, TargetFrame::kBase);
  EXPECT_TRUE(back.joints.empty());

  json bad = j;
  bad["configuration"]["wrist"] = "sideways";
  EXPECT_EQ(ReadError<CompensationTargetWire>(bad), "configuration.wrist: not a wrist flag: \"sideways\"");
  EXPECT_EQ(ReadError<CompensationTargetWire>(json::object()), "joints: required");
}

TEST(FieldTableTest, PosesWriteTheirOrientationWhenTheyHaveOne) {
  PoseWire point;
  point.position_mm = {1, 2, 3};
  point.has_orientation = false;
  EXPECT_EQ(json(point), json::parse(R"({"position_mm": [1.0, 2.0, 3.0]})"));
  const PoseWire read = json(point).get<PoseWire>();
  EXPECT_FALSE(read.has_orientation);

  // A result pose: rpy_deg derived beside the quaternion (90 degrees about z), the quaternion required.
  PoseResultWire turned;
  turned.quaternion = {std::sqrt(0.5), 0.0, 0.0, std::sqrt(0.5)};
  const json r = turned;
  ASSERT_TRUE(r.contains("rpy_deg"));
  EXPECT_NEAR(r["rpy_deg"][2].get<double>(), 90.0, 1e-12);
  EXPECT_NEAR(r["rpy_deg"][0].get<double>(), 0.0, 1e-12);
  EXPECT_EQ(ReadError<PoseResultWire>(json::parse(R"({"position_mm": [0, 0, 0]})")), "quaternion: required");
}

TEST(FieldTableTest, JointsWriteTheGeometryOfTheirRobotsConvention) {
  RegisterRobotRequest dh;
  dh.id = "r";
  dh.convention = GeometryConvention::kStandardDh;
  JointWire revolute;
  revolute.a_mm = 100;
  revolute.min = -90;
  revolute.max = 90;
  JointWire prismatic;
  prismatic.type = JointType::kPrismatic;
  prismatic.min = 0;
  prismatic.max = 500;
  prismatic.mass_kg = 2;
  dh.joints = {revolute, prismatic};
  const json j = dh;
  EXPECT_EQ(j["joints"][0], json::parse(R"({"type": "revolute", "a_mm": 100.0, "alpha_deg": 0.0, "d_mm": 0.0,
                                            "theta_deg": 0.0, "min_deg": -90.0, "max_deg": 90.0})"));
  EXPECT_EQ(j["joints"][1], json::parse(R"({"type": "prismatic", "a_mm": 0.0, "alpha_deg": 0.0, "d_mm": 0.0,
                                            "theta_deg": 0.0, "min_mm": 0.0, "max_mm": 500.0, "mass_kg": 2.0,
                                            "com_mm": [0.0, 0.0, 0.0]})"));
  const RegisterRobotRequest back = j.get<RegisterRobotRequest>();
  EXPECT_EQ(back.joints.at(1).max, 500.0);
  EXPECT_EQ(back.joints.at(1).mass_kg, 2.0);

  RegisterRobotRequest transform = dh;
  transform.convention = GeometryConvention::kTransform;
  transform.joints[0].xyz_mm = {0, 0, 50};
  const json t = transform;
  EXPECT_EQ(t["joints"][0], json::parse(R"({"type": "revolute", "xyz_mm": [0.0, 0.0, 50.0],
                                            "rpy_deg": [0.0, 0.0, 0.0], "min_deg": -90.0, "max_deg": 90.0})"));
  EXPECT_EQ(t.get<RegisterRobotRequest>().joints.at(0).xyz_mm[2], 50.0);
  json missing = t;
  missing["joints"][1].erase("max_mm");
  EXPECT_EQ(ReadError<RegisterRobotRequest>(missing), "joints[1].max_mm: required");

  // A preset's definition has no table; a robot's provenance is the server's, never a request's.
  RegisterRobotRequest preset;
  preset.id = "p";
  preset.from_preset = "ur5e";
  EXPECT_EQ(json(preset), json::parse(R"({"id": "p", "from_preset": "ur5e"})"));
  const std::vector<std::string> keys = Keys(WireFieldNames<RegisterRobotRequest>());
  EXPECT_EQ(std::count(keys.begin(), keys.end(), "calibrated_from"), 0);
  EXPECT_EQ(std::count(keys.begin(), keys.end(), "urdf_source"), 0);
  EXPECT_EQ(std::count(keys.begin(), keys.end(), "gravity"), 1);
}

TEST(FieldTableTest, AJointWrittenOnItsOwnHasItsRobotsKeys) {
  JointSpec spec;
  spec.xyz_mm = Eigen::Vector3d(0, 0, 10);
  spec.min = -1;
  spec.max = 1;
  const json transform = JointToWire(spec, GeometryConvention::kTransform);
  EXPECT_EQ(transform["xyz_mm"], json::parse("[0.0, 0.0, 10.0]"));
  EXPECT_FALSE(transform.contains("a_mm"));
  const json dh = JointToWire(spec, GeometryConvention::kModifiedDh);
  EXPECT_TRUE(dh.contains("a_mm"));
  EXPECT_FALSE(dh.contains("xyz_mm"));
}

TEST(FieldTableTest, TheRobotResourceStatesEveryJointsMassAndUnit) {
  Robot robot;
  robot.convention = GeometryConvention::kTransform;
  RobotJoint joint;
  joint.name = "j1";
  joint.unit = "deg";
  robot.joints = {joint};
  const json j = json(robot)["joints"][0];
  EXPECT_EQ(j, json::parse(R"({"name": "j1", "type": "revolute", "xyz_mm": [0.0, 0.0, 0.0],
                               "rpy_deg": [0.0, 0.0, 0.0], "min_deg": 0.0, "max_deg": 0.0, "mass_kg": 0.0,
                               "com_mm": [0.0, 0.0, 0.0], "compliance_deg_per_nm": 0.0,
                               "harmonics_deg": [0.0, 0.0, 0.0, 0.0], "unit": "deg"})"));
  EXPECT_FALSE(json(robot).contains("urdf"));
  robot.urdf = UrdfChainWire{"base", "tip"};
  EXPECT_EQ(json(robot)["urdf"], json::parse(R"({"base_link": "base", "tip_link": "tip"})"));
}

TEST(FieldTableTest, OperationsWriteTheRequestAndResultOfTheirKind) {
  Operation plan;
  plan.id = "op1";
  plan.kind = OperationKind::kPlan;
  plan.plan = "p1";
  const json p = plan;
  EXPECT_EQ(p["result"], json::parse(R"({"plan": "p1"})"));
  EXPECT_FALSE(p.contains("request"));
  EXPECT_EQ(p.get<Operation>().plan, std::optional<std::string>("p1"));

  Operation fit;
  fit.id = "op2";
  fit.kind = OperationKind::kFit;
  fit.fit_request = FitRequest{};
  fit.fit_request->max_iterations = 7;
  const json f = fit;
  EXPECT_EQ(f["request"]["max_iterations"], 7);
  EXPECT_FALSE(f.contains("result"));
  const Operation back = f.get<Operation>();
  ASSERT_TRUE(back.fit_request.has_value());
  EXPECT_EQ(back.fit_request->max_iterations, 7);
  EXPECT_FALSE(back.plan_request.has_value());
}

TEST(FieldTableTest, ImportsWriteTheKeysOfTheirFormat) {
  ImportMeasurementsRequest sa;
  sa.request_id = "r";
  sa.format = TrackerFileFormat::kSa;
  sa.text = "x";
  EXPECT_EQ(json(sa), json::parse(R"({"request_id": "r", "role": "calibration", "format": "sa", "text": "x",
                                      "match": "name"})"));
  ImportMeasurementsRequest csv = sa;
  csv.format = TrackerFileFormat::kCsv;
  csv.joints.columns = {"q1", "q2"};
  csv.joints.unit = AngleUnit::kDeg;
  csv.orientation.representation = OrientationRepresentation::kEuler;
  csv.orientation.columns = {"a", "b", "c"};
  csv.orientation.sequence = "ZYX";
  csv.orientation.convention = EulerConvention::kIntrinsic;
  csv.orientation.unit = AngleUnit::kDeg;
  const json j = csv;
  EXPECT_FALSE(j.contains("match"));  // a file with joints is not matched to a plan
  EXPECT_EQ(j["decimal"], ".");
  EXPECT_EQ(j["columns"], json::parse(R"({"target": "target", "x": "x", "y": "y", "z": "z"})"));
  EXPECT_EQ(j["orientation"], json::parse(R"({"representation": "euler", "columns": ["a", "b", "c"],
                                              "sequence": "ZYX", "convention": "intrinsic", "unit": "deg"})"));
  const ImportMeasurementsRequest back = j.get<ImportMeasurementsRequest>();
  EXPECT_EQ(back.orientation.sequence, "ZYX");
  EXPECT_EQ(back.joints.columns, csv.joints.columns);
  // A parser that knows the representation allows its keys only.
  EXPECT_EQ(Keys(WireFieldNamesOf(csv.orientation)),
            (std::vector<std::string>{"representation", "columns", "sequence", "convention", "unit"}));
}

TEST(FieldTableTest, AStoredCalibrationKeepsItsStateInOneObject) {
  StoredCalibration c;
  c.errors = {0.5};
  const json without = c;
  ASSERT_TRUE(without.contains("state"));
  EXPECT_EQ(without["state"]["errors"], json::parse("[0.5]"));
  EXPECT_FALSE(without["state"].contains("covariance"));
  EXPECT_FALSE(without["state"].contains("singular_values"));  // written with the covariance only
  c.covariance = std::vector<std::vector<double>>{{1.0}};
  c.num_residuals = 12;
  const json with = c;
  EXPECT_EQ(with["state"]["num_residuals"], 12);
  json lost = with;
  lost["state"].erase("num_residuals");
  EXPECT_EQ(ReadError<StoredCalibration>(lost), "state.num_residuals: required");
  json turned_away = with;  // a frame of the calibration is a whole pose
  turned_away["state"]["T_world_base"].erase("quaternion");
  EXPECT_EQ(ReadError<StoredCalibration>(turned_away), "state.T_world_base.quaternion: required");
}

}  // namespace
}  // namespace robocal::api
