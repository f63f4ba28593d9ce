// The wire shapes of api/: every resource the service returns survives wire -> typed -> wire unchanged, every
// required field is required by name, and stored documents of the previous schema version still load.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <string>

#include "robocal/api/cells.h"
#include "robocal/api/health.h"
#include "robocal/api/programs.h"
#include "robocal/api/stored.h"
#include "robocal/api/tracker_files.h"
#include "robocal/core/arm_kinematics.h"
#include "robocal/core/cell.h"
#include "robocal/core/planning.h"
#include "robocal/core/presets.h"
#include "robocal/core/virtual_cell.h"
#include "robocal/server/service.h"

namespace robocal::api {
namespace {

using nlohmann::json;
using server::Service;
using server::ServiceOptions;

// A service on in-memory SQLite with a calibrated grinder5 campaign "w" (12 poses, validation 8) and an async
// plan operation.
class WireTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    storage_ = server::OpenSqliteStorage(":memory:").release();
    service_ = new Service(storage_, ServiceOptions{});
    const RobotModel model = Preset("grinder5");
    plan_ = std::get<PlanResult>(service_->CreatePlan(
        {{"robot", "grinder5"}, {"num_configurations", 12}, {"num_validation", 10}, {"options", {{"k_max", 10}}}}));
    campaign_before_ = service_->CreateCampaign({{"id", "w"}, {"robot", "grinder5"}, {"plan", plan_.id}});
    VirtualCellOptions cell_options;
    cell_options.seed = 4;
    VirtualCell cell(model, cell_options);
    std::vector<Eigen::VectorXd> configurations;
    for (const auto& q : plan_.configurations) configurations.push_back(JointsToCore(model, q));
    batch_ = service_->AppendMeasurements("w", Batch(model, cell.MeasureAll(configurations, 1), "cal", "calibration"));
    Rng rng(9);
    (void)service_->AppendMeasurements(
        "w", Batch(model, cell.MeasureAll(RandomConfigurations(model, 8, &rng), 1), "val", "validation"));
    fit_ = std::get<CalibrationResult>(service_->Fit("w", json::object()));
    operation_ = std::get<Operation>(service_->CreatePlan(
        {{"robot", "ur5e"}, {"num_configurations", 8}, {"async", true}, {"options", {{"k_max", 5}}}}));
    service_->WaitForOperations();
    operation_ = service_->GetOperation(operation_.id);
  }
  static void TearDownTestSuite() {
    delete service_;
    delete storage_;
  }

  static json Batch(const RobotModel& model, const std::vector<Measurement>& measurements, const std::string& id,
                    const std::string& role) {
    json list = json::array();
    for (const Measurement& m : measurements) {
      list.push_back(MeasurementWire{JointsToWire(model, m.joints), TransformToPose(m.T_world_tool)});
    }
    return {{"request_id", id}, {"role", role}, {"measurements", list}};
  }

  static server::Storage* storage_;
  static Service* service_;
  static PlanResult plan_;
  static Campaign campaign_before_;
  static BatchResult batch_;
  static CalibrationResult fit_;
  static Operation operation_;
};

server::Storage* WireTest::storage_ = nullptr;
Service* WireTest::service_ = nullptr;
PlanResult WireTest::plan_;
Campaign WireTest::campaign_before_;
BatchResult WireTest::batch_;
CalibrationResult WireTest::fit_;
Operation WireTest::operation_;

// wire -> typed -> wire, through the text the network carries: equal JSON.
template <typename T>
void ExpectRoundTrip(const T& value) {
  const json wire = json(value);
  const json again = json(FromWire<T>(json::parse(wire.dump())));
  EXPECT_EQ(again, wire) << wire.dump(1);
}

// Every member path of `value` (objects, and the first element of arrays, as "a.b[0].c").
void MemberPaths(const json& value, const std::string& path, std::vector<std::string>* out) {
  if (value.is_object()) {
    for (const auto& [key, member] : value.items()) {
      const std::string p = path.empty() ? key : path + "." + key;
      out->push_back(p);
      MemberPaths(member, p, out);
    }
  } else if (value.is_array() && !value.empty()) {
    MemberPaths(value[0], path + "[0]", out);
  }
}

// `value` without the member at `path`.
json Without(json value, const std::string& path) {
  json* at = &value;
  std::string rest = path;
  for (;;) {
    const std::size_t cut = rest.find_first_of(".[");
    const std::string key = rest.substr(0, cut);
    if (cut == std::string::npos) {
      at->erase(key);
      return value;
    }
    if (!key.empty()) at = &(*at)[key];
    if (rest[cut] == '[') {
      at = &(*at)[0];
      rest = rest.substr(rest.find(']', cut) + 1);
      if (!rest.empty() && rest[0] == '.') rest = rest.substr(1);
    } else {
      rest = rest.substr(cut + 1);
    }
  }
}

// Removing any member not in `optional` (paths as MemberPaths writes them) is an error naming that member.
// `named`: members whose absence is reported under another name.
template <typename T>
void ExpectEveryFieldRequired(const T& value, const std::set<std::string>& optional,
                              const std::map<std::string, std::string>& named = {}) {
  const json wire = json(value);
  std::vector<std::string> paths;
  MemberPaths(wire, "", &paths);
  int required = 0;
  for (const std::string& path : paths) {
    if (optional.count(path)) {
      EXPECT_NO_THROW((void)FromWire<T>(Without(wire, path))) << path;
      continue;
    }
    ++required;
    try {
      (void)FromWire<T>(Without(wire, path));
      ADD_FAILURE() << "accepted without " << path;
    } catch (const WireError& e) {
      EXPECT_EQ(e.path(), named.count(path) ? named.at(path) : path) << e.what();
      EXPECT_EQ(e.reason(), "required") << e.what();
    }
  }
  EXPECT_GT(required, 0);
}

