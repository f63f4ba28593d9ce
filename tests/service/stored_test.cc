// Stored documents (api/stored.h): every older schema version still loads, and a stored calibration comes back
// whole (Restore) through the document's JSON text.
#include <cmath>

#include <gtest/gtest.h>

#include "robocal/api/stored.h"
#include "robocal/core/planning.h"
#include "robocal/core/presets.h"
#include "robocal/core/random.h"
#include "robocal/core/virtual_cell.h"

namespace robocal::api {
namespace {

using nlohmann::json;

// The nominal robot as a calibration: no parameters estimated, every error zero.
Calibration Uncalibrated(const RobotModel& model) {
  return Calibration{.model = model,
                     .errors = Eigen::VectorXd::Zero(model.num_error_parameters()),
                     .parameters = {},
                     .covariance = {},
                     .T_world_base = Transform::Identity(),
                     .T_flange_tool = Transform::Identity(),
                     .reflectors = {},
                     .summary = {}};
}

// ---------------------------------------------------------------------------------------------- stored documents

// Documents as the server wrote them before stored documents had a schema version (copied from a database of
// that version): they still load, including values the request validation of today refuses (a theta of 400 deg
// and a description longer than 1024 characters would be refused as requests).
TEST(StoredDocumentTest, PreviousSchemaVersionStillLoads) {
  const std::string long_text(2000, 'x');
  const json robot_v1 = {
      {"id", "old"},
      {"description", long_text},
      {"convention", "mdh"},
      {"joints",
       {{{"type", "revolute"}, {"a_mm", 0}, {"alpha_deg", 0}, {"d_mm", 300}, {"theta_deg", 400}, {"min_deg", -170},
         {"max_deg", 170}},
        {{"name", "lift"}, {"type", "prismatic"}, {"a_mm", 50}, {"alpha_deg", -90}, {"d_mm", 0}, {"theta_deg", 0},
         {"min_mm", 0}, {"max_mm", 800}}}},
      {"tool", {{"position_mm", {0, 0, 120}}, {"quaternion", {1, 0, 0, 0}}}}};
  EXPECT_THROW((void)ParseRegisterRobotRequest(robot_v1, Limits{}), ApiError);
  const StoredRobot robot = FromWire<StoredRobot>(robot_v1);
  EXPECT_EQ(robot.definition.description, long_text);
  const RobotModel model = BuildModel(robot.definition);
  EXPECT_EQ(model.num_joints(), 2);
  EXPECT_EQ(model.joint_name(1), "lift");
  // Written again, it carries the current version and reads back the same.
  const json robot_v2 = json(robot);
  EXPECT_EQ(robot_v2.at("schema_version"), kStoredSchemaVersion);
  EXPECT_EQ(json(FromWire<StoredRobot>(robot_v2)), robot_v2);

  const json campaign_v1 = {{"id", "c1"},
                            {"description", ""},
                            {"robot", "old"},
                            {"robot_definition", robot_v1},
                            {"measurement_type", "position"},
                            {"plan", nullptr},
                            {"noise", {{"position_mm", 0.015}, {"orientation_deg", 0.0057}}},
                            {"created_unix_ms", 1700000000000}};
  const StoredCampaign campaign = FromWire<StoredCampaign>(campaign_v1);
  EXPECT_EQ(campaign.measurement_type, MeasurementType::kPosition);
  EXPECT_FALSE(campaign.plan.has_value());
  EXPECT_FALSE(campaign.tracker.has_value());
  EXPECT_EQ(campaign.repeatability_mm, 0.0);
  EXPECT_TRUE(campaign.reflectors.empty());
  EXPECT_FALSE(campaign.payload.has_value());
  // Without a plan member, and with a null repeatability: read as none and 0, as before the field table.
  json campaign_loose = campaign_v1;
  campaign_loose.erase("plan");
  campaign_loose["repeatability_mm"] = nullptr;
  const StoredCampaign loose = FromWire<StoredCampaign>(campaign_loose);
  EXPECT_FALSE(loose.plan.has_value());
  EXPECT_EQ(loose.repeatability_mm, 0.0);
  // Written again, the campaign states every member (this version's form) and reads back the same.
  const json campaign_v5 = json(campaign);
  EXPECT_EQ(campaign_v5.at("schema_version"), kStoredSchemaVersion);
  EXPECT_TRUE(campaign_v5.at("tracker").is_null());
  EXPECT_EQ(json(FromWire<StoredCampaign>(campaign_v5)), campaign_v5);

  // A version-1 fit said nothing of a deadline (it was written only when true).
  const Calibration identity = Uncalibrated(model);
  CalibrationResult result = ToWire(identity);
  result.campaign = "c1";
  result.robot = "old";
  result.stored = true;
  json calibration_v1 = json(ToStored(identity, result));
  calibration_v1.erase("schema_version");
  calibration_v1["result"]["summary"].erase("deadline_exceeded");
  const StoredCalibration stored = FromWire<StoredCalibration>(calibration_v1);
  EXPECT_FALSE(stored.result.summary.deadline_exceeded);
  EXPECT_EQ(stored.errors.size(), static_cast<std::size_t>(model.num_error_parameters()));
  EXPECT_FALSE(stored.last_calibration_sequence.has_value());  // unknown: the report takes the first ones

  json future = robot_v2;
  future["schema_version"] = kStoredSchemaVersion + 1;
  try {
    (void)FromWire<StoredRobot>(future);
    FAIL() << "a newer version read as this one";
  } catch (const WireError& e) {
    EXPECT_EQ(e.path(), "schema_version");
  }
}

// The last calibration measurement a fit saw is kept when known, and absent (not 0) when not.
TEST(StoredDocumentTest, LastCalibrationSequenceRoundTrips) {
  const RobotModel model = Preset("ur5e");
  const Calibration c = Uncalibrated(model);
  StoredCalibration s = ToStored(c, ToWire(c));
  EXPECT_FALSE(json(s)["state"].contains("last_calibration_sequence"));
  EXPECT_FALSE(FromWire<StoredCalibration>(json(s)).last_calibration_sequence.has_value());
  s.last_calibration_sequence = 90;
  EXPECT_EQ(json(s)["state"]["last_calibration_sequence"], 90);
  EXPECT_EQ(FromWire<StoredCalibration>(json(s)).last_calibration_sequence, std::optional<std::int64_t>(90));
}

// A stored fit that did not converge comes back as it was stored (it used to be restored as converged).
TEST(StoredDocumentTest, RestoredCalibrationKeepsItsTermination) {
  const RobotModel model = Preset("ur5e");
  for (Termination t : {Termination::kNoConvergence, Termination::kDegraded, Termination::kConvergence}) {
    Calibration c = Uncalibrated(model);
    c.summary.termination = t;
    c.summary.message = "as stored";
    CalibrationResult result = ToWire(c);
    const StoredCalibration stored = FromWire<StoredCalibration>(json(ToStored(c, result)));
    const Calibration restored = Restore(model, stored);
    EXPECT_EQ(restored.summary.termination, t) << WireName(t);
    EXPECT_EQ(restored.summary.message, "as stored");
  }
}

// A calibration fitted with a gross outlier, then stored and restored: the same calibration, member by member (the
// figures the wire keeps in degrees to round-off, everything else exactly), and the same reports.
class RestoreTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    VirtualCellOptions o;
    o.seed = 21;
    o.shots_per_pose = 2;
    VirtualCell cell(*model_, o);
    Rng rng(4);
    std::vector<Measurement> shots = cell.MeasureAll(RandomConfigurations(*model_, 25, &rng));
    shots[7].T_world_tool.translation() += Eigen::Vector3d(3.0, 0.0, 0.0);
    fitted_ = new Calibration(Identify(*model_, shots));
  }
  static void TearDownTestSuite() { delete fitted_; }

