// robocal::Client against the real server in-process: every call, typed results, errors with status and
// fields, auth, retries of idempotent calls only.
#include "robocal/client/client.h"

#include <gtest/gtest.h>

#include <limits>
#include <sstream>

#include "mock_tracker.h"
#include "robocal/client/csv.h"
#include "test_server.h"

namespace robocal {
namespace {

using client::ServiceError;

ClientOptions Options(const std::string& url) {
  ClientOptions o;
  o.server_url = url;
  o.retry_backoff = std::chrono::milliseconds(1);
  return o;
}

// A small calibrated campaign shared by the tests of the campaign calls.
struct Calibrated {
  api::PlanResult plan;
  api::Campaign campaign;
};

Calibrated MakeCalibratedCampaign(Client& c) {
  api::PlanRequest plan_request;
  plan_request.robot = "grinder5";
  plan_request.num_configurations = 10;
  plan_request.options.k_max = 20;
  plan_request.num_validation = 10;
  Calibrated out;
  out.plan = c.CreatePlan(plan_request);
  api::CreateCampaignRequest campaign_request;
  campaign_request.robot = "grinder5";
  campaign_request.plan = out.plan.id;
  out.campaign = c.CreateCampaign(campaign_request);
  mock::MockTrackerOptions options;
  options.shots_per_pose = 2;
  VirtualCell cell = mock::MakeCell(options);
  c.UploadMeasurements(out.campaign.id, mock::MeasurementBatch(&cell, out.plan.configurations,
                                                               api::MeasurementRole::kCalibration, options));
  c.Fit(out.campaign.id);
  c.UploadMeasurements(out.campaign.id, mock::MeasurementBatch(&cell, out.plan.configurations,
                                                               api::MeasurementRole::kValidation, options));
  return out;
}

TEST(ClientTest, ServiceEndpoints) {
  testing::TestServer server;
  Client c(Options(server.url()));
  const api::Health health = c.GetHealth();
  EXPECT_EQ(health.status, "ok");
  EXPECT_FALSE(health.version.empty());
  EXPECT_EQ(c.GetOpenApi().value("openapi", ""), "3.0.3");
  EXPECT_NE(c.GetMetrics().find("robocal_http_requests_total"), std::string::npos);
}

// A check of more configurations than the server takes at once goes in consecutive requests, its results in
// order: configuration i gets its own report (every one is q1 = i, checked against the distance each gives).
TEST(ClientTest, CellChecksLongerThanARequestArePaged) {
  testing::TestServer server;
  Client c(Options(server.url()));
  api::CellWire request;
  request.id = "paged";
  request.robot = "ur5e";
  request.tracker.position_mm = {2500, -800, 300};
  (void)c.CreateCell(request);
  const std::size_t n = 2 * api::kMaxCheckConfigurations + 17;
  std::vector<std::vector<double>> joints;
  for (std::size_t i = 0; i < n; ++i) joints.push_back({-180.0 + 360.0 * i / n, -90, 90, 0, 90, 0});
  const api::CellCheckResult all = c.CheckCell("paged", joints);
  ASSERT_EQ(all.results.size(), n);
  EXPECT_EQ(all.cell, "paged");
  // The same answers as checking a few of them one by one.
  for (const std::size_t i : {std::size_t{0}, api::kMaxCheckConfigurations, n - 1}) {
    const api::CellCheckResult one = c.CheckCell("paged", {joints[i]});
    ASSERT_EQ(one.results.size(), 1u);
    EXPECT_EQ(one.results[0].reflectors[0].distance_mm, all.results[i].reflectors[0].distance_mm) << i;
  }
}

TEST(ClientTest, Robots) {
  testing::TestServer server;
  Client c(Options(server.url()));
  const auto robots = c.ListRobots();
  ASSERT_GE(robots.size(), 3u);
  EXPECT_EQ(robots[0].id, "grinder5");
  const api::Robot grinder = c.GetRobot("grinder5");
  EXPECT_TRUE(grinder.preset);
  EXPECT_EQ(grinder.num_joints, 5);
  ASSERT_EQ(grinder.joints.size(), 5u);
  EXPECT_EQ(grinder.joints[0].unit, "mm");
  EXPECT_EQ(grinder.joints[0].type, JointType::kPrismatic);
  EXPECT_EQ(grinder.joints[4].unit, "deg");
  EXPECT_LT(grinder.joints[4].min, grinder.joints[4].max);

  api::RegisterRobotRequest request;
  request.id = "cell7";
  request.from_preset = "ur5e";
  const api::Robot registered = c.RegisterRobot(request);
  EXPECT_EQ(registered.id, "cell7");
  EXPECT_FALSE(registered.preset);
  EXPECT_EQ(c.GetRobot("cell7").joints.size(), 6u);

  const api::ForwardResult forward = c.RobotForward("cell7", {std::vector<double>(6, 0.0)});
  EXPECT_EQ(forward.robot, "cell7");
  EXPECT_EQ(forward.frame, "world (nominal base)");
  ASSERT_EQ(forward.poses.size(), 1u);
  EXPECT_TRUE(forward.poses[0].has_orientation);

  try {
    c.RegisterRobot(request);
    FAIL() << "registering twice must fail";
  } catch (const ServiceError& e) {
    EXPECT_EQ(e.http_status(), 409);
    EXPECT_EQ(e.status(), api::Status::kAlreadyExists);
  }
  c.DeleteRobot("cell7");
  try {
    c.GetRobot("cell7");
    FAIL() << "deleted robot still there";
  } catch (const ServiceError& e) {
    EXPECT_EQ(e.http_status(), 404);
    EXPECT_EQ(e.status(), api::Status::kNotFound);
  }
}

// Lists follow the server's pages: every item once, in order, whatever the page size.
TEST(ClientTest, ListsFollowEveryPage) {
  testing::TestServer server;
  Client c(Options(server.url()));
  std::vector<std::string> created;
  for (int i = 0; i < 5; ++i) {
    api::CreateCampaignRequest request;
    request.id = "page-" + std::to_string(i);
    request.robot = "ur5e";
    created.push_back(c.CreateCampaign(request).id);
  }
  for (int page_size : {1, 2, 5, 100}) {
    std::vector<std::string> listed;
    for (const api::Campaign& campaign : c.ListCampaigns(page_size)) listed.push_back(campaign.id);
    EXPECT_EQ(listed, created) << "page_size " << page_size;
  }
  std::vector<std::string> robots_by_one, robots_at_once;
  for (const api::Robot& r : c.ListRobots(1)) robots_by_one.push_back(r.id);
  for (const api::Robot& r : c.ListRobots(1000)) robots_at_once.push_back(r.id);
  EXPECT_EQ(robots_by_one, robots_at_once);
  EXPECT_GE(robots_by_one.size(), 3u);
  EXPECT_THROW(c.ListCampaigns(0), std::invalid_argument);
  EXPECT_THROW(c.ListRobots(1001), std::invalid_argument);
}

TEST(ClientTest, InvalidArgumentCarriesFields) {
  testing::TestServer server;
  Client c(Options(server.url()));
  try {
    c.RobotForward("grinder5", {{1.0, 2.0}});
    FAIL() << "wrong joint count accepted";
  } catch (const ServiceError& e) {
    EXPECT_EQ(e.http_status(), 400);
    EXPECT_EQ(e.status(), api::Status::kInvalidArgument);
    ASSERT_FALSE(e.details().empty());
    EXPECT_EQ(e.details()[0].field.rfind("joints[0]", 0), 0u) << e.details()[0].field;
  }
}

TEST(ClientTest, PlansAndOperations) {
  testing::TestServer server;
  Client c(Options(server.url()));
  api::PlanRequest request;
  request.robot = "grinder5";
  request.num_configurations = 8;
  request.options.k_max = 10;
  request.num_validation = 10;
  const api::PlanResult plan = c.CreatePlan(request);
  EXPECT_EQ(plan.configurations.size(), 8u);
  EXPECT_EQ(plan.request.num_configurations, 8);
  EXPECT_EQ(plan.joint_units.size(), 5u);
  EXPECT_GT(plan.indices.condition_number, 0.0);
  EXPECT_EQ(c.GetPlan(plan.id).configurations, plan.configurations);

  const api::Operation started = c.StartPlan(request);
  EXPECT_EQ(started.kind, api::OperationKind::kPlan);
  int callbacks = 0;
  const api::Operation done = c.WaitOperation(
      started.id,
      [&callbacks](const api::Operation&) {
        ++callbacks;
        return true;
      },
      std::chrono::milliseconds(10));
  EXPECT_TRUE(done.done);
  EXPECT_EQ(done.state, api::OperationState::kSucceeded);
  EXPECT_GE(callbacks, 1);
  ASSERT_TRUE(done.plan.has_value());
  // Same request, same seed: the same plan.
  EXPECT_EQ(c.GetPlan(*done.plan).configurations, plan.configurations);
  EXPECT_TRUE(c.CancelOperation(started.id).done);
}

TEST(ClientTest, CampaignFlow) {
  testing::TestServer server;
  Client c(Options(server.url()));
  const Calibrated calibrated = MakeCalibratedCampaign(c);
  const std::string id = calibrated.campaign.id;

  const api::Campaign campaign = c.GetCampaign(id);
  EXPECT_EQ(campaign.plan, calibrated.plan.id);
  EXPECT_EQ(campaign.counts.calibration, 20);
  EXPECT_EQ(campaign.counts.validation, 10);
  EXPECT_TRUE(campaign.calibrated);
  // The list's items are the same campaigns, counts and calibrated included (they once read as uncalibrated).
  const std::vector<api::Campaign> listed = c.ListCampaigns();
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(nlohmann::json(listed[0]), nlohmann::json(campaign));
  EXPECT_TRUE(listed[0].calibrated);
  api::CreateCampaignRequest fresh;
  fresh.robot = "grinder5";
  const std::string uncalibrated = c.CreateCampaign(fresh).id;
  for (const api::Campaign& item : c.ListCampaigns()) EXPECT_EQ(item.calibrated, item.id != uncalibrated) << item.id;

  const api::MeasurementList first = c.ListMeasurements(id, api::MeasurementRole::kCalibration, 0, 15);
  EXPECT_EQ(first.campaign, id);
  EXPECT_EQ(first.measurements.size(), 15u);
  ASSERT_TRUE(first.next_after.has_value());
  const api::MeasurementList rest = c.ListMeasurements(id, api::MeasurementRole::kCalibration, *first.next_after, 15);
  EXPECT_EQ(rest.measurements.size(), 5u);
  EXPECT_EQ(rest.measurements[0].role, api::MeasurementRole::kCalibration);
  EXPECT_EQ(c.ListMeasurements(id, api::MeasurementRole::kValidation).measurements.size(), 10u);
  EXPECT_EQ(c.ListMeasurements(id).measurements.size(), 30u);

  const api::CalibrationResult calibration = c.GetCalibration(id);
  EXPECT_EQ(calibration.campaign, id);
  EXPECT_FALSE(calibration.parameters.empty());
  EXPECT_LT(calibration.residuals_after.rms_position_mm, calibration.residuals_before.rms_position_mm);

  const api::CompensatedTargets compensated = c.CompensateJoints(id, {calibrated.plan.configurations[0]});
  EXPECT_EQ(compensated.campaign, id);
  ASSERT_EQ(compensated.results.size(), 1u);
  EXPECT_TRUE(compensated.results[0].converged) << compensated.results[0].message;
  EXPECT_EQ(compensated.results[0].joints.size(), 5u);
  EXPECT_GT(compensated.results[0].iterations, 0);

  const api::ForwardResult forward = c.CampaignForward(id, {calibrated.plan.configurations[0]});
  EXPECT_EQ(forward.campaign, id);
  EXPECT_EQ(forward.frame, "tracker");
  ASSERT_EQ(forward.poses.size(), 1u);

  const api::Evaluation evaluation = c.Evaluate(id);
  EXPECT_EQ(evaluation.num_validation, 10);
  EXPECT_LT(evaluation.calibrated.e_xyz_mm.mean, evaluation.nominal.e_xyz_mm.mean);

  // The report: an HTML page whose parameter table is the calibration's, and whose validation table takes h_mm.
  const std::string page = c.GetCampaignReport(id);
  EXPECT_EQ(page.rfind("<!DOCTYPE html>", 0), 0u);
  for (const api::ParameterEstimate& p : calibration.parameters) {
    EXPECT_NE(page.find("<tr data-parameter=\"" + p.name + "\">"), std::string::npos) << p.name;
  }
  EXPECT_NE(c.GetCampaignReport(id, 50.0).find("id=\"h-mm\" data-value=\"50\""), std::string::npos);
  try {
    (void)c.GetCampaignReport(uncalibrated);
    ADD_FAILURE() << "a report of an uncalibrated campaign";
  } catch (const ServiceError& e) {
    EXPECT_EQ(e.status(), api::Status::kFailedPrecondition);
  }
  try {
    (void)c.GetCampaignReport(id, -1.0);
    ADD_FAILURE() << "a negative h_mm";
  } catch (const ServiceError& e) {
    EXPECT_EQ(e.http_status(), 400);
    ASSERT_FALSE(e.details().empty());
    EXPECT_EQ(e.details()[0].field, "h_mm");
  }
}

TEST(ClientTest, AsyncFitIsAnOperationWhoseResultIsTheStoredFit) {
  testing::TestServer server;
  Client c(Options(server.url()));
  const Calibrated calibrated = MakeCalibratedCampaign(c);
  // stored and deadline_exceeded are what the server sent: a fit without them is a ProtocolError (protocol_test).
  const api::CalibrationResult sync = c.GetCalibration(calibrated.campaign.id);
  EXPECT_TRUE(sync.stored);
  EXPECT_FALSE(sync.summary.deadline_exceeded);
  EXPECT_EQ(sync.summary.termination, Termination::kConvergence);
  const api::Operation started = c.StartFit(calibrated.campaign.id);
  EXPECT_EQ(started.kind, api::OperationKind::kFit);
  EXPECT_EQ(started.campaign, calibrated.campaign.id);
  const api::Operation done = c.WaitOperation(started.id, nullptr, std::chrono::milliseconds(5));
  ASSERT_EQ(done.state, api::OperationState::kSucceeded) << nlohmann::json(done).dump();
  ASSERT_TRUE(done.fit.has_value());
  EXPECT_TRUE(done.fit->stored);
  EXPECT_FALSE(done.plan.has_value());
  ASSERT_EQ(done.fit->parameters.size(), sync.parameters.size());
  // The same data and request give the same fit, now stored again.
  for (size_t k = 0; k < sync.parameters.size(); ++k) {
    EXPECT_EQ(done.fit->parameters[k].name, sync.parameters[k].name);
    EXPECT_DOUBLE_EQ(done.fit->parameters[k].value, sync.parameters[k].value);
  }
  EXPECT_EQ(c.GetCalibration(calibrated.campaign.id).created_unix_ms, done.fit->created_unix_ms);
}

TEST(ClientTest, UploadIsIdempotentByRequestId) {
  testing::TestServer server;
  Client c(Options(server.url()));
  api::CreateCampaignRequest campaign_request;
  campaign_request.robot = "grinder5";
  const api::Campaign campaign = c.CreateCampaign(campaign_request);
  mock::MockTrackerOptions options;
  VirtualCell cell = mock::MakeCell(options);
  api::MeasurementBatchRequest batch =
      mock::MeasurementBatch(&cell, {{0, 0, 0, 0, 0}}, api::MeasurementRole::kCalibration, options);
  batch.request_id.clear();  // derived from the content

  const api::BatchResult first = c.UploadMeasurements(campaign.id, batch);
  EXPECT_EQ(first.campaign, campaign.id);
  EXPECT_FALSE(first.replayed);
  EXPECT_EQ(first.request_id, client::ContentRequestId(batch));
  const api::BatchResult again = c.UploadMeasurements(campaign.id, batch);
  EXPECT_TRUE(again.replayed);
  EXPECT_EQ(again.batch_id, first.batch_id);
  EXPECT_EQ(c.GetCampaign(campaign.id).counts.calibration, first.count);

  batch.request_id = first.request_id;
  batch.measurements.pop_back();
  try {
    c.UploadMeasurements(campaign.id, batch);
    FAIL() << "reused request id with other content accepted";
  } catch (const ServiceError& e) {
    EXPECT_EQ(e.http_status(), 409);
    ASSERT_FALSE(e.details().empty());
    EXPECT_EQ(e.details()[0].field, "request_id");
  }
}

TEST(ClientTest, FitWithoutMeasurementsIsFailedPrecondition) {
  testing::TestServer server;
  Client c(Options(server.url()));
  api::CreateCampaignRequest request;
  request.robot = "grinder5";
  const api::Campaign campaign = c.CreateCampaign(request);
  try {
    c.Fit(campaign.id);
    FAIL();
  } catch (const ServiceError& e) {
    EXPECT_EQ(e.status(), api::Status::kFailedPrecondition);
    EXPECT_EQ(e.http_status(), 400);
  }
}

TEST(ClientTest, BearerToken) {
  testing::TestServer server({"s3cret"});
  Client anonymous(Options(server.url()));
  EXPECT_EQ(anonymous.GetHealth().status, "ok");  // liveness needs no token
  try {
    anonymous.ListRobots();
    FAIL();
  } catch (const ServiceError& e) {
    EXPECT_EQ(e.http_status(), 401);
    EXPECT_EQ(e.status(), api::Status::kUnauthenticated);
  }
  ClientOptions with_token = Options(server.url());
  with_token.bearer_token = "s3cret";
  Client authorised(with_token);
  EXPECT_FALSE(authorised.ListRobots().empty());
}

TEST(ClientTest, ConnectionFailureAfterRetries) {
  std::string url;
  {
    testing::TestServer server;
    url = server.url();
  }  // the port is closed now
  ClientOptions options = Options(url);
  options.connect_timeout = std::chrono::milliseconds(500);
  Client c(options);
  EXPECT_THROW(c.GetHealth(), client::ConnectionError);
  EXPECT_THROW(c.CreatePlan(api::PlanRequest{}), client::ConnectionError);
}

TEST(ClientTest, InvalidOptions) {
  ClientOptions options;
  options.server_url = "127.0.0.1:8080";
  std::string error;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(error.find("http://"), std::string::npos);
  EXPECT_THROW(Client{options}, std::invalid_argument);
  options.server_url = "http://host:1/path";
  EXPECT_FALSE(options.IsValid(&error));
}

// Joints as api::Robot gives them: the CSV columns take the name and the unit.
api::RobotJoint Joint(const std::string& name, const std::string& unit) {
  api::RobotJoint joint;
  joint.name = name;
  joint.type = unit == "deg" ? JointType::kRevolute : JointType::kPrismatic;
  joint.unit = unit;
  return joint;
}

TEST(CsvTest, JointsRoundTrip) {
  const std::vector<api::RobotJoint> joints = {Joint("x", "mm"), Joint("b", "deg")};
  std::stringstream s;
  client::WriteJointsCsv(s, joints, {{1.5, -20.25}, {3, 4}});
  EXPECT_EQ(s.str().substr(0, 11), "x_mm,b_deg\n");
  const auto rows = client::ReadJointsCsv(s, 2);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_DOUBLE_EQ(rows[0][1], -20.25);
}

// Values below the normal double range make strtod report ERANGE, yet they are finite values a plan or a
// measurement can hold, and the writer writes them; the reader must give them back (found by the csv fuzzer).
TEST(CsvTest, SubnormalValuesReadBackAsWritten) {
  const std::vector<api::RobotJoint> joints = {Joint("x", "mm")};
  const std::vector<std::vector<double>> rows = {
      {1.3833344017909062e-319}, {-2.5e-310}, {std::numeric_limits<double>::denorm_min()}};
  std::stringstream s;
  client::WriteJointsCsv(s, joints, rows);
  EXPECT_EQ(client::ReadJointsCsv(s, 1), rows);
  // Text below even the subnormals rounds to zero, as any decimal conversion does.
  std::istringstream tiny("x_mm\n1e-400\n");
  EXPECT_EQ(client::ReadJointsCsv(tiny, 1), (std::vector<std::vector<double>>{{0.0}}));
}

// Compensation targets: joint rows, or pose rows with the branch columns in any order (an empty cell leaves the
// flag free); a bad flag or a stray column is named with its line and column.
TEST(CsvTest, CompensationTargetsJointsOrPosesWithBranches) {
  std::istringstream joints("x_mm,b_deg\n1,2\n3,4\n");
  const auto j = client::ReadCompensationTargetsCsv(joints, 2);
  ASSERT_EQ(j.size(), 2u);
  EXPECT_FALSE(j[0].pose.has_value());
  EXPECT_EQ(j[1].joints, (std::vector<double>{3, 4}));
  std::istringstream poses(
      "x_mm,y_mm,z_mm,qw,qx,qy,qz,wrist,shoulder\n1,2,3,1,0,0,0,flip,back\n4,5,6,0,1,0,0,,front\n");
  const auto p = client::ReadCompensationTargetsCsv(poses, 6, TargetFrame::kBase);
  ASSERT_EQ(p.size(), 2u);
  ASSERT_TRUE(p[0].pose.has_value());
  EXPECT_EQ(p[0].frame, TargetFrame::kBase);
  EXPECT_EQ(p[0].pose->position_mm[2], 3.0);
  EXPECT_EQ(p[0].configuration, (ArmConfiguration{-1, 0, -1}));
  EXPECT_EQ(p[1].configuration, (ArmConfiguration{1, 0, 0}));
  EXPECT_EQ(p[1].pose->quaternion[1], 1.0);
  std::istringstream bad_flag("x_mm,y_mm,z_mm,qw,qx,qy,qz,elbow\n1,2,3,1,0,0,0,sideways\n");
  try {
    client::ReadCompensationTargetsCsv(bad_flag, 6);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "line 2, column 8: not a elbow flag: \"sideways\"");
  }
  std::istringstream stray("x_mm,y_mm,z_mm,qw,qx,qy,qz,knee\n1,2,3,1,0,0,0,up\n");
  EXPECT_THROW(client::ReadCompensationTargetsCsv(stray, 6), std::runtime_error);
  std::istringstream short_joints("a_deg\n1\n");
  EXPECT_THROW(client::ReadCompensationTargetsCsv(short_joints, 6), std::runtime_error);
}

// Results of a robot with named branches carry shoulder, elbow, wrist (and branch_change in a sequence).
TEST(CsvTest, CompensationResultsWithBranches) {
  const std::vector<api::RobotJoint> joints = {Joint("a", "deg")};
  api::Compensation first, second, none;
  first.joints = {1.0};
  first.converged = true;
  first.predicted_error_mm = 0.25;
  first.configuration = ArmConfiguration{1, -1, 1};
  second = first;
  second.configuration = ArmConfiguration{1, -1, -1};
  second.branch_change = true;
  second.joint_jump_deg = 2.0;
  std::stringstream s;
  client::WriteCompensationCsv(s, joints, {first, second, none}, true);
  EXPECT_EQ(s.str(),
            "a_deg,position_error_mm,orientation_error_deg,predicted_error_mm,converged,shoulder,elbow,wrist,"
            "joint_jump_deg,joint_jump,branch_change\n"
            "1,0,0,0.25,1,front,down,noflip,,0,0\n"
            "1,0,0,0.25,1,front,down,flip,2,0,1\n"
            "nan,0,0,,0,,,,,0,0\n");
  std::stringstream plain;
  client::WriteCompensationCsv(plain, joints, {none}, false);
  EXPECT_EQ(plain.str(), "a_deg,position_error_mm,orientation_error_deg,predicted_error_mm,converged\nnan,0,0,,0\n");
}

TEST(CsvTest, MeasurementsWithAndWithoutOrientation) {
  std::istringstream full("# a comment\nq1_deg,x_mm,y_mm,z_mm,qw,qx,qy,qz\n10,1,2,3,1,0,0,0\n");
  const auto m = client::ReadMeasurementsCsv(full, 1);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_TRUE(m[0].pose.has_orientation);
  std::istringstream position("q1_deg,x_mm,y_mm,z_mm\n10,1,2,3\n");
  EXPECT_FALSE(client::ReadMeasurementsCsv(position, 1)[0].pose.has_orientation);
  // A campaign with reflectors: a last column names each shot's nest, and is written back.
  std::istringstream nests("q1_deg,x_mm,y_mm,z_mm,reflector\n10,1,2,3,smr1\n10,4,5,6,smr2\n");
  const auto shots = client::ReadMeasurementsCsv(nests, 1);
  ASSERT_EQ(shots.size(), 2u);
  EXPECT_EQ(shots[1].reflector, "smr2");
  EXPECT_FALSE(shots[1].pose.has_orientation);
  std::ostringstream written;
  client::WriteMeasurementsCsv(written, {Joint("q1", "deg")}, shots);
  EXPECT_EQ(written.str(), "q1_deg,x_mm,y_mm,z_mm,reflector\n10,1,2,3,smr1\n10,4,5,6,smr2\n");
  std::istringstream bad_id("q1_deg,x_mm,y_mm,z_mm,reflector\n10,1,2,3,SMR 1\n");
  EXPECT_THROW(client::ReadMeasurementsCsv(bad_id, 1), std::runtime_error);
  std::istringstream bad("q1_deg,x_mm,y_mm,z_mm\n10,1,zwei,3\n");
  try {
    client::ReadMeasurementsCsv(bad, 1);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("line 2, column 3"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace robocal
