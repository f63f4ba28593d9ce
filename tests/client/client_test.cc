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
  client::PlanResult plan;
  client::Campaign campaign;
};

Calibrated MakeCalibratedCampaign(Client& c) {
  api::PlanRequest plan_request;
  plan_request.robot = "grinder5";
  plan_request.num_configurations = 10;
  plan_request.k_max = 20;
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
  const auto batch_json = mock::MeasurementBatch(&cell, out.plan.configurations, "calibration", options);
  api::MeasurementBatchRequest batch;
  batch.role = "calibration";
  for (const auto& m : batch_json.at("measurements")) batch.measurements.push_back(api::MeasurementFromJson(m));
  c.UploadMeasurements(out.campaign.id, batch);
  c.Fit(out.campaign.id);
  const auto validation = mock::MeasurementBatch(&cell, out.plan.configurations, "validation", options);
  api::MeasurementBatchRequest vbatch;
  vbatch.role = "validation";
  for (const auto& m : validation.at("measurements")) vbatch.measurements.push_back(api::MeasurementFromJson(m));
  c.UploadMeasurements(out.campaign.id, vbatch);
  return out;
}

TEST(ClientTest, ServiceEndpoints) {
  testing::TestServer server;
  Client c(Options(server.url()));
  EXPECT_EQ(c.GetHealth().status, "ok");
  EXPECT_EQ(c.GetOpenApi().value("openapi", ""), "3.0.3");
  EXPECT_NE(c.GetMetrics().find("robocal_http_requests_total"), std::string::npos);
}

TEST(ClientTest, Robots) {
  testing::TestServer server;
  Client c(Options(server.url()));
  const auto robots = c.ListRobots();
  ASSERT_GE(robots.size(), 3u);
  EXPECT_EQ(robots[0].id, "grinder5");
  const client::RobotInfo grinder = c.GetRobot("grinder5");
  EXPECT_TRUE(grinder.preset);
  EXPECT_EQ(grinder.joints.size(), 5u);
  EXPECT_EQ(grinder.joints[0].unit, "mm");
  EXPECT_EQ(grinder.joints[4].unit, "deg");

  api::RegisterRobotRequest request;
  request.id = "cell7";
  request.from_preset = "ur5e";
  const client::RobotInfo registered = c.RegisterRobot(request);
  EXPECT_EQ(registered.id, "cell7");
  EXPECT_FALSE(registered.preset);
  EXPECT_EQ(c.GetRobot("cell7").joints.size(), 6u);

  const auto poses = c.RobotForward("cell7", {std::vector<double>(6, 0.0)});
  ASSERT_EQ(poses.size(), 1u);
  EXPECT_TRUE(poses[0].has_orientation);

  try {
    c.RegisterRobot(request);
    FAIL() << "registering twice must fail";
  } catch (const ServiceError& e) {
    EXPECT_EQ(e.http_status(), 409);
    EXPECT_EQ(e.status(), "ALREADY_EXISTS");
  }
  c.DeleteRobot("cell7");
  try {
    c.GetRobot("cell7");
    FAIL() << "deleted robot still there";
  } catch (const ServiceError& e) {
    EXPECT_EQ(e.http_status(), 404);
    EXPECT_EQ(e.status(), "NOT_FOUND");
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
    for (const client::Campaign& campaign : c.ListCampaigns(page_size)) listed.push_back(campaign.id);
    EXPECT_EQ(listed, created) << "page_size " << page_size;
  }
  std::vector<std::string> robots_by_one, robots_at_once;
  for (const client::RobotInfo& r : c.ListRobots(1)) robots_by_one.push_back(r.id);
  for (const client::RobotInfo& r : c.ListRobots(1000)) robots_at_once.push_back(r.id);
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
    EXPECT_EQ(e.status(), "INVALID_ARGUMENT");
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
  request.k_max = 10;
  request.num_validation = 10;
  const client::PlanResult plan = c.CreatePlan(request);
  EXPECT_EQ(plan.configurations.size(), 8u);
  EXPECT_EQ(plan.joint_units.size(), 5u);
  EXPECT_GT(plan.indices.condition_number, 0.0);
  EXPECT_EQ(c.GetPlan(plan.id).configurations, plan.configurations);

  const client::Operation started = c.StartPlan(request);
  EXPECT_EQ(started.kind, "plan");
  int callbacks = 0;
  const client::Operation done = c.WaitOperation(
      started.id,
      [&callbacks](const client::Operation&) {
        ++callbacks;
        return true;
      },
      std::chrono::milliseconds(10));
  EXPECT_TRUE(done.done);
  EXPECT_EQ(done.state, "SUCCEEDED");
  EXPECT_GE(callbacks, 1);
  // Same request, same seed: the same plan.
  EXPECT_EQ(c.GetPlan(done.plan).configurations, plan.configurations);
  EXPECT_TRUE(c.CancelOperation(started.id).done);
}