  // The document as the server writes it (outliers by sequence number 100 + index), read back.
  static StoredCalibration StoredText(const Calibration& c) {
    std::vector<std::int64_t> sequences;
    for (int i = 0; i < c.summary.num_measurements + static_cast<int>(c.summary.outliers.size()); ++i) {
      sequences.push_back(100 + i);
    }
    return FromWire<StoredCalibration>(json::parse(json(ToStored(c, ToWire(c, sequences))).dump()));
  }

  static inline const RobotModel* model_ = new RobotModel(Preset("grinder5"));
  static inline Calibration* fitted_ = nullptr;
};

void ExpectSameParameters(const std::vector<IdentifiedParameter>& a, const std::vector<IdentifiedParameter>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].index, b[k].index);
    EXPECT_EQ(a[k].name, b[k].name);
    EXPECT_NEAR(a[k].value, b[k].value, 1e-14 * std::abs(b[k].value)) << b[k].name;
    EXPECT_NEAR(a[k].std, b[k].std, 1e-14 * b[k].std) << b[k].name;
  }
}

void ExpectSameResiduals(const ResidualStatistics& a, const ResidualStatistics& b) {
  EXPECT_EQ(a.num_measurements, b.num_measurements);
  EXPECT_EQ(a.rms_position_mm, b.rms_position_mm);
  EXPECT_EQ(a.max_position_mm, b.max_position_mm);
  EXPECT_NEAR(a.rms_orientation_rad, b.rms_orientation_rad, 1e-15);
  EXPECT_NEAR(a.max_orientation_rad, b.max_orientation_rad, 1e-15);
  EXPECT_EQ(a.rms_weighted, b.rms_weighted);
}

