// Wire types: validation names every bad field, conversions keep units straight.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "robocal/api/calibration.h"
#include "robocal/api/campaigns.h"
#include "robocal/api/json_reader.h"
#include "robocal/api/text.h"
#include "robocal/api/plans.h"
#include "robocal/api/robots.h"
#include "robocal/core/presets.h"

namespace robocal::api {
namespace {

using nlohmann::json;

// The violations of a request that is expected to fail validation.
std::vector<FieldViolation> Violations(const std::function<void()>& parse) {
  try {
    parse();
  } catch (const ApiError& e) {
    EXPECT_EQ(e.status(), Status::kInvalidArgument);
    return e.details();
  }
  ADD_FAILURE() << "no error";
  return {};
}

bool HasField(const std::vector<FieldViolation>& v, const std::string& field) {
  for (const auto& f : v) {
    if (f.field == field) return true;
  }
  return false;
}

// The published FNV-1a 64-bit test vectors: the hash client and server agree on for idempotent uploads.
TEST(ContentHashTest, IsFnv1a64) {
  EXPECT_EQ(ContentHash(""), "cbf29ce484222325");
  EXPECT_EQ(ContentHash("a"), "af63dc4c8601ec8c");
  EXPECT_EQ(ContentHash("foobar"), "85944171f73967e8");
}

TEST(ApiTest, MalformedJsonIsInvalidArgument) {
  EXPECT_THROW(ParseBody("{\"a\":"), ApiError);
  EXPECT_THROW(ParseBody("[1,2]"), ApiError);
  EXPECT_NO_THROW(ParseBody("{}"));
  // JSON has no Inf, but a literal beyond double range would become one.
  try {
    ParseBody(R"({"joints":[[0,0,0,0,0,1e999]]})");
    ADD_FAILURE() << "accepted 1e999";
  } catch (const ApiError& e) {
    EXPECT_EQ(e.details().at(0).field, "body");
  }
}

TEST(SafeTextTest, KeepsUtf8AndEscapesEverythingElse) {
  using api::SafeText;
  EXPECT_EQ(SafeText("joint 3 dz"), "joint 3 dz");
  EXPECT_EQ(SafeText("\xc3\xa9\xe2\x82\xac\xf0\x9f\x98\x80"), "\xc3\xa9\xe2\x82\xac\xf0\x9f\x98\x80");  // e-acute, euro, emoji
  EXPECT_EQ(SafeText("a\xff" "b"), "a\\xffb");
  EXPECT_EQ(SafeText("\xc3\x28"), "\\xc3(");                                 // a lead byte without its continuation
  EXPECT_EQ(SafeText("\xc0\xaf"), "\\xc0\\xaf");                            // overlong '/'
  EXPECT_EQ(SafeText("\xed\xa0\x80"), "\\xed\\xa0\\x80");                   // a UTF-16 surrogate
  EXPECT_EQ(SafeText("\xf4\x90\x80\x80"), "\\xf4\\x90\\x80\\x80");          // above U+10FFFF
  EXPECT_EQ(SafeText("\xe2\x82"), "\\xe2\\x82");                            // cut short at the end
  EXPECT_EQ(SafeText(std::string("a\0b\x1b[31m\x7f", 9)), "a\\x00b\\x1b[31m\\x7f");
  EXPECT_EQ(SafeText(std::string(10, 'x'), 4), "xxxx...");
  for (const std::string raw : {"\xff\xfe", "ok", "\x1b\xc3"}) EXPECT_EQ(SafeText(SafeText(raw)), SafeText(raw));
  EXPECT_TRUE(api::IsValidUtf8("\xc3\xa9"));
  EXPECT_FALSE(api::IsValidUtf8("\xc3"));
  // An error made from request bytes can always be serialised.
  const api::ApiError e(api::Status::kInvalidArgument, "bad \xff", {{"f\xfe", "r\x01"}});
  EXPECT_EQ(std::string(e.what()), "bad \\xff");
  EXPECT_EQ(e.details()[0].field, "f\\xfe");
  EXPECT_NO_THROW((void)api::ErrorBody(e.status(), 400, "raw \xff", e.details()).dump());
}

TEST(ApiTest, DuplicateKeysAreNamedByTheirPath) {
  try {
    (void)api::ParseBody(R"({"a":[{"b":1},{"b":1,"c":{"d":1,"d":2}}],"e":1,"e":2})");
    FAIL() << "duplicates accepted";
  } catch (const api::ApiError& e) {
    ASSERT_EQ(e.details().size(), 2u);
    EXPECT_EQ(e.details()[0].field, "a[1].c.d");
    EXPECT_EQ(e.details()[1].field, "e");
  }
  // Deep nesting is refused in linear time and memory (a path per level would be quadratic).
  const std::string deep = std::string(4000000, '[') + std::string(4000000, ']');
  try {
    (void)api::ParseBody("{\"a\":" + deep + "}");
    FAIL() << "deep nesting accepted";
  } catch (const api::ApiError& e) {
    EXPECT_EQ(e.details()[0].field, "body");
  }
  EXPECT_NO_THROW((void)api::ParseBody("{\"a\":" + std::string(31, '[') + std::string(31, ']') + "}"));
  // Arrays and objects beyond the element limit are refused with their path before values are built.
  try {
    (void)api::ParseBody(R"({"a":{"b":[1,2,3,4]}})", 3);
    FAIL() << "a long array accepted";
  } catch (const api::ApiError& e) {
    EXPECT_EQ(e.details()[0].field, "a.b");
    EXPECT_NE(e.details()[0].reason.find("limit 3"), std::string::npos) << e.details()[0].reason;
  }
  try {
    (void)api::ParseBody(R"({"a":1,"b":2,"c":3,"d":4})", 3);
    FAIL() << "a wide object accepted";
  } catch (const api::ApiError& e) {
    EXPECT_EQ(e.details()[0].field, "body");
  }
  EXPECT_NO_THROW((void)api::ParseBody(R"({"a":[[1,2,3],[4,5,6],[7,8,9]]})", 3));
  // The same key in sibling objects is no duplicate.
  EXPECT_NO_THROW((void)api::ParseBody(R"({"a":[{"b":1},{"b":2}],"c":{"b":3}})"));
}

TEST(ApiTest, MeasurementBatchCollectsEveryProblem) {
  const RobotModel model = Preset("ur5e");
  const json body = json::parse(R"({
    "request_id": "r1", "role": "calibration",
    "measurements": [
      {"joints": [0,0,0,0,0,0], "pose": {"position_mm": [1,2,3], "quaternion": [1,0,0,0]}},
      {"joints": [0,0,0,0,0], "pose": {"position_mm": [1,2,3], "quaternion": [1,0,0,0]}},
      {"joints": [0,0,0,0,0,"9"], "pose": {"position_mm": [1,2,"x"], "rpy_deg": [0,0,0]}},
      {"joints": [0,0,0,0,0,9000], "pose": {"position_mm": [1,2,3]}}
    ]})");
  auto v = Violations([&] { ParseMeasurementBatchRequest(body, model, MeasurementType::kPose, Limits{}); });
  EXPECT_TRUE(HasField(v, "measurements[1].joints"));
  EXPECT_TRUE(HasField(v, "measurements[2].joints[5]"));
  EXPECT_TRUE(HasField(v, "measurements[2].pose.position_mm[2]"));
  EXPECT_TRUE(HasField(v, "measurements[3].joints[5]"));
  EXPECT_TRUE(HasField(v, "measurements[3].pose.quaternion"));
  for (const auto& f : v) {
    if (f.field == "measurements[1].joints") {
      EXPECT_EQ(f.reason, "expected 6 values, got 5");
    }
  }
}

TEST(ApiTest, PositionMeasurementsNeedNoOrientation) {
  const RobotModel model = Preset("grinder5");
  const json body = json::parse(R"({"request_id": "r", "measurements": [
      {"joints": [0,0,0,0,0], "pose": {"position_mm": [1,2,3]}}]})");
  const auto req = ParseMeasurementBatchRequest(body, model, MeasurementType::kPosition, Limits{});
  EXPECT_EQ(req.role, MeasurementRole::kCalibration);
  EXPECT_FALSE(req.measurements[0].pose.has_orientation);
}