TEST(ClientTest, CampaignFlow) {
  testing::TestServer server;
  Client c(Options(server.url()));
  const Calibrated calibrated = MakeCalibratedCampaign(c);
  const std::string id = calibrated.campaign.id;

  const client::Campaign campaign = c.GetCampaign(id);
  EXPECT_EQ(campaign.plan, calibrated.plan.id);
  EXPECT_EQ(campaign.calibration_count, 20);
  EXPECT_EQ(campaign.validation_count, 10);
  EXPECT_TRUE(campaign.calibrated);
  ASSERT_EQ(c.ListCampaigns().size(), 1u);

  const client::MeasurementPage first = c.ListMeasurements(id, "calibration", 0, 15);
  EXPECT_EQ(first.measurements.size(), 15u);
  ASSERT_TRUE(first.next_after.has_value());
  const client::MeasurementPage rest = c.ListMeasurements(id, "calibration", *first.next_after, 15);
  EXPECT_EQ(rest.measurements.size(), 5u);

  const client::CalibrationResult calibration = c.GetCalibration(id);
  EXPECT_FALSE(calibration.parameters.empty());
  EXPECT_LT(calibration.residuals_after.rms_position_mm, calibration.residuals_before.rms_position_mm);

  const auto compensated = c.CompensateJoints(id, {calibrated.plan.configurations[0]});
  ASSERT_EQ(compensated.size(), 1u);
  EXPECT_TRUE(compensated[0].converged) << compensated[0].message;
  EXPECT_EQ(compensated[0].joints.size(), 5u);

  const auto poses = c.CampaignForward(id, {calibrated.plan.configurations[0]});
  ASSERT_EQ(poses.size(), 1u);

  const client::Evaluation evaluation = c.Evaluate(id);
  EXPECT_EQ(evaluation.num_validation, 10);
  EXPECT_LT(evaluation.calibrated.e_xyz_mm.mean, evaluation.nominal.e_xyz_mm.mean);
}

TEST(ClientTest, AsyncFitIsAnOperationWhoseResultIsTheStoredFit) {
  testing::TestServer server;
  Client c(Options(server.url()));
  const Calibrated calibrated = MakeCalibratedCampaign(c);
  const client::CalibrationResult sync = c.GetCalibration(calibrated.campaign.id);
  EXPECT_TRUE(sync.stored);
  EXPECT_FALSE(sync.deadline_exceeded);
  const client::Operation started = c.StartFit(calibrated.campaign.id);
  EXPECT_EQ(started.kind, "fit");
  const client::Operation done = c.WaitOperation(started.id, nullptr, std::chrono::milliseconds(5));
  ASSERT_EQ(done.state, "SUCCEEDED") << done.raw.dump();
  ASSERT_TRUE(done.fit.has_value());
  EXPECT_TRUE(done.fit->stored);
  EXPECT_TRUE(done.plan.empty());
  ASSERT_EQ(done.fit->parameters.size(), sync.parameters.size());
  // The same data and request give the same fit, now stored again.
  for (size_t k = 0; k < sync.parameters.size(); ++k) {
    EXPECT_EQ(done.fit->parameters[k].name, sync.parameters[k].name);
    EXPECT_DOUBLE_EQ(done.fit->parameters[k].value, sync.parameters[k].value);
  }
  EXPECT_EQ(c.GetCalibration(calibrated.campaign.id).raw.at("created_unix_ms"),
            done.fit->raw.at("created_unix_ms"));
}

TEST(ClientTest, UploadIsIdempotentByRequestId) {
  testing::TestServer server;
  Client c(Options(server.url()));
  api::CreateCampaignRequest campaign_request;
  campaign_request.robot = "grinder5";
  const client::Campaign campaign = c.CreateCampaign(campaign_request);
  mock::MockTrackerOptions options;
  VirtualCell cell = mock::MakeCell(options);
  const auto batch_json = mock::MeasurementBatch(&cell, {{0, 0, 0, 0, 0}}, "calibration", options);
  api::MeasurementBatchRequest batch;
  for (const auto& m : batch_json.at("measurements")) batch.measurements.push_back(api::MeasurementFromJson(m));

  const client::UploadResult first = c.UploadMeasurements(campaign.id, batch);
  EXPECT_FALSE(first.replayed);
  EXPECT_EQ(first.request_id, client::ContentRequestId(batch));
  const client::UploadResult again = c.UploadMeasurements(campaign.id, batch);
  EXPECT_TRUE(again.replayed);
  EXPECT_EQ(again.batch_id, first.batch_id);
  EXPECT_EQ(c.GetCampaign(campaign.id).calibration_count, first.count);

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
  const client::Campaign campaign = c.CreateCampaign(request);
  try {
    c.Fit(campaign.id);
    FAIL();
  } catch (const ServiceError& e) {
    EXPECT_EQ(e.status(), "FAILED_PRECONDITION");
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
    EXPECT_EQ(e.status(), "UNAUTHENTICATED");
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

TEST(CsvTest, JointsRoundTrip) {
  const std::vector<client::JointInfo> joints = {{"x", "prismatic", "mm", 0, 1}, {"b", "revolute", "deg", 0, 1}};
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
  const std::vector<client::JointInfo> joints = {{"x", "prismatic", "mm", 0, 1}};
  const std::vector<std::vector<double>> rows = {
      {1.3833344017909062e-319}, {-2.5e-310}, {std::numeric_limits<double>::denorm_min()}};
  std::stringstream s;
  client::WriteJointsCsv(s, joints, rows);
  EXPECT_EQ(client::ReadJointsCsv(s, 1), rows);
  // Text below even the subnormals rounds to zero, as any decimal conversion does.
  std::istringstream tiny("x_mm\n1e-400\n");
  EXPECT_EQ(client::ReadJointsCsv(tiny, 1), (std::vector<std::vector<double>>{{0.0}}));
}

TEST(CsvTest, MeasurementsWithAndWithoutOrientation) {
  std::istringstream full("# a comment\nq1_deg,x_mm,y_mm,z_mm,qw,qx,qy,qz\n10,1,2,3,1,0,0,0\n");
  const auto m = client::ReadMeasurementsCsv(full, 1);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_TRUE(m[0].pose.has_orientation);
  std::istringstream position("q1_deg,x_mm,y_mm,z_mm\n10,1,2,3\n");
  EXPECT_FALSE(client::ReadMeasurementsCsv(position, 1)[0].pose.has_orientation);
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
