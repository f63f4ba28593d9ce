// The stored documents and their versions.
#include "robocal/api/stored.h"

#include "robocal/api/json_reader.h"

namespace robocal::api {
namespace {

constexpr const char* kVersionKey = "schema_version";

nlohmann::json Versioned(nlohmann::json j) {
  j[kVersionKey] = kStoredSchemaVersion;
  return j;
}

// Version 1 wrote deadline_exceeded only when it was true.
void DefaultFalse(nlohmann::json* object, const char* key) {
  if (object->is_object() && !object->contains(key)) (*object)[key] = false;
}

}  // namespace

int StoredSchemaVersion(const nlohmann::json& document) {
  const WireReader r(document);
  int version = 1;
  r.Optional(kVersionKey, &version);
  if (version < 1 || version > kStoredSchemaVersion) {
    throw WireError(kVersionKey, "version " + std::to_string(version) + " is not one this server reads (1.." +
                                     std::to_string(kStoredSchemaVersion) + ")");
  }
  return version;
}

void to_json(nlohmann::json& j, const StoredRobot& robot) {
  j = Versioned(robot.definition);
  if (!robot.history.empty()) j["history"] = robot.history;
}

void from_json(const nlohmann::json& j, StoredRobot& robot) {
  (void)StoredSchemaVersion(j);
  nlohmann::json definition = j;
  if (definition.is_object() && definition.contains("history")) {
    ReadWire(definition["history"], "history", &robot.history);
    definition.erase("history");
  }
  from_json(definition, robot.definition);
}

void to_json(nlohmann::json& j, const StoredCampaign& c) {
  WriteFields(j, c);
  j[kVersionKey] = kStoredSchemaVersion;
}

void from_json(const nlohmann::json& j, StoredCampaign& c) {
  (void)StoredSchemaVersion(j);
  // What versions before 4 did not write, and what version 4 wrote only when set: the campaign's Later() rows
  // (campaigns.h), absent or null read as each member's default.
  nlohmann::json doc = j;
  FillLaterKeys<StoredCampaign>(&doc);
  ReadFields(doc, &c);
}

void to_json(nlohmann::json& j, const StoredPlan& plan) { j = Versioned(plan.plan); }

void from_json(const nlohmann::json& j, StoredPlan& plan) {
  const int version = StoredSchemaVersion(j);
  if (version >= 3) {
    ReadWire(j, "", &plan.plan);
    return;
  }
  // Plans before cells had neither a cell nor configuration checks, nor the predicted_error figures.
  nlohmann::json doc = j;
  for (nlohmann::json* indices : {&doc["indices"], &doc["baseline"]["indices"], &doc["summary"]["initial"]}) {
    if (indices->is_object() && !indices->contains("predicted_error_mm")) (*indices)["predicted_error_mm"] = nullptr;
  }
  for (nlohmann::json* accuracy : {&doc["predicted_accuracy"], &doc["baseline"]["predicted_accuracy"]}) {
    if (accuracy->is_object() && !accuracy->contains("rms_error_mm")) (*accuracy)["rms_error_mm"] = nullptr;
  }
  if (doc.is_object() && !doc.contains("cell")) doc["cell"] = nullptr;
  if (doc.is_object() && !doc.contains("configuration_checks")) doc["configuration_checks"] = nlohmann::json::array();
  if (version == 1 && doc.contains("summary")) DefaultFalse(&doc["summary"], "deadline_exceeded");
  ReadWire(doc, "", &plan.plan);
}

void to_json(nlohmann::json& j, const StoredCalibration& c) {
  WriteFields(j, c);
  j[kVersionKey] = kStoredSchemaVersion;
}

void from_json(const nlohmann::json& j, StoredCalibration& c) {
  nlohmann::json doc = j;
  if (StoredSchemaVersion(j) == 1 && doc.contains("result") && doc["result"].contains("summary")) {
    DefaultFalse(&doc["result"]["summary"], "deadline_exceeded");
  }
  ReadFields(doc, &c);
}

StoredCalibration ToStored(const Calibration& calibration, const CalibrationResult& result) {
  const IdentificationSummary& s = calibration.summary;
  StoredCalibration stored;
  stored.result = result;
  stored.registered_base = TransformToPose(calibration.model.T_world_base());
  stored.T_world_base = TransformToPose(calibration.T_world_base);
  stored.T_flange_tool = TransformToPose(calibration.T_flange_tool);
  stored.errors.assign(calibration.errors.data(), calibration.errors.data() + calibration.errors.size());
  std::vector<std::vector<double>>& covariance = stored.covariance.emplace();
  for (Eigen::Index i = 0; i < calibration.covariance.rows(); ++i) {
    covariance.emplace_back(calibration.covariance.cols());
    Eigen::Map<Eigen::RowVectorXd>(covariance.back().data(), calibration.covariance.cols()) =
        calibration.covariance.row(i);
  }
  stored.singular_values.assign(s.singular_values.data(), s.singular_values.data() + s.singular_values.size());
  stored.num_residuals = s.num_residuals;
  for (const OutlierMeasurement& o : s.outliers) stored.outlier_measurements.push_back(o.measurement);
  stored.implausible_joint_terms = s.implausible_joint_terms;
  return stored;
}

namespace {

Eigen::MatrixXd CovarianceOf(const StoredCalibration& stored) {
  if (!stored.covariance) return {};
  const std::vector<std::vector<double>>& rows = *stored.covariance;
  const std::size_t n = stored.result.parameters.size();
  if (rows.size() != n) {
    throw WireError("state.covariance", "expected " + std::to_string(n) + " rows (one per estimated parameter), got " +
                                            std::to_string(rows.size()));
  }
  Eigen::MatrixXd covariance(n, n);
  for (std::size_t i = 0; i < n; ++i) {
    if (rows[i].size() != n) {
      throw WireError(IndexPath("state.covariance", i),
                      "expected " + std::to_string(n) + " values, got " + std::to_string(rows[i].size()));
    }
    covariance.row(static_cast<Eigen::Index>(i)) =
        Eigen::Map<const Eigen::RowVectorXd>(rows[i].data(), static_cast<Eigen::Index>(n));
  }
  return covariance;
}

// The core summary the stored fit was written from: the wire result's figures in the core's units, and the state's
// version-5 members.
IdentificationSummary SummaryOf(const StoredCalibration& stored, const RobotModel& model,
                                const std::vector<Reflector>& reflectors) {
  const CalibrationResult& r = stored.result;
  IdentificationSummary s;
  WireToCore(r.summary, &s);
  WireToCore(r, &s);
  s.measurement_type = r.measurement_type;
  s.num_residuals = stored.num_residuals;
  s.before = ToCore(r.residuals_before);
  s.after = ToCore(r.residuals_after);
  s.singular_values = Eigen::Map<const Eigen::VectorXd>(stored.singular_values.data(),
                                                        static_cast<Eigen::Index>(stored.singular_values.size()));
  for (const DroppedParameterWire& d : r.dropped) {
    s.dropped.push_back({.index = ParameterIndex(model, reflectors, d.name), .name = d.name, .reason = d.reason});
  }
  // Version 5 records each outlier's index (the covariance marks a version-5 state); older fits do not: -1.
  const bool indexed = stored.covariance.has_value();
  if (indexed && stored.outlier_measurements.size() != r.outliers.size()) {
    throw WireError("state.outlier_measurements", "expected " + std::to_string(r.outliers.size()) +
                                                      " values (one per outlier), got " +
                                                      std::to_string(stored.outlier_measurements.size()));
  }
  for (std::size_t k = 0; k < r.outliers.size(); ++k) {
    const OutlierWire& o = r.outliers[k];
    s.outliers.push_back({.measurement = indexed ? stored.outlier_measurements[k] : -1,
                          .reflector = ReflectorIndex(r.reflectors, o.reflector),
                          .normalized_residual = o.normalized_residual,
                          .cause = o.cause});
  }
  s.outlier_threshold = r.robust.threshold;
  s.robust_scale = r.robust.scale;
  s.rejection_rounds = r.robust.rounds;
  s.parameters_with_outliers = ToCore(r.parameters_with_outliers, model, reflectors, "result.parameters_with_outliers");
  s.model = ToCore(r.model);
  s.implausible_joint_terms = stored.implausible_joint_terms;
  if (r.model_choice) {
    s.model_folds = r.model_choice->folds;
    for (const ModelCandidateWire& c : r.model_choice->candidates) {
      if (c.chosen) s.model_chosen = static_cast<int>(s.model_candidates.size());
      s.model_candidates.push_back({.terms = ToCore(c.model),
                                    .num_parameters = c.num_parameters,
                                    .cv_mean_mm = c.cv_mean_mm,
                                    .cv_rms_mm = c.cv_rms_mm,
                                    .cv_standard_error_mm = c.cv_standard_error_mm,
                                    .failed_folds = c.failed_folds,
                                    .note = c.note});
    }
  }
  return s;
}

}  // namespace

Calibration Restore(const RobotModel& geometric, const StoredCalibration& stored) {
  // The model the fit estimated: the campaign's robot with the fit's joint terms (none in older fits).
  const RobotModel nominal = geometric.WithErrorTerms(ToCore(stored.result.model));
  if (static_cast<int>(stored.errors.size()) != nominal.num_error_parameters()) {
    throw WireError("state.errors", "expected " + std::to_string(nominal.num_error_parameters()) +
                                        " values for the campaign's robot, got " +
                                        std::to_string(stored.errors.size()));
  }
  RobotModelSpec spec = nominal.spec();
  spec.T_world_base = PoseToTransform(stored.registered_base);
  std::vector<Reflector> reflectors = ToCore(stored.result.reflectors);
  IdentificationSummary summary = SummaryOf(stored, nominal, reflectors);
  std::vector<IdentifiedParameter> parameters =
      ToCore(stored.result.parameters, nominal, reflectors, "result.parameters");
  return Calibration{
      .model = RobotModel::Build(spec),
      .errors = Eigen::Map<const Eigen::VectorXd>(stored.errors.data(), static_cast<Eigen::Index>(stored.errors.size())),
      .parameters = std::move(parameters),
      .covariance = CovarianceOf(stored),
      .T_world_base = PoseToTransform(stored.T_world_base),
      .T_flange_tool = PoseToTransform(stored.T_flange_tool),
      .reflectors = std::move(reflectors),
      .summary = std::move(summary)};
}

void to_json(nlohmann::json& j, const StoredCell& c) {
  WriteFields(j, c);
  j[kVersionKey] = kStoredSchemaVersion;
}

void from_json(const nlohmann::json& j, StoredCell& c) {
  (void)StoredSchemaVersion(j);
  ReadFields(j, &c);
}

void to_json(nlohmann::json& j, const StoredOperation& op) { j = Versioned(op.operation); }

void from_json(const nlohmann::json& j, StoredOperation& op) {
  if (StoredSchemaVersion(j) == 1) {
    nlohmann::json doc = j;
    DefaultFalse(&doc, "cancel_requested");
    if (doc.contains("result") && doc["result"].contains("summary")) {
      DefaultFalse(&doc["result"]["summary"], "deadline_exceeded");
    }
    ReadWire(doc, "", &op.operation);
    return;
  }
  ReadWire(j, "", &op.operation);
}

// The shapes' to_json / from_json, instantiated here once (ROBOCAL_WIRE_DECLARE).

}  // namespace robocal::api