// The rpy_deg beside each quaternion of a reply is derived, not read.
const std::set<std::string> kDerived = {"base.rpy_deg",
                                        "tool.rpy_deg",
                                        "flange.rpy_deg",
                                        "robots[0].flange.rpy_deg",
                                        "registered_base.rpy_deg",
                                        "robots[0].base.rpy_deg",
                                        "robots[0].tool.rpy_deg",
                                        "poses[0].rpy_deg",
                                        "result.base.rpy_deg",
                                        "result.tool.rpy_deg",
                                        "result.registered_base.rpy_deg"};

std::set<std::string> With(std::set<std::string> a, const std::set<std::string>& b) {
  a.insert(b.begin(), b.end());
  return a;
}

TEST_F(WireTest, RobotsRoundTripAndRequireEveryField) {
  const Robot robot = service_->GetRobot("grinder5");
  EXPECT_EQ(robot.joints.size(), 5u);
  ExpectRoundTrip(robot);
  // A table robot with a prismatic joint, in the transform convention.
  const Robot table = service_->CreateRobot(json::parse(R"({"id":"lin","convention":"transform","joints":[
      {"type":"revolute","xyz_mm":[0,0,100],"rpy_deg":[0,0,0],"min_deg":-90,"max_deg":90},
      {"type":"prismatic","xyz_mm":[200,0,0],"rpy_deg":[0,90,0],"min_mm":0,"max_mm":400}]})"));
  ExpectRoundTrip(table);
  EXPECT_EQ(json(table)["joints"][1].at("max_mm"), 400.0);
  // Every joint field of the convention, the name included (optional in definitions only).
  ExpectEveryFieldRequired(robot, kDerived);
  ExpectEveryFieldRequired(table, kDerived);
  // A robot imported from a URDF names its links; the whole "urdf" member is absent for other robots.
  const Robot imported = service_->CreateRobot(json::parse(R"({"id":"imp","base_link":"b","tip_link":"t","urdf":
      "<robot name='x'><link name='b'/><link name='m'/><link name='t'/><joint name='j1' type='revolute'><parent link='b'/><child link='m'/><axis xyz='0 1 0'/><limit lower='-1' upper='1' effort='1' velocity='1'/></joint><joint name='tip' type='fixed'><parent link='m'/><child link='t'/><origin xyz='0 0 0.1' rpy='0 0 0'/></joint></robot>"})"));
  ASSERT_TRUE(imported.urdf.has_value());
  EXPECT_EQ(imported.urdf->tip_link, "t");
  EXPECT_EQ(imported.joints.at(0).name, "j1");
  ExpectRoundTrip(imported);
  std::set<std::string> optional = kDerived;
  optional.insert("urdf");
  ExpectEveryFieldRequired(imported, optional);
  const RobotList list = service_->ListRobots("2");
  ASSERT_TRUE(list.next_page_token.has_value());
  ExpectRoundTrip(list);
  ExpectEveryFieldRequired(list, With(kDerived, {"next_page_token"}));
  const ForwardResult fk = service_->RobotForward("grinder5", {{"joints", {{0, 0, 0, 0, 0}}}});
  ExpectRoundTrip(fk);
  // A forward reply names its robot or its campaign.
  ExpectEveryFieldRequired(fk, kDerived, {{"robot", "robot or campaign"}});
  ExpectRoundTrip(Health{"ok", "1.2.3"});
  ExpectEveryFieldRequired(Health{"ok", "1.2.3"}, {});
}

TEST_F(WireTest, PlansAndOperationsRoundTripAndRequireEveryField) {
  ExpectRoundTrip(plan_);
  // Plans stored before "auto" lack its range.
  ExpectEveryFieldRequired(plan_, {"request.min_configurations", "request.max_configurations"});
  EXPECT_EQ(service_->GetPlan(plan_.id).configurations, plan_.configurations);
  ASSERT_EQ(operation_.state, OperationState::kSucceeded);
  ASSERT_TRUE(operation_.plan.has_value());
  ExpectRoundTrip(operation_);
  ExpectEveryFieldRequired(
      operation_, {"request", "result", "campaign", "request.min_configurations", "request.max_configurations"});
}

TEST_F(WireTest, CampaignsAndMeasurementsRoundTripAndRequireEveryField) {
  const Campaign campaign = service_->GetCampaign("w");
  EXPECT_TRUE(campaign.calibrated);
  EXPECT_EQ(campaign.counts.calibration, 12);
  EXPECT_EQ(campaign.counts.validation, 8);
  ExpectRoundTrip(campaign);
  ExpectEveryFieldRequired(campaign, {});
  ExpectRoundTrip(batch_);
  ExpectEveryFieldRequired(batch_, {});
  const MeasurementList page = service_->ListMeasurements("w", "validation", "", "3");
  ASSERT_EQ(page.measurements.size(), 3u);
  ASSERT_TRUE(page.next_after.has_value());
  ExpectRoundTrip(page);
  // A position campaign's measurements carry no quaternion.
  ExpectEveryFieldRequired(page, {"next_after", "measurements[0].pose.quaternion"});
}

// GET /v1/campaigns items say which campaigns are calibrated (they used to carry neither counts nor
// `calibrated`, so a client saw every campaign as uncalibrated).
TEST_F(WireTest, CampaignListItemsSayWhichAreCalibrated) {
  (void)service_->CreateCampaign({{"id", "w2"}, {"robot", "grinder5"}});
  const CampaignList list = service_->ListCampaigns();
  ASSERT_EQ(list.campaigns.size(), 2u);
  EXPECT_EQ(list.campaigns[0].id, "w");
  EXPECT_TRUE(list.campaigns[0].calibrated);
  EXPECT_EQ(list.campaigns[0].counts.calibration, 12);
  EXPECT_FALSE(list.campaigns[1].calibrated);
  EXPECT_FALSE(campaign_before_.calibrated);
  ExpectRoundTrip(list);
  const json wire = json(list);
  EXPECT_EQ(wire["campaigns"][0].at("calibrated"), true);
  EXPECT_EQ(wire["campaigns"][0].at("counts").at("validation"), 8);
}