void ExpectSameTransform(const Transform& a, const Transform& b) {
  EXPECT_LT((a.matrix() - b.matrix()).cwiseAbs().maxCoeff(), 1e-12);
}

TEST_F(RestoreTest, ACalibrationComesBackWhole) {
  const Calibration& c = *fitted_;
  ASSERT_EQ(c.summary.termination, Termination::kConvergence) << c.summary.message;
  ASSERT_EQ(c.summary.outliers.size(), 1u) << "the disturbed shot";
  EXPECT_EQ(c.summary.outliers[0].measurement, 7);
  ASSERT_GT(c.covariance.rows(), 10);
  const Calibration r = Restore(*model_, StoredText(c));

  EXPECT_EQ(r.model.num_error_parameters(), c.model.num_error_parameters());
  ExpectSameTransform(r.model.T_world_base(), c.model.T_world_base());
  EXPECT_EQ(r.errors, c.errors);
  ExpectSameParameters(r.parameters, c.parameters);
  EXPECT_EQ(r.covariance, c.covariance);
  ExpectSameTransform(r.T_world_base, c.T_world_base);
  ExpectSameTransform(r.T_flange_tool, c.T_flange_tool);
  EXPECT_TRUE(r.reflectors.empty());

  const IdentificationSummary& a = r.summary;
  const IdentificationSummary& b = c.summary;
  EXPECT_EQ(a.termination, b.termination);
  EXPECT_EQ(a.message, b.message);
  EXPECT_EQ(a.measurement_type, b.measurement_type);
  EXPECT_EQ(a.num_measurements, b.num_measurements);
  EXPECT_EQ(a.num_poses, b.num_poses);
  EXPECT_EQ(a.num_residuals, b.num_residuals);
  EXPECT_EQ(a.num_parameters, b.num_parameters);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.initial_cost, b.initial_cost);
  EXPECT_EQ(a.final_cost, b.final_cost);
  EXPECT_EQ(a.sigma_hat, b.sigma_hat);
  ExpectSameResiduals(a.before, b.before);
  ExpectSameResiduals(a.after, b.after);
  EXPECT_EQ(a.condition_number, b.condition_number);
  EXPECT_EQ(a.singular_values, b.singular_values);
  EXPECT_EQ(a.scaling, b.scaling);
  ASSERT_EQ(a.dropped.size(), b.dropped.size());
  for (std::size_t k = 0; k < a.dropped.size(); ++k) {
    EXPECT_EQ(a.dropped[k].index, b.dropped[k].index);
    EXPECT_EQ(a.dropped[k].name, b.dropped[k].name);
    EXPECT_EQ(a.dropped[k].reason, b.dropped[k].reason);
  }
  ASSERT_EQ(a.outliers.size(), b.outliers.size());
  for (std::size_t k = 0; k < a.outliers.size(); ++k) {
    EXPECT_EQ(a.outliers[k].measurement, b.outliers[k].measurement);
    EXPECT_EQ(a.outliers[k].reflector, b.outliers[k].reflector);
    EXPECT_EQ(a.outliers[k].normalized_residual, b.outliers[k].normalized_residual);
  }
  EXPECT_EQ(a.outlier_threshold, b.outlier_threshold);
  EXPECT_EQ(a.robust_scale, b.robust_scale);
  EXPECT_EQ(a.rejection_rounds, b.rejection_rounds);
  ExpectSameParameters(a.parameters_with_outliers, b.parameters_with_outliers);
  EXPECT_EQ(a.model_error.estimated, b.model_error.estimated);
  EXPECT_EQ(a.model_error.model_error_mm, b.model_error.model_error_mm);
  EXPECT_NEAR(a.model_error.model_error_rad, b.model_error.model_error_rad, 1e-15);
  EXPECT_EQ(a.model_error.tracker_rms_mm, b.model_error.tracker_rms_mm);
  EXPECT_NEAR(a.model_error.tracker_rms_rad, b.model_error.tracker_rms_rad, 1e-15);
  EXPECT_EQ(a.model.Describe(), b.model.Describe());
  EXPECT_EQ(a.seconds, b.seconds);
  EXPECT_EQ(a.BriefReport(), b.BriefReport());
  EXPECT_EQ(a.FullReport(), b.FullReport());
  EXPECT_EQ(r.FullReport(), c.FullReport());
}