TEST(ApiTest, ArraysAreLimited) {
  const RobotModel model = Preset("ur5e");
  Limits limits;
  limits.max_array_length = 2;
  const json body = {{"joints", json::array({json::array({0, 0, 0, 0, 0, 0}), json::array({0, 0, 0, 0, 0, 0}),
                                             json::array({0, 0, 0, 0, 0, 0})})}};
  auto v = Violations([&] { ParseForwardRequest(body, model, limits); });
  ASSERT_TRUE(HasField(v, "joints"));
  EXPECT_NE(v[0].reason.find("limit 2"), std::string::npos);
  auto empty = Violations([&] { ParseForwardRequest(json{{"joints", json::array()}}, model, limits); });
  EXPECT_TRUE(HasField(empty, "joints"));
}

TEST(ApiTest, PlanRequestRejectsUnknownEnumsAndFields) {
  auto v = Violations([] {
    ParsePlanRequest(json::parse(R"({"robot":"ur5e","optimiser":"magic","num_configurations":5000,
                                     "measurment_type":"pose","options":{"k_max":1.5}})"),
                     Limits{});
  });
  EXPECT_TRUE(HasField(v, "optimiser"));
  EXPECT_TRUE(HasField(v, "num_configurations"));
  EXPECT_TRUE(HasField(v, "measurment_type"));
  EXPECT_TRUE(HasField(v, "options.k_max"));
}