TEST_F(WireTest, CalibrationCompensationEvaluationRoundTripAndRequireEveryField) {
  EXPECT_TRUE(fit_.stored);
  EXPECT_FALSE(fit_.summary.deadline_exceeded);
  ExpectRoundTrip(fit_);
  // The robust fit's members, the model error and the model are absent from fits stored before them; inside
  // them every member is required.
  ExpectEveryFieldRequired(
      fit_, With(kDerived, {"robust", "outliers", "parameters_with_outliers", "model_error", "reflectors", "model"}));
  CalibrationResult with_outliers = fit_;
  with_outliers.outliers.push_back({7, "smr2", 123.5, true, OutlierMeasurement::Cause::kStale});
  with_outliers.reflectors.push_back({"smr2", {1.0, 2.0, 3.0}, true});
  with_outliers.parameters_with_outliers = fit_.parameters;
  ExpectRoundTrip(with_outliers);
  ExpectEveryFieldRequired(
      with_outliers, With(kDerived, {"robust", "outliers", "parameters_with_outliers", "model_error", "reflectors",
                                     "outliers[0].reflector", "outliers[0].cause", "model"}));
  // A fit with its model chosen by cross-validation: the comparison round-trips, every member required.
  CalibrationResult chosen = fit_;
  chosen.model = {.compliance = true, .joint_harmonics = 2};
  chosen.model_choice = ModelChoiceWire{
      5,
      {{{.compliance = false, .joint_harmonics = 0}, "geometric", 42, 0.4, 0.45, 0.01, 0, "", false},
       {{.compliance = true, .joint_harmonics = 2}, "compliance + harmonics 2", 72, 0.33, 0.37, 0.011, 0, "", true}}};
  ExpectRoundTrip(chosen);
  ExpectEveryFieldRequired(chosen, With(kDerived, {"robust", "outliers", "parameters_with_outliers", "model_error",
                                                   "reflectors", "model", "model_choice"}));
  EXPECT_EQ(json(service_->GetCalibration("w")), json(fit_));
  const CompensatedTargets comp = service_->Compensate("w", json::parse(R"({"targets":[{"joints":[10,20,30,40,50]},
                                      {"pose":{"position_mm":[400,0,300],"rpy_deg":[180,0,0]},"frame":"base"}]})"));
  ASSERT_EQ(comp.results.size(), 2u);
  for (const Compensation& c : comp.results) {
    EXPECT_GT(c.predicted_error_mm, 0.0);  // NaN fails too
    EXPECT_LT(c.predicted_error_mm, 10.0);
  }
  ExpectRoundTrip(comp);
  // A reply of an older server has no predicted_error_mm.
  ExpectEveryFieldRequired(comp, {"results[0].predicted_error_mm"});
  // The reply as the server writes it is the same document, with every kind of value a result can hold.
  EXPECT_EQ(json::parse(DumpCompensatedTargets(comp)), json(comp));
  CompensatedTargets odd = comp;
  odd.campaign = "c-\"quoted\"";
  odd.results[0].message = "tab\there, newline\n, \u00e9, backslash \\";
  odd.results[0].configuration = ArmConfiguration{-1, 1, -1};
  odd.results[0].branch_change = true;
  odd.results[0].joint_jump = true;
  odd.results[0].joint_jump_deg = 1e-300;
  odd.results[1].joints = {std::nan(""), -0.0, 1e300, 5e-324};
  odd.results[1].position_error_mm = std::nan("");
  odd.results[1].predicted_error_mm = std::nan("");
  odd.results[1].termination = Termination::kFailure;
  EXPECT_EQ(json::parse(DumpCompensatedTargets(odd)), json(odd));
  EXPECT_EQ(json::parse(DumpCompensatedTargets(CompensatedTargets{})), json(CompensatedTargets{}));
  const Evaluation eval = service_->Evaluate("w", json::object());
  EXPECT_EQ(eval.num_validation, 8);
  ExpectRoundTrip(eval);
  ExpectEveryFieldRequired(eval, {});
  const ForwardResult fk = service_->CampaignForward("w", {{"joints", {{0, 0, 0, 0, 0}}}});
  ExpectRoundTrip(fk);
  ExpectEveryFieldRequired(fk, kDerived, {{"campaign", "robot or campaign"}});
}

// A program (sequence): pose targets along a smooth path, each solved from the previous result, converge with
// small joint moves between them; the jumps are on the wire, flagged over the threshold, and round-trip. A path
// through the singularity (A = 0, where the C axis is parallel to the tool axis) is flagged where C swings.
TEST_F(WireTest, CompensationSequenceFollowsTheProgram) {
  const RobotModel model = Preset("grinder5");
  constexpr int kSteps = 40;
  const auto program_of = [&](const std::vector<double>& from_wire, const std::vector<double>& to_wire) {
    const Eigen::VectorXd from = JointsToCore(model, from_wire), to = JointsToCore(model, to_wire);
    json targets = json::array();
    for (int i = 0; i <= kSteps; ++i) {
      const Eigen::VectorXd q = from + (to - from) * i / kSteps;
      const Transform T_base_tool = model.T_world_base().inverse() * ForwardKinematics(model, q);
      targets.push_back({{"pose", TransformToPose(T_base_tool)}, {"frame", "base"}});
    }
    // The program's first point says where the robot starts (from the default start the solver can wind C to
    // its limit on the other branch); every later one starts from the result before it.
    targets[0]["start_joints"] = from_wire;
    return targets;
  };
  // C 20 -> 60 deg, A 30 -> 100 deg: 1 and 1.75 deg per step, away from A = 0.
  const json smooth = program_of({300, 200, 250, 20, 30}, {420, 260, 300, 60, 100});
  const CompensatedTargets program =
      service_->Compensate("w", {{"targets", smooth}, {"sequence", true}, {"max_joint_jump_deg", 5}});
  ASSERT_EQ(program.results.size(), static_cast<std::size_t>(kSteps + 1));
  EXPECT_TRUE(std::isnan(program.results[0].joint_jump_deg));
  for (std::size_t i = 0; i < program.results.size(); ++i) {
    EXPECT_TRUE(program.results[i].converged) << i << ": " << program.results[i].message;
    if (i == 0) continue;
    EXPECT_NEAR(program.results[i].joint_jump_deg, 1.75, 0.1) << i;
    EXPECT_FALSE(program.results[i].joint_jump) << i;
  }
  ExpectRoundTrip(program);
  // The same program with a threshold below the step flags every move after the first.
  const CompensatedTargets tight =
      service_->Compensate("w", {{"targets", smooth}, {"sequence", true}, {"max_joint_jump_deg", 1}});
  for (std::size_t i = 1; i < tight.results.size(); ++i) EXPECT_TRUE(tight.results[i].joint_jump) << i;
  // Without sequence no jumps are reported.
  const CompensatedTargets apart = service_->Compensate("w", {{"targets", smooth}});
  for (const Compensation& c : apart.results) EXPECT_TRUE(std::isnan(c.joint_jump_deg));
  // A 30 -> -40 deg passes A = 0 between steps 17 and 18: C swings there, and only there.
  const CompensatedTargets through =
      service_->Compensate("w", {{"targets", program_of({300, 200, 250, 20, 30}, {420, 260, 300, 60, -40})},
                                 {"sequence", true},
                                 {"max_joint_jump_deg", 5}});
  std::vector<std::size_t> flagged;
  for (std::size_t i = 0; i < through.results.size(); ++i) {
    EXPECT_TRUE(through.results[i].converged) << i << ": " << through.results[i].message;
    if (through.results[i].joint_jump) flagged.push_back(i);
  }
  EXPECT_EQ(flagged, std::vector<std::size_t>{18});
}

