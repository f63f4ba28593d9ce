// The campaign report's data: the stored campaign, robot, plan (and its cell's drawing), calibration (whole: its
// covariance's correlations and singular values as the fit computed them) and measurements, with every calibration
// measurement's residual before and after computed by the core's own function (fit_diagnostics.h).
// report_html.cc renders it.
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <map>
#include <optional>
#include <regex>
#include <set>

#include "report_html.h"
#include "robocal/api/text.h"
#include "robocal/core/fit_diagnostics.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"
#include "robocal/server/service.h"
#include "service_support.h"

namespace robocal::server {
namespace {

using api::ApiError;
using api::Status;

// E_tot's h from the query: absent is :evaluate's default; given, a decimal number (digits, an optional fraction
// and exponent: what JSON and printf's %g write; never hex, inf, nan, a sign +, blanks or nothing) in :evaluate's
// range. strtod alone would take "0x10", "inf" and " 30".
double ParseReportH(const std::optional<std::string>& text) {
  if (!text) return api::EvaluateRequest{}.h_mm;
  static const std::regex kDecimal(R"(-?[0-9]+(\.[0-9]+)?([eE][-+]?[0-9]+)?)");
  const std::string reason = "must be a decimal number (mm), got \"" + api::SafeText(*text, 64) + "\"";
  char* end = nullptr;
  errno = 0;
  const double value = std::regex_match(*text, kDecimal) ? std::strtod(text->c_str(), &end) : 0.0;
  if (end != text->c_str() + text->size() || errno == ERANGE || !std::isfinite(value)) {
    throw ApiError(Status::kInvalidArgument, "invalid report request: h_mm: " + reason, {{"h_mm", reason}});
  }
  try {
    return api::ParseEvaluateRequest(nlohmann::json{{"h_mm", value}}).h_mm;
  } catch (const ApiError& e) {  // :evaluate's range and its words, said of the report
    const std::string why = e.details().empty() ? e.what() : e.details()[0].reason;
    throw ApiError(e.status(), "invalid report request: h_mm: " + why, e.details());
  }
}

std::array<double, 3> Minus(const Eigen::Vector3d& p, const std::array<double, 3>& origin) {
  return {p.x() - origin[0], p.y() - origin[1], p.z() - origin[2]};
}

// The stick figures of a plan's configurations in its cell: nominal forward kinematics in the base frame,
// moved so that the tracker is the origin.
report::CellFigure DrawCell(const RobotModel& model, const api::PlanResult& plan, const api::CellWire& cell) {
  report::CellFigure f;
  f.cell = cell.id;
  f.tracker_in_base_mm = cell.tracker.position_mm;
  std::vector<Transform> T_base_joint(static_cast<std::size_t>(model.num_joints()));
  Transform T_base_flange;
  for (const std::vector<double>& configuration : plan.configurations) {
    NominalChainInBase(model, api::JointsToCore(model, configuration), T_base_joint.data(), &T_base_flange);
    std::vector<std::array<double, 3>> chain;
    chain.push_back(Minus(Eigen::Vector3d::Zero(), f.tracker_in_base_mm));
    for (const Transform& T : T_base_joint) chain.push_back(Minus(T.translation(), f.tracker_in_base_mm));
    chain.push_back(Minus(T_base_flange.translation(), f.tracker_in_base_mm));
    chain.push_back(Minus((T_base_flange * model.T_flange_tool()).translation(), f.tracker_in_base_mm));
    f.chains.push_back(std::move(chain));
  }
  for (const api::ObstacleWire& o : cell.obstacles) {
    const api::BoxWire& b = o.box;
    f.obstacles.push_back({o.id, Minus(Eigen::Vector3d(b.min_mm[0], b.min_mm[1], b.min_mm[2]), f.tracker_in_base_mm),
                           Minus(Eigen::Vector3d(b.max_mm[0], b.max_mm[1], b.max_mm[2]), f.tracker_in_base_mm)});
  }
  return f;
}

// The plan the campaign was made from, and its cell's drawing; or why there is none.
void AddReportPlan(Storage* storage, const RobotModel& model, const api::StoredCampaign& campaign,
                   report::ReportData* data) {
  if (!campaign.plan) {
    data->plan_missing = "The campaign was not made from a plan (it names none).";
    return;
  }
  const auto doc = storage->Get(kPlans, *campaign.plan);
  if (!doc) {
    data->plan_missing = "The campaign names plan \"" + *campaign.plan + "\", which is no longer stored.";
    return;
  }
  report::PlanSection section;
  section.plan = ReadStored<api::StoredPlan>(*doc).plan;
  const api::PlanResult& plan = section.plan;
  if (!plan.cell) {
    section.no_figure_reason =
        "The plan was made without a cell: there is no tracker to draw the configurations "
        "around (plan in a cell to see them here).";
  } else if (const auto cell_doc = storage->Get(kCells, *plan.cell); !cell_doc) {
    section.no_figure_reason = "The plan's cell \"" + *plan.cell + "\" is no longer stored: nothing to draw.";
  } else {
    section.figure = DrawCell(model, plan, ReadStored<api::StoredCell>(*cell_doc).cell);
  }
  data->plan = std::move(section);
}

// The calibration measurements a stored fit saw, in sequence order, with their sequences and wire joints.
struct ReportFitMeasurements {
  std::vector<Measurement> measurements;
  std::vector<std::int64_t> sequences;
  std::vector<std::vector<double>> joints;  // wire joints, to group the shots of one configuration exactly
  /// The calibration measurements stored after the fit (not in it).
  std::int64_t after_fit = 0;
};

// The fit as stored, and the calibration measurements it saw (its outliers included): those up to the last
// sequence it recorded; for a fit stored before it recorded one, the first (used + excluded) ones, which are
// the same measurements (they are append-only in sequence order). Later ones are counted, not used.
ReportFitMeasurements ReadReportFitMeasurements(Storage* storage, const std::string& campaign_id,
                                                const api::StoredCampaign& campaign, const RobotModel& model,
                                                const api::CalibrationResult& result,
                                                const std::optional<std::int64_t>& last_calibration_sequence) {
  ReportFitMeasurements seen;
  ForEachMeasurement(storage, campaign_id, "calibration", [&](const StoredMeasurement& s) {
    if (!SeenByFit(result, last_calibration_sequence, s.sequence,
                   static_cast<std::int64_t>(seen.measurements.size()))) {
      seen.after_fit += 1;
      return;
    }
    api::MeasurementWire w = ReadMeasurement(s);
    seen.measurements.push_back(MeasurementToCore(model, w, campaign));
    seen.sequences.push_back(s.sequence);
    seen.joints.push_back(std::move(w.joints));
  });
  return seen;
}

// The covariance's correlations and the singular values, as the fit computed them and stored them with it.
void AddReportLinearization(const Calibration& calibration, const api::CalibrationResult& result,
                            report::FitSection* fit) {
  if (result.parameters.empty()) {
    fit->linearization_problem = "the fit estimated no parameters";
  } else if (calibration.covariance.size() == 0) {
    fit->linearization_problem = "the fit was stored before calibrations kept their covariance; fit again to see it";
  } else {
    const Eigen::VectorXd& sv = calibration.summary.singular_values;
    fit->singular_values.assign(sv.data(), sv.data() + sv.size());
    fit->condition_number = calibration.summary.condition_number;
    std::vector<std::string> names;
    for (const IdentifiedParameter& p : calibration.parameters) names.push_back(p.name);
    fit->correlations = report::TopCorrelations(names, CorrelationOf(calibration.covariance), report::kTopCorrelations);
  }
}

// Each fitted map over its knots, with the 2-sigma band of its value from the coefficients' covariance.
std::vector<report::MapCurve> ReportMapCurves(const Calibration& calibration) {
  std::vector<report::MapCurve> curves;
  const JointMapTerms& map_terms = calibration.model.error_terms().maps;
  if (calibration.covariance.size() == 0 || !map_terms.resolved()) return curves;
  std::map<int, int> reduced;  // error parameter -> its row in the covariance
  for (std::size_t k = 0; k < calibration.parameters.size(); ++k) {
    reduced[calibration.parameters[k].index] = static_cast<int>(k);
  }
  constexpr int kSamples = 241;
  for (std::size_t m = 0; m < map_terms.joints.size(); ++m) {
    const int joint = map_terms.joints[m];
    const int first = calibration.model.map_parameter(joint);
    const int intervals = map_terms.intervals[m];
    const double from = map_terms.first_knot_rad[m], spacing = map_terms.knot_spacing_rad;
    report::MapCurve curve;
    curve.joint = calibration.model.joint_name(joint);
    for (int i = 0; i < kSamples; ++i) {
      const double q = from + spacing * intervals * i / (kSamples - 1.0);
      double b[4];
      const int j = MapBasis(from, spacing, intervals, q, b);
      double value = 0.0, variance = 0.0;
      for (int r = 0; r < 4; ++r) {
        value += b[r] * calibration.errors[first + j + r];
        const auto row = reduced.find(first + j + r);
        if (row == reduced.end()) continue;
        for (int t = 0; t < 4; ++t) {
          const auto col = reduced.find(first + j + t);
          if (col != reduced.end()) variance += b[r] * b[t] * calibration.covariance(row->second, col->second);
        }
      }
      curve.angle_deg.push_back(q * kDegPerRad);
      curve.value_deg.push_back(value * kDegPerRad);
      curve.band_deg.push_back(2.0 * std::sqrt(std::max(variance, 0.0)) * kDegPerRad);
    }
    curves.push_back(std::move(curve));
  }
  return curves;
}

// Every calibration measurement's residual before (nominal model, registered base, given reflectors) and after,
// as the fit's own before/after statistics compute them; then the RMS per joint configuration.
std::vector<report::PoseResidual> ReportPoseResiduals(const api::StoredCampaign& campaign, const RobotModel& model,
                                                      const Calibration& calibration,
                                                      const api::CalibrationResult& result,
                                                      const ReportFitMeasurements& seen) {
  const std::vector<Reflector> given = api::ToCore(campaign.reflectors);
  const MeasurementNoise noise = api::NoiseOf(campaign);
  std::set<std::int64_t> outlier_sequences;
  for (const api::OutlierWire& o : result.outliers) outlier_sequences.insert(o.sequence);
  const std::vector<Measurement>& measurements = seen.measurements;
  const std::vector<MeasurementResidualNorms> before =
      ComputeMeasurementResiduals(calibration.model, Eigen::VectorXd(), measurements, campaign.type(), noise,
                                  ReflectorsInTool(model, given, Eigen::VectorXd()));
  const std::vector<MeasurementResidualNorms> after =
      ComputeMeasurementResiduals(calibration.model, calibration.errors, measurements, campaign.type(), noise,
                                  ReflectorsInTool(model, calibration.reflectors, Eigen::VectorXd()));
  std::vector<report::PoseResidual> poses;
  std::map<std::vector<double>, std::size_t> pose_of;
  struct Sums {
    double before_p = 0, after_p = 0, before_o = 0, after_o = 0;
  };
  std::vector<Sums> sums;
  for (std::size_t i = 0; i < measurements.size(); ++i) {
    const auto [it, added] = pose_of.emplace(seen.joints[i], poses.size());
    if (added) {
      report::PoseResidual p;
      p.first_sequence = seen.sequences[i];
      poses.push_back(p);
      sums.emplace_back();
    }
    report::PoseResidual& p = poses[it->second];
    Sums& s = sums[it->second];
    p.last_sequence = seen.sequences[i];
    p.shots += 1;
    p.outliers += outlier_sequences.count(seen.sequences[i]) ? 1 : 0;
    s.before_p += before[i].position_mm * before[i].position_mm;
    s.after_p += after[i].position_mm * after[i].position_mm;
    s.before_o += before[i].orientation_rad * before[i].orientation_rad;
    s.after_o += after[i].orientation_rad * after[i].orientation_rad;
  }
  for (std::size_t k = 0; k < poses.size(); ++k) {
    report::PoseResidual& p = poses[k];
    const double n = p.shots;
    p.before_position_mm = std::sqrt(sums[k].before_p / n);
    p.after_position_mm = std::sqrt(sums[k].after_p / n);
    p.before_orientation_deg = std::sqrt(sums[k].before_o / n) * kDegPerRad;
    p.after_orientation_deg = std::sqrt(sums[k].after_o / n) * kDegPerRad;
  }
  return poses;
}

}  // namespace

std::string Service::CampaignReport(const std::string& campaign_id, const std::optional<std::string>& h_mm_text) {
  const double h_mm = ParseReportH(h_mm_text);
  const Calibrated loaded = LoadCalibrated(campaign_id);
  const api::StoredCampaign& campaign = loaded.campaign;
  const RobotModel& model = loaded.model;
  const TrimWhenDone trim(&trimmer_, true);

  report::ReportData data;
  data.campaign = campaign.id;
  data.description = campaign.description;
  data.measurement_type = campaign.type();
  data.created_unix_ms = campaign.created_unix_ms;
  data.counts.validation = storage_->CountMeasurements(campaign_id, "validation");
  data.counts.test = storage_->CountMeasurements(campaign_id, "test");
  data.generated_unix_ms = NowUnixMs();
  const api::RegisterRobotRequest& definition = campaign.robot_definition;
  data.robot = definition.from_preset.empty()
                   ? RobotResource(campaign.robot, model, definition)
                   : api::RobotFromModel(campaign.robot, model, true, PresetDescription(definition.from_preset));
  AddReportPlan(storage_, model, campaign, &data);

  report::FitSection& fit = data.fit;
  fit.calibration = loaded.result;
  const ReportFitMeasurements seen = ReadReportFitMeasurements(storage_, campaign_id, campaign, model, loaded.result,
                                                               loaded.last_calibration_sequence);
  data.calibration_after_fit = seen.after_fit;
  // Counted as read, so that the header's numbers agree with each other while uploads go on.
  data.counts.calibration = static_cast<std::int64_t>(seen.measurements.size()) + data.calibration_after_fit;
  AddReportLinearization(loaded.calibration, loaded.result, &fit);
  fit.maps = ReportMapCurves(loaded.calibration);
  fit.poses = ReportPoseResiduals(campaign, model, loaded.calibration, loaded.result, seen);

  // The validation, as :evaluate answers it.
  if (data.counts.validation > 0) {
    AccuracyReport before_accuracy, after_accuracy;
    report::ValidationSection validation;
    validation.evaluation = EvaluateLoaded(loaded, h_mm, &before_accuracy, &after_accuracy);
    validation.e_xyz_before_mm = std::move(before_accuracy.e_xyz_values_mm);
    validation.e_xyz_after_mm = std::move(after_accuracy.e_xyz_values_mm);
    data.validation = std::move(validation);
  }
  // The ISO 9283 test, as GET .../iso9283 answers it.
  if (data.counts.test > 0) {
    try {
      data.iso9283 = Iso9283Report(campaign_id);
    } catch (const ApiError& e) {
      data.iso9283_problem = std::string("The test shots give no ISO 9283 figures: ") + e.what();
    }
  }
  return report::RenderReport(data);
}

}  // namespace robocal::server