std::string ReasonFor(const std::vector<FieldViolation>& v, const std::string& field) {
  for (const auto& f : v) {
    if (f.field == field) return f.reason;
  }
  return "";
}

// Each optimiser's defaults fit the default limits; the limits bound a plan's total work, computed from its
// options alone, and a refusal names every field that sets the total and the limit.
TEST(ApiTest, PlanWorkIsBoundedOnItsTotal) {
  for (const char* optimiser : {"solis_wets", "random", "exchange"}) {
    EXPECT_NO_THROW(ParsePlanRequest(json{{"robot", "ur5e"}, {"optimiser", optimiser}}, Limits{})) << optimiser;
  }
  const PlanRequest capped = ParsePlanRequest(
      json::parse(R"({"robot":"ur5e","options":{"k_max":1000000,"restarts":1000,"max_evaluations":1000}})"), Limits{});
  EXPECT_EQ(MaxWork(capped).evaluations, 1000);
  EXPECT_EQ(MaxWork(capped).jacobians, 1000 * 10 + 2 * 100);

  Limits limits;
  limits.max_plan_jacobians = 5000;
  auto v = Violations([&] {
    ParsePlanRequest(json::parse(R"({"robot":"ur5e","num_configurations":30,"num_validation":10,
                                     "optimiser":"random","options":{"num_sets":200}})"),
                     limits);
  });
  for (const char* field : {"num_configurations", "options.num_sets", "num_validation"}) {
    EXPECT_NE(ReasonFor(v, field).find("6020 configuration Jacobians"), std::string::npos) << field;
    EXPECT_NE(ReasonFor(v, field).find("max_plan_jacobians = 5000"), std::string::npos) << field;
  }

  // Only the chosen optimiser's options count: clients send every option with its default.
  EXPECT_NO_THROW(ParsePlanRequest(json::parse(R"({"robot":"ur5e","options":{"num_candidates":1000000}})"), Limits{}));
  v = Violations([] {
    ParsePlanRequest(json::parse(R"({"robot":"ur5e","optimiser":"exchange","num_configurations":20,
                                     "options":{"num_candidates":10}})"),
                     Limits{});
  });
  EXPECT_NE(ReasonFor(v, "options.num_candidates").find("at least num_configurations"), std::string::npos);
  v = Violations([] {
    ParsePlanRequest(json::parse(R"({"robot":"ur5e","num_configurations":1001,"options":{"max_evaluations":2000000}})"),
                     Limits{});
  });
  EXPECT_NE(ReasonFor(v, "num_configurations").find("max_plan_configurations = 1000"), std::string::npos);
  EXPECT_NE(ReasonFor(v, "options.max_evaluations").find("max_plan_evaluations = 1000000"), std::string::npos);
}