TEST_F(WireTest, CellsRoundTripAndRequireEveryField) {
  const CellWire cell = service_->CreateCell(json::parse(R"({"id": "wc", "robot": "grinder5",
      "tracker": {"position_mm": [2000, -500, 400], "min_distance_mm": 1000},
      "obstacles": [{"id": "floor", "box": {"min_mm": [-3000, -3000, -500], "max_mm": [3000, 3000, -10]}}],
      "clearance_mm": 10})"));
  // Every default written out: one reflector at the tool point, a radius per link, the joint limits.
  ASSERT_EQ(cell.reflectors.size(), 1u);
  EXPECT_EQ(cell.link_radii_mm.size(), 5u);
  EXPECT_EQ(cell.joint_ranges.size(), 5u);
  ExpectRoundTrip(cell);
  ExpectEveryFieldRequired(cell, {"tracker.max_distance_mm"});
  CellList list;
  list.cells = {cell};
  list.next_page_token = "x";
  ExpectRoundTrip(list);
  const CellCheckResult check = service_->CheckCell("wc", {{"joints", {{0, 0, 0, 0, 0}, {0, 80, 0, 0, 0}}}});
  ASSERT_EQ(check.results.size(), 2u);
  ExpectRoundTrip(check);
  ExpectEveryFieldRequired(check, {"results[0].reflectors[0].blocked_by"});
}

// The request a client writes for a core cell spec (the mock tracker's preset cells) is accepted by the server
// and builds the same cell: every feasibility verdict agrees with the core cell over sampled configurations.
TEST_F(WireTest, PresetCellRequestsBuildThePresetCells) {
  for (const std::string robot : {"grinder5", "puma560", "ur5e"}) {
    const RobotModel model = Preset(robot);
    const CellSpec spec = PresetCellSpec(robot);
    const CellWire request = CellRequestOf("preset-" + robot, robot, spec, model);
    const CellWire created = service_->CreateCell(json(request));
    EXPECT_EQ(created.obstacles.size(), spec.obstacles.size()) << robot;
    const Cell core = Cell::Build(model, spec);
    const Cell back = ToCell(created, model);
    Rng rng(11);
    int feasible = 0;
    for (const Eigen::VectorXd& q : RandomConfigurations(model, 400, &rng)) {
      const bool expected = IsFeasible(model, core, q);
      EXPECT_EQ(IsFeasible(model, back, q), expected) << robot;
      feasible += expected ? 1 : 0;
    }
    EXPECT_GT(feasible, 0) << robot << ": the comparison saw no feasible configuration";
  }
  // A request that leaves radii, ranges and reflectors to the server is written without them (an empty list
  // would be refused for its size) and gets the defaults.
  CellWire minimal;
  minimal.id = "minimal";
  minimal.robot = "ur5e";
  minimal.tracker.position_mm = {2500, -800, 300};
  const CellWire created = service_->CreateCell(json(minimal));
  EXPECT_EQ(created.link_radii_mm, DefaultLinkRadii(Preset("ur5e")));
  EXPECT_EQ(created.joint_ranges.size(), 6u);
  EXPECT_EQ(created.reflectors.size(), 1u);
}

// In a cell that leaves about 1 % feasible, a plan either comes with its whole random baseline (drawn in the
// same cell) or is refused as FAILED_PRECONDITION naming the cell: never a plan with an empty baseline (seeds 5
// and 6 once returned one).
TEST_F(WireTest, PlansInATightCellHaveTheirBaseline) {
  (void)service_->CreateCell(json::parse(R"({"id": "tight", "robot": "ur5e",
      "tracker": {"position_mm": [2300, -1400, 1400]},
      "reflectors": [{"id": "s", "position_mm": [0, 0, 100], "normal": [0, 0, 1], "acceptance_half_angle_deg": 20}],
      "obstacles": [{"id": "floor", "box": {"min_mm": [-3000, -3000, -500], "max_mm": [3000, 3000, -10]}}],
      "clearance_mm": 10})"));
  int planned = 0;
  for (int seed = 1; seed <= 8; ++seed) {
    try {
      const server::PlanReply reply = service_->CreatePlan(
          {{"robot", "ur5e"}, {"cell", "tight"}, {"optimiser", "random"}, {"num_configurations", 50}, {"seed", seed}});
      const PlanResult& plan = std::get<PlanResult>(reply);
      EXPECT_EQ(plan.configurations.size(), 50u) << seed;
      EXPECT_EQ(plan.baseline.configurations.size(), 50u) << seed;
      EXPECT_GT(plan.baseline.predicted_accuracy.num_validation, 0) << seed;
      ++planned;
    } catch (const ApiError& e) {
      EXPECT_EQ(e.status(), Status::kFailedPrecondition) << seed << ": " << e.what();
      ASSERT_FALSE(e.details().empty());
      EXPECT_EQ(e.details()[0].field, "cell");
    }
  }
  EXPECT_GE(planned, 5);
}