// The summary's members a plain fit leaves empty: the model choice and implausible joint terms.
TEST_F(RestoreTest, TheModelChoiceAndImplausibleTermsComeBack) {
  Calibration c = *fitted_;
  c.summary.model_folds = 4;
  c.summary.model_chosen = 1;
  const auto candidate = [](bool compliance, int harmonics, int parameters, double mean, int failed, const char* note) {
    ModelCandidate m;
    m.terms.compliance = compliance;
    m.terms.joint_harmonics = harmonics;
    m.num_parameters = parameters;
    m.cv_mean_mm = mean;
    m.cv_rms_mm = 1.25 * mean;
    m.cv_standard_error_mm = 0.05 * mean;
    m.failed_folds = failed;
    m.note = note;
    return m;
  };
  c.summary.model_candidates = {candidate(false, 0, 20, 0.4, 0, ""), candidate(true, 0, 25, 0.3, 0, ""),
                                candidate(true, 2, 45, 0.0, 1, "an implausible joint term in fold 2")};
  c.summary.implausible_joint_terms = {"joint2.c 0.02 rad/(N*m)"};
  const IdentificationSummary a = Restore(*model_, StoredText(c)).summary;
  EXPECT_EQ(a.model_folds, 4);
  EXPECT_EQ(a.model_chosen, 1);
  ASSERT_EQ(a.model_candidates.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    const ModelCandidate& x = a.model_candidates[k];
    const ModelCandidate& y = c.summary.model_candidates[k];
    EXPECT_EQ(x.terms.Describe(), y.terms.Describe());
    EXPECT_EQ(x.num_parameters, y.num_parameters);
    EXPECT_EQ(x.cv_mean_mm, y.cv_mean_mm);
    EXPECT_EQ(x.cv_rms_mm, y.cv_rms_mm);
    EXPECT_EQ(x.cv_standard_error_mm, y.cv_standard_error_mm);
    EXPECT_EQ(x.failed_folds, y.failed_folds);
    EXPECT_EQ(x.note, y.note);
  }
  EXPECT_EQ(a.implausible_joint_terms, c.summary.implausible_joint_terms);
  EXPECT_EQ(a.FullReport(), c.summary.FullReport());
}

// A fit stored before version 5 restores without what version 5 added, and everything else as before.
TEST_F(RestoreTest, AVersion4FitLoadsWithoutItsCovariance) {
  json doc = json(ToStored(*fitted_, ToWire(*fitted_)));
  doc["schema_version"] = 4;
  for (const char* key :
       {"covariance", "singular_values", "num_residuals", "outlier_measurements", "implausible_joint_terms"}) {
    ASSERT_TRUE(doc["state"].contains(key)) << key;
    doc["state"].erase(key);
  }
  const StoredCalibration stored = FromWire<StoredCalibration>(doc);
  EXPECT_FALSE(stored.covariance.has_value());
  // Written again by this version, it stays a fit without covariance, and readable.
  const json again = json(stored);
  EXPECT_EQ(again["schema_version"], kStoredSchemaVersion);
  EXPECT_FALSE(FromWire<StoredCalibration>(again).covariance.has_value());
  const Calibration r = Restore(*model_, stored);
  EXPECT_EQ(r.covariance.size(), 0);
  EXPECT_EQ(r.summary.singular_values.size(), 0);
  EXPECT_EQ(r.errors, fitted_->errors);
  ExpectSameParameters(r.parameters, fitted_->parameters);
  ASSERT_EQ(r.summary.outliers.size(), fitted_->summary.outliers.size());
  EXPECT_EQ(r.summary.outliers[0].measurement, -1) << "not recorded before version 5";
  EXPECT_EQ(r.summary.termination, fitted_->summary.termination);
}

// A stored fit that does not fit its robot is refused by the member at fault, never restored half.
TEST_F(RestoreTest, ADocumentThatDoesNotFitTheRobotNamesItsMember) {
  const auto path_of = [&](const std::function<void(json*)>& damage) {
    json doc = json(ToStored(*fitted_, ToWire(*fitted_)));
    damage(&doc);
    try {
      (void)Restore(*model_, FromWire<StoredCalibration>(doc));
    } catch (const WireError& e) {
      return e.path();
    }
    return std::string("restored");
  };
  EXPECT_EQ(path_of([](json* d) { (*d)["state"]["covariance"].erase(0); }), "state.covariance");
  EXPECT_EQ(path_of([](json* d) { (*d)["state"]["covariance"][2].erase(0); }), "state.covariance[2]");
  EXPECT_EQ(path_of([](json* d) { (*d)["result"]["parameters"][1]["name"] = "joint9.dx"; }),
            "result.parameters[1].name");
  EXPECT_EQ(path_of([](json* d) { (*d)["result"]["parameters"][0]["unit"] = "inch"; }), "result.parameters[0].unit");
  EXPECT_EQ(path_of([](json* d) { (*d)["state"]["outlier_measurements"].erase(0); }), "state.outlier_measurements");
  EXPECT_EQ(path_of([](json* d) { (*d)["state"]["errors"].erase(0); }), "state.errors");
  EXPECT_EQ(path_of([](json*) {}), "restored");
}

}  // namespace
}  // namespace robocal::api