TEST(ApiTest, RegisterRobotRoundTripsThroughTheCore) {
  const json body = json::parse(R"({"id":"arm2","convention":"dh","joints":[
      {"type":"revolute","a_mm":100,"alpha_deg":90,"d_mm":50,"min_deg":-170,"max_deg":170},
      {"type":"prismatic","min_mm":0,"max_mm":500}],
      "tool":{"position_mm":[0,0,100],"rpy_deg":[0,0,90]}})");
  const RegisterRobotRequest req = ParseRegisterRobotRequest(body, Limits{});
  const RobotModel model = RobotModel::Build(ToSpec(req));
  EXPECT_EQ(model.num_joints(), 2);
  EXPECT_NEAR(model.upper_limits()[0], 170.0 * std::numbers::pi / 180.0, 1e-12);
  EXPECT_NEAR(model.upper_limits()[1], 500.0, 1e-12);
  const json again = json(ParseRegisterRobotRequest(json(req), Limits{}));
  EXPECT_EQ(again, json(req));
}

TEST(ApiTest, RegisterRobotNamesCoreProblems) {
  auto v = Violations([] {
    ParseRegisterRobotRequest(json::parse(R"({"id":"Bad/Id","convention":"dh","joints":[
        {"type":"revolute","min_deg":10,"max_deg":-10}]})"),
                              Limits{});
  });
  EXPECT_TRUE(HasField(v, "id"));
  auto w = Violations([] {
    ParseRegisterRobotRequest(json::parse(R"({"id":"ok","convention":"dh","joints":[
        {"type":"revolute","min_deg":10,"max_deg":-10}]})"),
                              Limits{});
  });
  ASSERT_FALSE(w.empty());
  EXPECT_NE(w[0].field.find("joints[0]"), std::string::npos);
}

TEST(ApiTest, JointsConvertDegreesForRevoluteOnly) {
  const RobotModel model = Preset("grinder5");
  std::vector<double> wire = {100, 200, 300, 90, -45};
  const Eigen::VectorXd q = JointsToCore(model, wire);
  EXPECT_NEAR(q[3], std::numbers::pi / 2, 1e-15);
  EXPECT_NEAR(q[0], 100, 1e-15);
  const auto back = JointsToWire(model, q);
  for (int i = 0; i < 5; ++i) EXPECT_NEAR(back[i], wire[i], 1e-12);
}

TEST(ApiTest, PoseAcceptsRpyAndRejectsNonUnitQuaternion) {
  Problems p;
  PoseWire pose;
  ASSERT_TRUE(ParsePose(json::parse(R"({"position_mm":[1,2,3],"rpy_deg":[0,0,90]})"), "pose", true, &p, &pose));
  EXPECT_NEAR(pose.quaternion[0], std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(pose.quaternion[3], std::sqrt(0.5), 1e-12);
  EXPECT_FALSE(ParsePose(json::parse(R"({"position_mm":[1,2,3],"quaternion":[2,0,0,0]})"), "pose", true, &p,
                         &pose));
  EXPECT_TRUE(HasField(p.list(), "pose.quaternion"));
}

TEST(ApiTest, ErrorBodyShape) {
  const json body = ErrorBody(Status::kNotFound, 404, "no robot", {{"robot", "unknown"}});
  EXPECT_EQ(body["error"]["status"], "NOT_FOUND");
  EXPECT_EQ(body["error"]["code"], 404);
  EXPECT_EQ(body["error"]["details"][0]["field"], "robot");
}

TEST(ApiTest, NonFiniteNumbersBecomeNull) {
  EXPECT_TRUE(Num(std::numeric_limits<double>::infinity()).is_null());
  EXPECT_EQ(Num(2.5), json(2.5));
}

}  // namespace
}  // namespace robocal::api