// What the review of cells found: ids that would break CSV columns and blocked_by, a tool radius of 0 that
// silently meant the default, checks larger than a reply should be; each refused naming the field.
TEST_F(WireTest, CellRequestsRefuseIdsAndSizesThatBreakReports) {
  const auto refused_field = [&](const json& body) {
    try {
      (void)service_->CreateCell(body);
    } catch (const ApiError& e) {
      EXPECT_EQ(e.status(), Status::kInvalidArgument);
      EXPECT_EQ(std::string(e.what()).find("robot model"), std::string::npos) << e.what();
      return e.details().empty() ? std::string() : e.details()[0].field;
    }
    return std::string("accepted");
  };
  const json base = {{"id", "ok"}, {"robot", "ur5e"}, {"tracker", {{"position_mm", {2500, -800, 300}}}}};
  json comma = base;
  comma["reflectors"] = {{{"id", "a,b"}, {"position_mm", {0, 0, 100}}, {"normal", {0, 0, 1}}}};
  EXPECT_EQ(refused_field(comma), "reflectors[0].id");
  json named_like_a_link = base;
  named_like_a_link["obstacles"] = {
      {{"id", "link 1"}, {"box", {{"min_mm", {3000, 0, 0}}, {"max_mm", {3100, 50, 50}}}}}};
  EXPECT_EQ(refused_field(named_like_a_link), "obstacles[0].id");
  json zero_tool = base;
  zero_tool["tool_radius_mm"] = 0;
  EXPECT_EQ(refused_field(zero_tool), "tool_radius_mm");
  json inside = base;
  inside["tracker"]["position_mm"] = {0, 0, 0};
  inside["obstacles"] = {{{"id", "b"}, {"box", {{"min_mm", {-10, -10, -10}}, {"max_mm", {10, 10, 10}}}}}};
  EXPECT_EQ(refused_field(inside), "tracker.position_mm");

  (void)service_->CreateCell(base);
  json many = {{"joints", json::array()}};
  for (std::size_t i = 0; i <= kMaxCheckConfigurations; ++i) many["joints"].push_back({0, -90, 90, 0, 90, 0});
  try {
    (void)service_->CheckCell("ok", many);
    FAIL() << "a check of " << many["joints"].size() << " configurations accepted";
  } catch (const ApiError& e) {
    EXPECT_EQ(e.details().at(0).field, "joints");
    EXPECT_NE(std::string(e.what()).find("invalid check request"), std::string::npos) << e.what();
  }
  many["joints"].erase(many["joints"].begin());
  EXPECT_EQ(service_->CheckCell("ok", many).results.size(), kMaxCheckConfigurations);
}

// A cell is made for its robot as registered then: a plan in it for a robot re-registered since is refused
// (it would hold the old robot's joints under the new robot's name), and a cell of more boxes than a check can
// afford is refused by name.
TEST_F(WireTest, CellsKeepToTheRobotTheyWereMadeFor) {
  (void)service_->CreateRobot({{"id", "myrob"}, {"from_preset", "ur5e"}});
  (void)service_->CreateCell({{"id", "cr"}, {"robot", "myrob"}, {"tracker", {{"position_mm", {2500, -800, 300}}}}});
  service_->DeleteRobot("myrob");
  (void)service_->CreateRobot({{"id", "myrob"}, {"from_preset", "puma560"}});
  try {
    (void)service_->CreatePlan({{"robot", "myrob"}, {"cell", "cr"}, {"num_configurations", 8}});
    FAIL() << "planned in a cell made for another definition of the robot";
  } catch (const ApiError& e) {
    EXPECT_EQ(e.status(), Status::kFailedPrecondition);
    ASSERT_FALSE(e.details().empty());
    EXPECT_EQ(e.details()[0].field, "cell");
  }
  json many = {{"id", "boxes"}, {"robot", "ur5e"}, {"tracker", {{"position_mm", {2500, -800, 300}}}}};
  for (int i = 0; i < 129; ++i) {
    many["obstacles"].push_back({{"id", "b" + std::to_string(i)},
                                 {"box", {{"min_mm", {3000 + 10 * i, 0, 0}}, {"max_mm", {3005 + 10 * i, 5, 5}}}}});
  }
  try {
    (void)service_->CreateCell(many);
    FAIL() << "129 obstacles accepted";
  } catch (const ApiError& e) {
    EXPECT_EQ(e.details().at(0).field, "obstacles");
  }
}

// Joint terms a robot holds (e.g. from a compliant calibration) in wire units: written in a definition only when
// held, always in the resource; bad ones refused naming the field.
TEST_F(WireTest, RobotsHoldJointTermsInWireUnits) {
  const json joints = json::parse(R"([
      {"name":"s","type":"revolute","xyz_mm":[0,0,100],"rpy_deg":[0,0,0],"min_deg":-90,"max_deg":90,
       "mass_kg":4,"com_mm":[0,0,50],"harmonics_deg":[0.01,-0.02,0,0.005]},
      {"name":"e","type":"revolute","xyz_mm":[0,0,200],"rpy_deg":[90,0,0],"min_deg":-90,"max_deg":90,
       "mass_kg":2,"com_mm":[100,0,0],"compliance_deg_per_nm":0.002}])");
  const json body = {{"id", "held"},
                     {"convention", "transform"},
                     {"joints", joints},
                     {"tool", {{"position_mm", {150, 0, 0}}, {"rpy_deg", {0, 0, 0}}}}};
  const Robot robot = service_->CreateRobot(body);
  ExpectRoundTrip(robot);
  ExpectEveryFieldRequired(robot, kDerived);
  EXPECT_DOUBLE_EQ(robot.joints[1].compliance_deg_per_nm, 0.002);
  EXPECT_DOUBLE_EQ(robot.joints[0].harmonics_deg[1], -0.02);
  EXPECT_EQ(json(robot)["joints"][0]["compliance_deg_per_nm"], 0.0);
  EXPECT_EQ(json(robot)["joints"][1]["harmonics_deg"], json::array({0.0, 0.0, 0.0, 0.0}));
  const RegisterRobotRequest definition = ParseRegisterRobotRequest(body, Limits{});
  EXPECT_EQ(json(definition)["joints"][0]["harmonics_deg"], joints[0]["harmonics_deg"]);
  EXPECT_FALSE(json(definition)["joints"][0].contains("compliance_deg_per_nm"));
  EXPECT_FALSE(json(definition)["joints"][1].contains("harmonics_deg"));
  EXPECT_EQ(json(ParseRegisterRobotRequest(json(definition), Limits{})), json(definition));
  const RobotModel model = BuildModel(definition);
  EXPECT_TRUE(model.has_fixed_joint_terms());
  EXPECT_NEAR(model.spec().joints[1].compliance_rad_per_nm, 0.002 * kRadPerDeg, 1e-18);
  // The robot's :forward deflects under a payload; without held terms it would not.
  const ForwardResult light = service_->RobotForward("held", {{"joints", {{30, 40}}}});
  const ForwardResult heavy =
      service_->RobotForward("held", {{"joints", {{30, 40}}}, {"payload", {{"mass_kg", 5}, {"com_mm", {100, 0, 0}}}}});
  const double moved = std::hypot(heavy.poses[0].position_mm[0] - light.poses[0].position_mm[0],
                                  heavy.poses[0].position_mm[1] - light.poses[0].position_mm[1],
                                  heavy.poses[0].position_mm[2] - light.poses[0].position_mm[2]);
  EXPECT_GT(moved, 1e-3);

  const auto refused_field = [&](json joint_0, json joint_1) {
    json bad = body;
    bad["id"] = "bad-held";
    bad["joints"][0] = std::move(joint_0);
    bad["joints"][1] = std::move(joint_1);
    try {
      (void)service_->CreateRobot(bad);
    } catch (const ApiError& e) {
      EXPECT_EQ(e.status(), Status::kInvalidArgument);
      return e.details().empty() ? std::string() : e.details()[0].field;
    }
    return std::string("accepted");
  };
  json j0 = joints[0], j1 = joints[1];
  j1["compliance_deg_per_nm"] = 0.6;  // beyond 0.01 rad/(N*m)
  EXPECT_EQ(refused_field(j0, j1), "joints[1].compliance_deg_per_nm");
  j1 = joints[1];
  j0["harmonics_deg"] = {0, 0, 0.6, 0};
  EXPECT_EQ(refused_field(j0, j1), "joints[0].harmonics_deg[2]");
  j0["harmonics_deg"] = {0, 0, 0};
  EXPECT_EQ(refused_field(j0, j1), "joints[0].harmonics_deg");
  j0 = joints[0];
  j0.erase("mass_kg");
  j1.erase("mass_kg");
  EXPECT_EQ(refused_field(j0, j1), "joints");  // a compliance needs masses
  j1 = joints[1];
  j1["type"] = "prismatic";
  j1.erase("min_deg");
  j1.erase("max_deg");
  j1["min_mm"] = 0;
  j1["max_mm"] = 100;
  EXPECT_EQ(refused_field(joints[0], j1), "joints[1].type");
}

// The rows' core links (Field::Core) convert as the hand-written conversions they replaced did, bit for bit: a
// joint's angles by * kRadPerDeg and back by * kDegPerRad, a stored fit's model error back by / kDegPerRad (which
// differs from * kRadPerDeg in the last bit for 0.0123 deg); members without a link are left alone.
TEST(WireLinkTest, LinkedRowsConvertAsTheConversionsTheyReplaced) {
  JointWire joint;
  joint.alpha_deg = 0.0123;
  joint.rpy_deg = {0.0123, -90.0, 33.3};
  joint.compliance_deg_per_nm = 0.0123;
  joint.min = -170.0;
  JointSpec spec;
  spec.min = 7.0;
  WireToCore(joint, &spec);
  EXPECT_EQ(spec.alpha_rad, 0.0123 * kRadPerDeg);
  EXPECT_EQ(spec.rpy_rad.x(), 0.0123 * kRadPerDeg);
  EXPECT_EQ(spec.rpy_rad.y(), -90.0 * kRadPerDeg);
  EXPECT_EQ(spec.compliance_rad_per_nm, 0.0123 * kRadPerDeg);
  EXPECT_EQ(spec.min, 7.0) << "a joint's limits are in its unit: no row links them";
  JointWire back;
  CoreToWire(spec, &back);
  EXPECT_EQ(back.alpha_deg, spec.alpha_rad * kDegPerRad);
  EXPECT_EQ(back.rpy_deg[2], spec.rpy_rad.z() * kDegPerRad);
  EXPECT_EQ(back.min, 0.0);

  ModelErrorWire stored{.estimated = true,
                        .model_error_mm = 0.4,
                        .model_error_deg = 0.0123,
                        .tracker_rms_mm = 0.03,
                        .tracker_rms_deg = 0.0123};
  ModelErrorEstimate core;
  WireToCore(stored, &core);
  ASSERT_NE(0.0123 / kDegPerRad, 0.0123 * kRadPerDeg) << "the case must tell the two apart";
  EXPECT_EQ(core.model_error_rad, 0.0123 / kDegPerRad);
  EXPECT_EQ(core.tracker_rms_rad, 0.0123 / kDegPerRad);
  EXPECT_TRUE(core.estimated);
  EXPECT_EQ(core.model_error_mm, 0.4);
  CalibrationResult result;
  IdentificationSummary summary;
  summary.model_error = core;
  summary.condition_number = 12.5;
  CoreToWire(summary, &result);
  EXPECT_EQ(result.model_error.model_error_deg, core.model_error_rad * kDegPerRad);
  EXPECT_EQ(result.condition_number, 12.5);
}

TEST(WireRequestTest, RequestsRoundTrip) {
  const RobotModel model = Preset("ur5e");
  PlanRequest plan;
  plan.robot = "ur5e";
  plan.optimiser = Optimiser::kExchange;
  plan.objective = ObservabilityIndex::kO3;
  plan.measurement_type = MeasurementType::kPositionAxis;
  plan.seed = 12345678901234ULL;
  ExpectRoundTrip(plan);
  EXPECT_EQ(json(ParsePlanRequest(json(plan), Limits{})), json(plan));
  CreateCampaignRequest campaign;
  campaign.robot = "ur5e";
  campaign.measurement_type = MeasurementType::kPosition;
  ExpectRoundTrip(campaign);
  MeasurementBatchRequest batch;
  batch.request_id = "b1";
  batch.role = MeasurementRole::kValidation;
  batch.measurements.push_back({{0, 0, 0, 0, 0, 0}, PoseWire{{1, 2, 3}, {1, 0, 0, 0}, true}});
  ExpectRoundTrip(batch);
  EXPECT_EQ(json(ParseMeasurementBatchRequest(json(batch), model, MeasurementType::kPose, Limits{})), json(batch));
  FitRequest fit;
  fit.parameters = {"joint2.dz"};
  ExpectRoundTrip(fit);
  CompensateRequest comp;
  CompensationTargetWire target;
  target.pose = PoseWire{{400, 0, 300}, {0, 1, 0, 0}, true};
  target.frame = TargetFrame::kBase;
  target.start_joints = {0, -90, 90, 0, 90, 0};
  comp.targets = {target};
  ExpectRoundTrip(comp);
  EXPECT_EQ(json(ParseCompensateRequest(json(comp), model, Limits{})), json(comp));
  ExpectRoundTrip(EvaluateRequest{12.5});
  // A program: its files and frames are objects of names; the parser takes what to_json writes.
  CompensateProgramRequest program;
  program.dialect = programs::Dialect::kRapid;
  program.files = {{"main.mod", "MODULE main\r\nENDMODULE\r\n"}, {"b.prg", ""}};
  program.tools = {{"tool1", {0, 0, 150, 1, 0, 0, 0}}};
  program.bases = {{"wobj1", {1000, 0, 0, 0.5, 0.5, 0.5, 0.5}}};
  program.max_path_deviation_mm = 0.05;
  program.on_failure = programs::OnFailure::kRefuse;
  ExpectRoundTrip(program);
  EXPECT_EQ(json(ParseCompensateProgramRequest(json(program), Limits{})), json(program));
  // Without a dialect the extensions name it; a quaternion dialect's frames have 7 values, others 6.
  json named = json(program);
  named.erase("dialect");
  EXPECT_EQ(ParseCompensateProgramRequest(named, Limits{}).dialect, programs::Dialect::kRapid);
  named["files"] = {{"a.src", ""}, {"a.dat", ""}};
  try {
    (void)ParseCompensateProgramRequest(named, Limits{});
    FAIL();
  } catch (const ApiError& e) {
    ASSERT_FALSE(e.details().empty());
    EXPECT_EQ(e.details()[0].field, "tools.tool1");
  }
  // A dialect the file names contradict: named, not read as something it is not.
  json contradicted = {{"dialect", "rapid"}, {"files", {{"a.src", ""}, {"a.dat", ""}}}};
  try {
    (void)ParseCompensateProgramRequest(contradicted, Limits{});
    FAIL();
  } catch (const ApiError& e) {
    ASSERT_FALSE(e.details().empty());
    EXPECT_EQ(e.details()[0].field, "dialect");
  }
  contradicted["files"] = {{"a.mod", ""}, {"A.MOD", ""}};  // one file on a controller's file system
  try {
    (void)ParseCompensateProgramRequest(contradicted, Limits{});
    FAIL();
  } catch (const ApiError& e) {
    ASSERT_FALSE(e.details().empty());
    EXPECT_EQ(e.details()[0].field, "files.a.mod");
  }
  contradicted["files"] = {{"a.txt", ""}};  // extensions that say nothing: the dialect given is taken
  EXPECT_EQ(ParseCompensateProgramRequest(contradicted, Limits{}).dialect, programs::Dialect::kRapid);
  named["files"] = {{"a.src", ""}, {"b.mod", ""}};
  named.erase("tools");
  named.erase("bases");
  try {
    (void)ParseCompensateProgramRequest(named, Limits{});
    FAIL();
  } catch (const ApiError& e) {
    ASSERT_FALSE(e.details().empty());
    EXPECT_EQ(e.details()[0].field, "dialect");
  }
  ExpectRoundTrip(ForwardRequest{{{0, 0, 0, 0, 0, 0}}});
}

TEST(WireEnumTest, EveryEnumHasOneNameEachAndUnknownNamesAreNamed) {
  auto check = [](auto values) {
    std::set<std::string> names;
    for (auto v : values) {
      const std::string name = WireName(v);
      EXPECT_TRUE(names.insert(name).second) << name;
      decltype(v) back{};
      EXPECT_TRUE(FromWireName(name, &back));
      EXPECT_EQ(back, v);
    }
  };
  check(EnumTable<MeasurementType>::values);
  check(EnumTable<Termination>::values);
  check(EnumTable<ObservabilityIndex>::values);
  check(EnumTable<Optimiser>::values);
  check(EnumTable<OperationState>::values);
  check(EnumTable<Status>::values);
  check(EnumTable<GeometryConvention>::values);
  check(EnumTable<programs::Dialect>::values);
  check(EnumTable<programs::TargetKind>::values);
  check(EnumTable<programs::OnFailure>::values);
  json summary = json(PlanSummaryWire{});
  summary["termination"] = "DONE";
  try {
    (void)FromWire<PlanSummaryWire>(summary);
    FAIL();
  } catch (const WireError& e) {
    EXPECT_EQ(e.path(), "termination");
    EXPECT_NE(e.reason().find("NO_CONVERGENCE"), std::string::npos) << e.reason();
  }
  // A number where a string belongs, a fraction where an integer belongs: named by path.
  json indices = json(Indices{});
  indices["num_parameters"] = 2.5;
  try {
    (void)FromWire<Indices>(indices);
    FAIL();
  } catch (const WireError& e) {
    EXPECT_EQ(e.path(), "num_parameters");
  }
}

// The ISO 9283 poses' names, P1..P5.
std::vector<std::string> Iso9283PoseNames() {
  std::vector<std::string> names;
  for (int k = 0; k < kIso9283Poses; ++k) names.push_back(Iso9283PoseName(k));
  return names;
}

// The spec's enum lists are the enum tables' names: a value added to an enum without the spec, or the other way
// round, fails here.
TEST(WireEnumTest, TheSpecListsEachEnumsNames) {
  std::ifstream in(ROBOCAL_OPENAPI_JSON);
  ASSERT_TRUE(in) << ROBOCAL_OPENAPI_JSON;
  const json spec = json::parse(in);
  const std::map<std::string, std::vector<std::string>> tables = {
      {"measurement_type", WireNames<MeasurementType>()},
      {"termination", WireNames<Termination>()},
      {"objective", WireNames<ObservabilityIndex>()},
      {"optimiser", WireNames<Optimiser>()},
      {"scaling", WireNames<ColumnScaling>()},
      {"kind", WireNames<OperationKind>()},
      {"state", WireNames<OperationState>()},
      {"status", WireNames<Status>()},
      {"convention", WireNames<GeometryConvention>()},
      {"type", WireNames<JointType>()},
      {"frame", WireNames<TargetFrame>()},
      {"role", WireNames<MeasurementRole>()},
      {"from_preset", PresetNames()},
      {"format", WireNames<TrackerFileFormat>()},
      {"unit", WireNames<TrackerFileUnit>()},
      {"match", WireNames<TrackerFileMatch>()},
      {"shoulder", {ShoulderName(1), ShoulderName(-1)}},
      {"elbow", {ElbowName(1), ElbowName(-1)}},
      {"wrist", {WristName(1), WristName(-1)}},
      {"delimiter", WireNames<TrackerFileDelimiter>()},
      {"decimal", WireNames<TrackerFileDecimal>()},
      {"representation", WireNames<OrientationRepresentation>()},
      {"order", WireNames<QuaternionOrder>()},
      {"scope", WireNames<FitScope>()},
      {"dialect", WireNames<programs::Dialect>()},
      {"on_failure", WireNames<programs::OnFailure>()},
      {"cause", WireNames<OutlierMeasurement::Cause>()},
      {"malformed", WireNames<MalformedCandidates>()},
      {"test_pose", Iso9283PoseNames()},
      {"pose", Iso9283PoseNames()},
      {"commands", WireNames<TestCommands>()},
      {"frames", WireNames<TestFrames>()},
      {"purpose", WireNames<PlanPurpose>()},
      {"verdict", WireNames<CheckVerdict>()}};
  // Parameter units are named by their schema's path (below): "unit" is also the tracker file's.
  // Names another table owns elsewhere: by their schema's path.
  const std::map<std::string, std::vector<std::string>> at_path = {
      {"/components/schemas/ImportMeasurementsRequest/properties/joints.unit", WireNames<AngleUnit>()},
      {"/components/schemas/ImportMeasurementsRequest/properties/orientation.unit", WireNames<AngleUnit>()},
      {"/components/schemas/ImportMeasurementsRequest/properties/orientation.convention", WireNames<EulerConvention>()},
      {"/components/schemas/Calibration/properties/parameters/items.unit", ParameterUnits()},
      {"/components/schemas/Calibration/properties/parameters_with_outliers/items.unit", ParameterUnits()},
      {"/components/schemas/Calibration/properties/priors/properties/prior_determined/items.unit", ParameterUnits()},
      {"/components/schemas/CompensateProgramResponse/properties/targets/items.kind",
       WireNames<programs::TargetKind>()},
      {"/components/schemas/Plan.task_method", {kTaskByInverseKinematics, kTaskByRejectionSampling}},
      {"/components/schemas/Iso9283PlannedPose.name", Iso9283PoseNames()},
      {"/components/schemas/DriftCheckRequest.frames", WireNames<CheckFrames>()},
      {"/components/schemas/DriftCheck.frames", WireNames<CheckFrames>()},
      {"/components/schemas/DriftSuspect.unit", ParameterUnits()},
      {"/components/schemas/HistoryEntry.kind", WireNames<HistoryKind>()}};
  // Fixed values that are no enum of the API: the health status, the frames of forward replies, joint units.
  const std::set<std::vector<std::string>> fixed = {{"ok"},        {"tracker"},   {"world (nominal base)"},
                                                    {"deg", "mm"}, {"mm", "deg"}, {"3.0.3"}};
  int checked = 0;
  std::function<void(const json&, const std::string&)> walk = [&](const json& node, const std::string& path) {
    if (node.is_object()) {
      if (node.contains("properties")) {
        for (const auto& [name, schema] : node["properties"].items()) {
          if (!schema.is_object() || !schema.contains("enum")) continue;
          const auto values = schema["enum"].get<std::vector<std::string>>();
          if (fixed.count(values)) continue;
          const auto by_path = at_path.find(path + "." + name);
          ASSERT_TRUE(by_path != at_path.end() || tables.count(name))
              << path << "." << name << " has an enum no table owns";
          const std::vector<std::string>& table = by_path != at_path.end() ? by_path->second : tables.at(name);
          EXPECT_EQ(std::set<std::string>(values.begin(), values.end()),
                    std::set<std::string>(table.begin(), table.end()))
              << path << "." << name;
          ++checked;
        }
      }
      for (const auto& [key, child] : node.items()) walk(child, path + "/" + key);
    } else if (node.is_array()) {
      for (const json& child : node) walk(child, path);
    }
  };
  walk(spec, "");
  EXPECT_GT(checked, 12);
}

}  // namespace
}  // namespace robocal::api
