// Wire shapes of a campaign's calibration: the fit request and its mapping to the core's options, the
// calibration (fit) resource, compensation, and the accuracy evaluation in the paper's form.
#pragma once

#include <cstdint>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "robocal/api/campaigns.h"
#include "robocal/api/robots.h"
#include "robocal/api/wire.h"
#include "robocal/core/accuracy.h"
#include "robocal/core/compensation.h"
#include "robocal/core/identification.h"
#include "robocal/core/priors.h"

namespace robocal::api {

/// One flag of an arm configuration by name ("shoulder": "front" | "back", ...); left out when 0 (not demanded).
bool WriteConfigurationFlag(const char* flag, int value, nlohmann::json* out);
/// WireError at `path` for a name that is not one of the flag's two; absent: 0.
void ReadConfigurationFlag(const char* flag, const nlohmann::json* value, const std::string& path, int* out);

/// A configuration (branch) of a 6R arm with named branches: {"shoulder": "front" | "back", "elbow": "up" |
/// "down", "wrist": "noflip" | "flip"}. In a request each flag is optional (0 in ArmConfiguration: not
/// demanded); in a result all three are given.
template <>
struct WireFields<ArmConfiguration> {
  using S = ArmConfiguration;
  static constexpr auto fields = std::make_tuple(
      Computed<S>{"shoulder",
                  +[](const S& s, nlohmann::json* v) { return WriteConfigurationFlag("shoulder", s.shoulder, v); },
                  +[](const nlohmann::json* v, const std::string& path, S* s) {
                    ReadConfigurationFlag("shoulder", v, path, &s->shoulder);
                  }},
      Computed<S>{"elbow", +[](const S& s, nlohmann::json* v) { return WriteConfigurationFlag("elbow", s.elbow, v); },
                  +[](const nlohmann::json* v, const std::string& path, S* s) {
                    ReadConfigurationFlag("elbow", v, path, &s->elbow);
                  }},
      Computed<S>{"wrist", +[](const S& s, nlohmann::json* v) { return WriteConfigurationFlag("wrist", s.wrist, v); },
                  +[](const nlohmann::json* v, const std::string& path, S* s) {
                    ReadConfigurationFlag("wrist", v, path, &s->wrist);
                  }});
};
ROBOCAL_WIRE_DECLARE(ArmConfiguration);

}  // namespace robocal::api

namespace robocal {
// In the core's namespace, where argument-dependent lookup finds them: by the table above.
inline void to_json(nlohmann::json& j, const ArmConfiguration& c) { api::to_json(j, c); }
inline void from_json(const nlohmann::json& j, ArmConfiguration& c) { api::from_json(j, c); }
}  // namespace robocal

namespace robocal::api {

/// Where a fit placed one joint's map (JointMapTerms): its first knot and its intervals. Set by the server in a
/// fit's result.
struct MapGridWire {
  int joint = 1;  ///< 1-based
  double first_knot_deg = 0.0;
  int intervals = 1;
};
template <>
struct WireFields<MapGridWire> {
  using S = MapGridWire;
  static constexpr auto fields = std::make_tuple(Field{"joint", &S::joint}.Range(1, RequestRule::kNoBound),
                                                 Field{"first_knot_deg", &S::first_knot_deg},
                                                 Field{"intervals", &S::intervals}.Range(1, RequestRule::kNoBound));
};
ROBOCAL_WIRE_DECLARE(MapGridWire);

/// "joint_maps" of a model (docs/identification.md, "Joint error maps"): each listed joint's angle error as a cubic
/// B-spline of its angle, knots every knot_spacing_deg over the range the calibration poses cover, with a
/// second-difference penalty of weight `smoothness`.
struct JointMapsWire {
  /// 1-based joint numbers, ascending; absent or empty in a request: every revolute joint.
  std::vector<int> joints;
  double knot_spacing_deg = 4.0;
  double smoothness = 0.01;
  /// Set by the server: where each map's knots lie.
  std::vector<MapGridWire> grids;
};
template <>
struct WireFields<JointMapsWire> {
  using S = JointMapsWire;
  static constexpr auto fields = std::make_tuple(
      // Joints of the robot, ascending, each once: the parser's (it knows the robot).
      Field{"joints", &S::joints, Presence::kOmitEmpty}.Apart().Size(1, 0).Range(1, RequestRule::kNoBound),
      Field{"knot_spacing_deg", &S::knot_spacing_deg}.Mandatory().Range(kMinMapKnotSpacingRad* kDegPerRad,
                                                                        kMaxMapKnotSpacingRad* kDegPerRad),
      Field{"smoothness", &S::smoothness, Presence::kOptionalOnRead}.Range(0.0, 1e12),
      Field{"grids", &S::grids, Presence::kServerOnly});
};
ROBOCAL_WIRE_DECLARE(JointMapsWire);

/// POST /v1/campaigns/{c}:fit.
/// The model of a fit beyond geometry (docs/identification.md, "Beyond geometry"): joint compliance under gravity
/// and the payload, joint harmonics of order up to 2, and joint error maps. All off: the geometric model.
struct ModelWire {
  bool compliance = false;
  int joint_harmonics = 0;
  std::optional<JointMapsWire> joint_maps = std::nullopt;
};
template <>
struct WireFields<ModelWire> {
  using S = ModelWire;
  static constexpr auto fields = std::make_tuple(
      Field{"compliance", &S::compliance}, Field{"joint_harmonics", &S::joint_harmonics}.Range(0, kMaxJointHarmonics),
      // Read by the parser with the robot's joints (JointMapsWire's table).
      Field{"joint_maps", &S::joint_maps, Presence::kOmitEmpty}.Apart());
};
ROBOCAL_WIRE_DECLARE(ModelWire);
/// The core's terms of a model: with joint maps, their grids as the wire's `grids` place them (a stored result), or
/// none yet (a parsed request, whose `joints` the parser filled: WithTermsFor places them over the measurements).
JointErrorTerms ToCore(const ModelWire& model);
ModelWire ToWire(const JointErrorTerms& terms);

/// "cross_validation" of a fit with "model": "auto": k-fold cross-validation on the calibration measurements.
struct CrossValidationWire {
  /// 2..20.
  int folds = 5;
  std::uint64_t seed = 1;
  /// Whether the candidates include joint error maps (every revolute joint, knots every 8, 4 and 2 deg, with
  /// compliance for a robot with masses): three more candidates whose fits take some times as long.
  bool joint_maps = false;
};
template <>
struct WireFields<CrossValidationWire> {
  static constexpr auto fields =
      std::make_tuple(Field{"folds", &CrossValidationWire::folds}.Range(2, 20),
                      Field{"seed", &CrossValidationWire::seed}.Range(0, RequestRule::kNoBound),
                      // Written when true; absent (and in requests stored before maps): none.
                      Field{"joint_maps", &CrossValidationWire::joint_maps, Presence::kOmitEmpty});
};
ROBOCAL_WIRE_DECLARE(CrossValidationWire);

/// "priors" of a fit (docs/identification.md, "Parameter priors"): each error parameter's a-priori standard deviation,
/// the expected size of its error, in wire units, by group and by name; the fit is then a MAP estimate. Groups left
/// out keep the defaults; the base and tool sites have no prior unless given one.
struct PriorsWire {
  double lengths_mm = kDefaultPriorLengthMm;
  double angles_deg = kDefaultPriorAngleRad * kDegPerRad;
  double joint_offsets_deg = kDefaultPriorJointOffsetRad * kDegPerRad;
  double joint_offsets_mm = kDefaultPriorLengthMm;
  std::optional<double> base_length_mm;
  std::optional<double> base_angle_deg;
  std::optional<double> tool_length_mm;
  std::optional<double> tool_angle_deg;
  /// By parameter name ("joint2.dz", "reflector.smr1.dx"), in the parameter's unit (mm, deg, deg/(N*m)).
  std::map<std::string, double> parameters;
  /// Multiplies every standard deviation.
  double scale = 1.0;
};
template <>
struct WireFields<PriorsWire> {
  using S = PriorsWire;
  static constexpr double kMax = 1e6;
  static constexpr Presence kOmit = Presence::kOmitEmpty;
  static constexpr auto fields =
      std::make_tuple(Field{"lengths_mm", &S::lengths_mm, Presence::kOptionalOnRead}.Range(1e-9, kMax),
                      Field{"angles_deg", &S::angles_deg, Presence::kOptionalOnRead}.Range(1e-9, kMax),
                      Field{"joint_offsets_deg", &S::joint_offsets_deg, Presence::kOptionalOnRead}.Range(1e-9, kMax),
                      Field{"joint_offsets_mm", &S::joint_offsets_mm, Presence::kOptionalOnRead}.Range(1e-9, kMax),
                      Field{"base_length_mm", &S::base_length_mm, kOmit}.Range(1e-9, kMax),
                      Field{"base_angle_deg", &S::base_angle_deg, kOmit}.Range(1e-9, kMax),
                      Field{"tool_length_mm", &S::tool_length_mm, kOmit}.Range(1e-9, kMax),
                      Field{"tool_angle_deg", &S::tool_angle_deg, kOmit}.Range(1e-9, kMax),
                      // Names of the fit's model: the parser reads them.
                      Field{"parameters", &S::parameters, kOmit}.Apart(),
                      Field{"scale", &S::scale, Presence::kOptionalOnRead}.Range(1e-6, 1e6));
};
ROBOCAL_WIRE_DECLARE(PriorsWire);
/// The core's priors of the wire's, for a fit of `model` with `reflectors` (names resolved to their units).
ParameterPriors ToCore(const PriorsWire& priors, const RobotModel& model, const std::vector<Reflector>& reflectors);

struct FitRequest {
  /// Parameter names to estimate (e.g. "joint2.dz"); empty: the identifiable set.
  std::vector<std::string> parameters;
  bool register_base = true;
  int max_iterations = 100;
  /// The robust fit (docs/identification.md, "Outliers"): measurements whose normalised residual exceeds the
  /// chi-square threshold at 1 - outlier_probability are excluded and the fit repeated.
  bool reject_outliers = true;
  double outlier_probability = 1e-3;
  /// Estimate the robot error the geometric model does not explain beside the tracker's noise
  /// (docs/identification.md, "Model error"); false: the campaign's noise model is the whole error.
  bool estimate_model_error = true;
  /// kAll (default): the identifiable parameters (or `parameters`); kFrames: the base and the tool only (the
  /// robot's kinematics held as they are: a calibrated robot in a new cell, docs/api.md), i.e. base.* and
  /// tool.dx/dy/dz, with tool.rx/ry for position_axis and tool.rx/ry/rz for pose measurements or nests.
  FitScope scope = FitScope::kAll;
  /// The model: on the wire "model" is "geometric" (the default), "auto" (chosen by k-fold cross-validation on
  /// the calibration measurements: the simplest candidate within one standard error of the best) or an object
  /// {"compliance": bool, "joint_harmonics": 0..2, "joint_maps": {...}}. `model_auto` is true for "auto".
  ModelWire model;
  bool model_auto = false;
  /// For "auto" only (of the model or the priors).
  CrossValidationWire cross_validation;
  /// On the wire "priors" is absent (none), "auto" (priors_auto: the defaults at the scale k-fold cross-validation
  /// chooses) or the object.
  std::optional<PriorsWire> priors;
  bool priors_auto = false;
  /// Run as a long-running operation.
  bool async = false;
};
template <>
struct WireFields<FitRequest> {
  using S = FitRequest;
  static constexpr auto fields = std::make_tuple(
      // Names of the fit's model (the parser knows it).
      Field{"parameters", &S::parameters}.Apart(), Field{"register_base", &S::register_base},
      Field{"max_iterations", &S::max_iterations}.Range(1, 1000),
      // Absent in requests stored before the robust fit and the model error's estimate: they did not exist.
      Field{"reject_outliers", &S::reject_outliers, Presence::kAbsentIsEmpty},
      Field{"outlier_probability", &S::outlier_probability, Presence::kOptionalOnRead}.Range(1e-12, 0.1),
      Field{"estimate_model_error", &S::estimate_model_error, Presence::kAbsentIsEmpty},
      Field{"scope", &S::scope, Presence::kOptionalOnRead}, Field{"async", &S::async},
      // "auto" or the model object; absent in requests stored before models beyond geometry: the geometric one.
      Computed<S>{"model",
                  +[](const S& s, nlohmann::json* value) {
                    *value = s.model_auto ? nlohmann::json("auto") : nlohmann::json(s.model);
                    return true;
                  },
                  +[](const nlohmann::json* value, const std::string& path, S* s) {
                    s->model_auto = value && value->is_string() && value->get<std::string>() == "auto";
                    if (value && !s->model_auto) ReadWire(*value, path, &s->model);
                  }},
      // "auto" or the object; absent in requests stored before priors: none.
      Computed<S>{"priors",
                  +[](const S& s, nlohmann::json* value) {
                    if (s.priors_auto) *value = "auto";
                    if (s.priors) *value = nlohmann::json(*s.priors);
                    return s.priors_auto || s.priors.has_value();
                  },
                  +[](const nlohmann::json* value, const std::string& path, S* s) {
                    s->priors_auto = value && value->is_string() && value->get<std::string>() == "auto";
                    if (value && !s->priors_auto) ReadWire(*value, path, &s->priors);
                  }},
      Field{"cross_validation", &S::cross_validation}.When(+[](const S& s) { return s.model_auto || s.priors_auto; }));
};
ROBOCAL_WIRE_DECLARE(FitRequest);
/// The model a fit estimates: `nominal` with the request's joint terms (the geometric one for "auto", whose
/// candidates are built by the core), its joint maps placed over `measurements` (WithTermsFor; without
/// measurements, the model without its maps, which names the parameters a request may give).
RobotModel FitModel(const FitRequest& request, const RobotModel& nominal,
                    const std::vector<Measurement>& measurements = {});
/// `parameters` name the model's error parameters and, in a campaign with reflectors, their offsets
/// ("reflector.<id>.dx").
FitRequest ParseFitRequest(const nlohmann::json& body, const RobotModel& model, const Limits& limits,
                           const std::vector<Reflector>& reflectors = {});
/// The core's options for a fit of `model` with measurements of `type` and the campaign's `noise` (progress left
/// empty) and `reflectors`. Parameters named in the request become sorted, unique indices of the fit's space.
IdentificationOptions ToIdentificationOptions(const FitRequest& request, const RobotModel& model, MeasurementType type,
                                              const MeasurementNoise& noise,
                                              const std::vector<Reflector>& reflectors = {});

/// The units of identified parameters on the wire: "mm", "deg", "deg/(N*m)" (a compliance).
const std::vector<std::string>& ParameterUnits();
/// The wire unit of a parameter of `unit`, and the factor from the core's value (mm, rad, rad/(N*m)) to it.
const std::string& ParameterUnitName(ParameterUnit unit);
double ParameterUnitScale(ParameterUnit unit);

/// One identified parameter: value and standard deviation in `unit` (mm, deg or deg/(N*m)).
struct ParameterEstimate {
  std::string name;
  std::string unit;
  double value = 0.0;
  double std = 0.0;
};
template <>
struct WireFields<ParameterEstimate> {
  using S = ParameterEstimate;
  static constexpr auto fields = std::make_tuple(Field{"name", &S::name}, Field{"unit", &S::unit},
                                                 Field{"value", &S::value}, Field{"std", &S::std});
};
ROBOCAL_WIRE_DECLARE(ParameterEstimate);

/// Residuals of the calibration measurements against a model (mm and degrees).
struct Residuals {
  int num_measurements = 0;
  double rms_position_mm = 0.0;
  double max_position_mm = 0.0;
  double rms_orientation_deg = 0.0;
  double max_orientation_deg = 0.0;
  double rms_weighted = 0.0;
};
template <>
struct WireFields<Residuals> {
  using S = Residuals;
  static constexpr auto fields = std::make_tuple(
      Field{"num_measurements", &S::num_measurements}, Field{"rms_position_mm", &S::rms_position_mm},
      Field{"max_position_mm", &S::max_position_mm}, Field{"rms_orientation_deg", &S::rms_orientation_deg},
      Field{"max_orientation_deg", &S::max_orientation_deg}, Field{"rms_weighted", &S::rms_weighted});
};
ROBOCAL_WIRE_DECLARE(Residuals);
Residuals ToWire(const ResidualStatistics& stats);
ResidualStatistics ToCore(const Residuals& residuals);

/// How the fit ended.
struct FitSummary {
  Termination termination = Termination::kFailure;
  std::string message;
  MeasurementType measurement_type = MeasurementType::kPose;
  int num_measurements = 0;
  int num_poses = 0;
  int num_parameters = 0;
  int iterations = 0;
  double initial_cost = 0.0;
  double final_cost = 0.0;
  double sigma_hat = 0.0;
  double seconds = 0.0;
  std::string brief;
  /// A synchronous fit stopped at the server's request deadline (returned, not stored).
  bool deadline_exceeded = false;
};
template <>
struct WireFields<FitSummary> {
  using S = FitSummary;
  using C = IdentificationSummary;
  static constexpr auto fields = std::make_tuple(
      Field{"termination", &S::termination}.Core(&C::termination), Field{"message", &S::message}.Core(&C::message),
      Field{"measurement_type", &S::measurement_type}.Core(&C::measurement_type),
      Field{"num_measurements", &S::num_measurements}.Core(&C::num_measurements),
      Field{"num_poses", &S::num_poses}.Core(&C::num_poses),
      Field{"num_parameters", &S::num_parameters}.Core(&C::num_parameters),
      Field{"iterations", &S::iterations}.Core(&C::iterations),
      Field{"initial_cost", &S::initial_cost}.Core(&C::initial_cost),
      Field{"final_cost", &S::final_cost}.Core(&C::final_cost), Field{"sigma_hat", &S::sigma_hat}.Core(&C::sigma_hat),
      Field{"seconds", &S::seconds}.Core(&C::seconds), Field{"brief", &S::brief},
      Field{"deadline_exceeded", &S::deadline_exceeded});
};
ROBOCAL_WIRE_DECLARE(FitSummary);

/// A calibration measurement the robust fit excluded: its stored sequence number and its normalised residual
/// (sigmas, against the final fit).
/// Why a measurement was excluded from a fit: "residual" (the robust fit) or "stale" (a stale tracker reading). The
/// table spelt out, as for the programs' enums (GCC 12 and a nested enum in ROBOCAL_API_ENUM_TABLE).
template <>
struct EnumTable<OutlierMeasurement::Cause> {
  static constexpr std::array<OutlierMeasurement::Cause, 2> values = {OutlierMeasurement::Cause::kResidual,
                                                                      OutlierMeasurement::Cause::kStale};
  static const char* Name(OutlierMeasurement::Cause value);
};

struct OutlierWire {
  std::int64_t sequence = 0;
  /// The reflector of the shot (a campaign with reflectors; absent otherwise).
  std::string reflector;
  double normalized_residual = 0.0;
  bool excluded = true;
  /// Absent in fits stored before stale readings were told apart: those were all the robust fit's.
  OutlierMeasurement::Cause cause = OutlierMeasurement::Cause::kResidual;
};
template <>
struct WireFields<OutlierWire> {
  using S = OutlierWire;
  static constexpr auto fields =
      std::make_tuple(Field{"sequence", &S::sequence}, Field{"reflector", &S::reflector, Presence::kOmitEmpty},
                      Field{"normalized_residual", &S::normalized_residual}, Field{"excluded", &S::excluded},
                      Field{"cause", &S::cause, Presence::kOptionalOnRead});
};
ROBOCAL_WIRE_DECLARE(OutlierWire);

/// The robust fit's figures: the threshold on the normalised residual (sigmas), the median-based scale of the
/// residuals (1 when the noise model is right), and the number of fits.
struct RobustFitWire {
  bool enabled = false;
  double threshold = 0.0;
  double scale = 0.0;
  int rounds = 0;
};
template <>
struct WireFields<RobustFitWire> {
  using S = RobustFitWire;
  static constexpr auto fields = std::make_tuple(Field{"enabled", &S::enabled}, Field{"threshold", &S::threshold},
                                                 Field{"scale", &S::scale}, Field{"rounds", &S::rounds});
};
ROBOCAL_WIRE_DECLARE(RobustFitWire);

/// The robot error the geometric model does not explain, as the fit estimated it (docs/identification.md,
/// "Model error"): RMS as a 3-D position error (mm) and as an angle (deg; 0 for position measurements), beside
/// the tracker's own RMS over the same measurements from the campaign's noise model.
struct ModelErrorWire {
  bool estimated = false;
  double model_error_mm = 0.0;
  double model_error_deg = 0.0;
  double tracker_rms_mm = 0.0;
  double tracker_rms_deg = 0.0;
};
template <>
struct WireFields<ModelErrorWire> {
  using S = ModelErrorWire;
  using C = ModelErrorEstimate;
  // Read back from a stored fit by dividing, as before the rows carried the link (bit for bit).
  static constexpr CoreUnit kDeg = CoreUnit::kDegForRadDividing;
  static constexpr auto fields =
      std::make_tuple(Field{"estimated", &S::estimated}.Core(&C::estimated),
                      Field{"model_error_mm", &S::model_error_mm}.Core(&C::model_error_mm),
                      Field{"model_error_deg", &S::model_error_deg}.Core(&C::model_error_rad, kDeg),
                      Field{"tracker_rms_mm", &S::tracker_rms_mm}.Core(&C::tracker_rms_mm),
                      Field{"tracker_rms_deg", &S::tracker_rms_deg}.Core(&C::tracker_rms_rad, kDeg));
};
ROBOCAL_WIRE_DECLARE(ModelErrorWire);

/// One candidate of a model chosen by cross-validation: its model, how many parameters it has, and its held-out
/// position error over the folds (E_xyz: mean, RMS, the standard error of the mean), or the folds that failed.
struct ModelCandidateWire {
  ModelWire model;
  std::string description;
  int num_parameters = 0;
  double cv_mean_mm = 0.0;
  double cv_rms_mm = 0.0;
  double cv_standard_error_mm = 0.0;
  int failed_folds = 0;
  std::string note;
  bool chosen = false;
};
template <>
struct WireFields<ModelCandidateWire> {
  using S = ModelCandidateWire;
  static constexpr auto fields =
      std::make_tuple(Field{"model", &S::model}, Field{"description", &S::description},
                      Field{"num_parameters", &S::num_parameters}, Field{"cv_mean_mm", &S::cv_mean_mm},
                      Field{"cv_rms_mm", &S::cv_rms_mm}, Field{"cv_standard_error_mm", &S::cv_standard_error_mm},
                      Field{"failed_folds", &S::failed_folds}, Field{"note", &S::note}, Field{"chosen", &S::chosen});
};
ROBOCAL_WIRE_DECLARE(ModelCandidateWire);

/// The choice of a fit with "model": "auto": the folds and every candidate, simplest first.
struct ModelChoiceWire {
  int folds = 0;
  std::vector<ModelCandidateWire> candidates;
};
template <>
struct WireFields<ModelChoiceWire> {
  using S = ModelChoiceWire;
  static constexpr auto fields = std::make_tuple(Field{"folds", &S::folds}, Field{"candidates", &S::candidates});
};
ROBOCAL_WIRE_DECLARE(ModelChoiceWire);

/// A parameter its prior rather than the data determined: its prior standard deviation (the parameter's unit) and
/// the data's share of its information, 0..1.
struct PriorDeterminedWire {
  std::string parameter;
  double prior_std = 0.0;
  std::string unit;
  double data_share = 0.0;
};
template <>
struct WireFields<PriorDeterminedWire> {
  using S = PriorDeterminedWire;
  static constexpr auto fields = std::make_tuple(Field{"parameter", &S::parameter}, Field{"prior_std", &S::prior_std},
                                                 Field{"unit", &S::unit}, Field{"data_share", &S::data_share});
};
ROBOCAL_WIRE_DECLARE(PriorDeterminedWire);

/// One scale of priors: auto and its cross-validated held-out position error (scale null: no priors).
struct PriorScaleWire {
  double scale = 0.0;
  double cv_mean_mm = 0.0;
  double cv_rms_mm = 0.0;
  double cv_standard_error_mm = 0.0;
  int failed_folds = 0;
  std::string note;
  bool chosen = false;
};
template <>
struct WireFields<PriorScaleWire> {
  using S = PriorScaleWire;
  static constexpr auto fields =
      std::make_tuple(Field{"scale", &S::scale}, Field{"cv_mean_mm", &S::cv_mean_mm}, Field{"cv_rms_mm", &S::cv_rms_mm},
                      Field{"cv_standard_error_mm", &S::cv_standard_error_mm}, Field{"failed_folds", &S::failed_folds},
                      Field{"note", &S::note}, Field{"chosen", &S::chosen});
};
ROBOCAL_WIRE_DECLARE(PriorScaleWire);

/// What the priors did in a fit: how many estimated parameters had one, the effective number of parameters, the
/// parameters the prior determined, and for "auto" each candidate scale.
struct PriorsResultWire {
  int num_priors = 0;
  double effective_parameters = 0.0;
  std::vector<PriorDeterminedWire> prior_determined;
  std::vector<PriorScaleWire> candidates;
  int folds = 0;
};
template <>
struct WireFields<PriorsResultWire> {
  using S = PriorsResultWire;
  static constexpr auto fields = std::make_tuple(
      Field{"num_priors", &S::num_priors}, Field{"effective_parameters", &S::effective_parameters},
      Field{"prior_determined", &S::prior_determined}, Field{"candidates", &S::candidates, Presence::kOmitEmpty},
      Field{"folds", &S::folds, Presence::kOmitEmpty});
};
ROBOCAL_WIRE_DECLARE(PriorsResultWire);

/// POST /v1/campaigns/{c}:fit, GET /v1/campaigns/{c}/calibration, and the result of a fit operation.
struct CalibrationResult {
  std::string campaign;
  std::string robot;
  MeasurementType measurement_type = MeasurementType::kPose;
  std::int64_t created_unix_ms = 0;
  /// False if the fit stopped at the request deadline or was cancelled: returned, not stored.
  bool stored = false;
  std::vector<ParameterEstimate> parameters;
  std::vector<DroppedParameterWire> dropped;
  /// Calibrated tracker -> robot base (the frame of compensation targets with frame "base").
  PoseResultWire base;
  /// Calibrated flange -> tool.
  PoseResultWire tool;
  /// The base registration the fit started from (without the identified base errors).
  PoseResultWire registered_base;
  Residuals residuals_before;
  Residuals residuals_after;
  double condition_number = 0.0;
  std::string scaling;
  /// The robust fit: what it excluded, and the parameters of plain least squares over every measurement
  /// (empty when nothing was excluded). Absent in fits stored before them (read as empty).
  RobustFitWire robust;
  std::vector<OutlierWire> outliers;
  std::vector<ParameterEstimate> parameters_with_outliers;
  /// Absent in fits stored before the estimate (read as not estimated).
  ModelErrorWire model_error;
  /// The model the fit estimated (absent in fits stored before models beyond geometry: geometric), and for
  /// "model": "auto" the comparison it was chosen by.
  ModelWire model;
  std::optional<ModelChoiceWire> model_choice;
  /// The campaign's reflectors at their identified positions (flange frame; a fixed one where it was given);
  /// empty without reflectors. Their offsets are also parameters (reflector.<id>.dx, ...) when identified.
  std::vector<CampaignReflectorWire> reflectors;
  /// A fit with priors: what they did (absent without priors).
  std::optional<PriorsResultWire> priors;
  FitSummary summary;
};
template <>
struct WireFields<CalibrationResult> {
  using S = CalibrationResult;
  static constexpr auto fields = std::make_tuple(
      Field{"campaign", &S::campaign}, Field{"robot", &S::robot}, Field{"measurement_type", &S::measurement_type},
      Field{"created_unix_ms", &S::created_unix_ms}, Field{"stored", &S::stored}, Field{"parameters", &S::parameters},
      Field{"dropped", &S::dropped}, Field{"base", &S::base}, Field{"tool", &S::tool},
      Field{"registered_base", &S::registered_base}, Field{"residuals_before", &S::residuals_before},
      Field{"residuals_after", &S::residuals_after},
      Field{"condition_number", &S::condition_number}.Core(&IdentificationSummary::condition_number),
      Field{"scaling", &S::scaling}.Core(&IdentificationSummary::scaling),
      Field{"robust", &S::robust, Presence::kOptionalOnRead},
      Field{"outliers", &S::outliers, Presence::kOptionalOnRead},
      Field{"parameters_with_outliers", &S::parameters_with_outliers, Presence::kOptionalOnRead},
      Field{"model_error", &S::model_error, Presence::kOptionalOnRead}.Core(&IdentificationSummary::model_error),
      Field{"model", &S::model, Presence::kOptionalOnRead},
      Field{"model_choice", &S::model_choice, Presence::kOmitEmpty},
      Field{"reflectors", &S::reflectors, Presence::kOptionalOnRead}, Field{"priors", &S::priors, Presence::kOmitEmpty},
      Field{"summary", &S::summary});
};
ROBOCAL_WIRE_DECLARE(CalibrationResult);
/// The wire form of a core calibration (campaign, robot, created_unix_ms and stored left for the caller).
/// `sequences` maps the fit's measurement indices to stored sequence numbers (empty: the indices themselves).
CalibrationResult ToWire(const Calibration& calibration, const std::vector<std::int64_t>& sequences = {});
/// Identified parameters back in the core's units and index space (`model`'s parameters, then the reflectors'
/// offsets); WireError at `path`[k] for a name the model does not have or a unit that is not the parameter's.
std::vector<IdentifiedParameter> ToCore(const std::vector<ParameterEstimate>& parameters, const RobotModel& model,
                                        const std::vector<Reflector>& reflectors, const std::string& path);

/// One compensation target: nominal joints ("joints"), or a pose ("pose", with "frame" tracker | base, optional
/// "start_joints" and optional "configuration", the branch demanded; docs/compensation.md gives the rules).
struct CompensationTargetWire {
  std::vector<double> joints;
  std::optional<PoseWire> pose;
  TargetFrame frame = TargetFrame::kTracker;
  std::vector<double> start_joints;
  /// Flags demanded (0: free); only for a robot with named branches.
  ArmConfiguration configuration;
  /// The payload at this target (a calibration with a compliance model deflects under it); unset: the
  /// campaign's payload, or none.
  std::optional<PayloadWire> payload;
};
template <>
struct WireFields<CompensationTargetWire> {
  using S = CompensationTargetWire;
  static constexpr bool (*kPoseTarget)(const S&) = +[](const S& s) { return s.pose.has_value(); };
  static constexpr auto fields =
      std::make_tuple(Field{"pose", &S::pose, Presence::kOmitEmpty},
                      Field{"joints", &S::joints}.When(+[](const S& s) { return !s.pose.has_value(); }),
                      Field{"frame", &S::frame, Presence::kOptionalOnRead}.When(kPoseTarget),
                      Field{"start_joints", &S::start_joints, Presence::kOmitEmpty}.When(kPoseTarget),
                      Field{"configuration", &S::configuration, Presence::kOmitEmpty}.When(kPoseTarget),
                      Field{"payload", &S::payload, Presence::kOmitEmpty});
};
ROBOCAL_WIRE_DECLARE(CompensationTargetWire);

/// POST /v1/campaigns/{c}:compensate.
struct CompensateRequest {
  std::vector<CompensationTargetWire> targets;
  /// The targets are one program, in order: a pose target without start_joints keeps the previous target's
  /// branch and starts from its result, and each result after the first says how far the joints move from the
  /// previous one (joint_jump_deg; joint_jump when more than max_joint_jump_deg) and whether the branch changed
  /// (branch_change).
  bool sequence = false;
  /// Threshold of joint_jump, deg (> 0, <= 720).
  double max_joint_jump_deg = 30.0;
};
CompensateRequest ParseCompensateRequest(const nlohmann::json& body, const RobotModel& model, const Limits& limits);
template <>
struct WireFields<CompensateRequest> {
  using S = CompensateRequest;
  // Targets need the robot (joint vectors, named configurations): the parser reads them. The jump's range is
  // (0, 720]: the parser refuses 0.
  static constexpr auto fields =
      std::make_tuple(Field{"targets", &S::targets}.Mandatory().Size(1, 0).Apart(), Field{"sequence", &S::sequence},
                      Field{"max_joint_jump_deg", &S::max_joint_jump_deg}.Range(0.0, 720.0));
};
ROBOCAL_WIRE_DECLARE(CompensateRequest);

/// One result of :compensate.
struct Compensation {
  /// The joints to command (deg / mm); empty if the solver produced none.
  std::vector<double> joints;
  double position_error_mm = 0.0;
  double orientation_error_deg = 0.0;
  /// Robots with fewer than 6 joints: the rotation about the tool axis left free; 0 otherwise.
  double free_rotation_deg = 0.0;
  bool converged = false;
  /// CONVERGENCE (converged), DEGRADED (a joint held at its limit), NO_CONVERGENCE (stopped with the error
  /// left in position_error_mm / orientation_error_deg; message says why), FAILURE (no usable joints).
  Termination termination = Termination::kFailure;
  int iterations = 0;
  std::string message;
  /// With sequence: the largest change of a revolute joint from the previous target's result (deg; NaN / null
  /// for the first target, without sequence, and for a robot without revolute joints), and whether it exceeds
  /// max_joint_jump_deg.
  double joint_jump_deg = std::numeric_limits<double>::quiet_NaN();
  bool joint_jump = false;
  /// For a robot with named branches (a 6R arm of a known family): the branch of `joints`; null otherwise.
  std::optional<ArmConfiguration> configuration;
  /// With sequence: the configuration differs from the previous target's result.
  bool branch_change = false;
  /// A 95 % bound on the tool position error (mm, tracker frame) the robot will have at `joints`: the fit's
  /// parameter covariance carried to them through the calibrated model, plus its estimated model error and the
  /// campaign's repeatability (PredictPositionError, docs/compensation.md "Predicted accuracy"). NaN / null
  /// without joints, and for a calibration without a parameter covariance (a fit stored by an older server).
  double predicted_error_mm = std::numeric_limits<double>::quiet_NaN();
};
template <>
struct WireFields<Compensation> {
  using S = Compensation;
  static constexpr auto fields = std::make_tuple(
      Field{"joints", &S::joints}, Field{"position_error_mm", &S::position_error_mm},
      Field{"orientation_error_deg", &S::orientation_error_deg}, Field{"free_rotation_deg", &S::free_rotation_deg},
      Field{"converged", &S::converged}, Field{"termination", &S::termination}, Field{"iterations", &S::iterations},
      Field{"message", &S::message}, Field{"joint_jump_deg", &S::joint_jump_deg}, Field{"joint_jump", &S::joint_jump},
      Field{"configuration", &S::configuration}, Field{"branch_change", &S::branch_change},
      Field{"predicted_error_mm", &S::predicted_error_mm, Presence::kOptionalOnRead});
};
ROBOCAL_WIRE_DECLARE(Compensation);
Compensation ToWire(const RobotModel& model, const CompensationResult& result);

/// The reply of :compensate, one result per target in order.
struct CompensatedTargets {
  std::string campaign;
  std::vector<Compensation> results;
};
template <>
struct WireFields<CompensatedTargets> {
  using S = CompensatedTargets;
  static constexpr auto fields = std::make_tuple(Field{"campaign", &S::campaign}, Field{"results", &S::results});
};
ROBOCAL_WIRE_DECLARE(CompensatedTargets);
/// The reply of :compensate as JSON text: the document json(r) is (same keys in the same order, same values,
/// tested), written directly. Why by hand: building the JSON tree (a map of 12 members per result) and dumping
/// it took 90 ms for a 10,000-target reply whose compensation takes 25 ms on 2 cores; this takes about 10 ms.
std::string DumpCompensatedTargets(const CompensatedTargets& r);

/// POST /v1/campaigns/{c}:evaluate.
struct EvaluateRequest {
  /// E_tot = E_xyz + h E_cos (E_cos in rad), mm.
  double h_mm = 30.0;
};
EvaluateRequest ParseEvaluateRequest(const nlohmann::json& body);
template <>
struct WireFields<EvaluateRequest> {
  using S = EvaluateRequest;
  static constexpr auto fields = std::make_tuple(Field{"h_mm", &S::h_mm}.Range(1e-9, 1e6));
};
ROBOCAL_WIRE_DECLARE(EvaluateRequest);

/// mean, std (N-1), max and RP = mean + 3 std of one error, in the unit its owner's name gives.
struct Statistics {
  int count = 0;
  double mean = 0.0;
  double std = 0.0;
  double max = 0.0;
  double rp = 0.0;
};
template <>
struct WireFields<Statistics> {
  using S = Statistics;
  static constexpr auto fields = std::make_tuple(Field{"count", &S::count}, Field{"mean", &S::mean},
                                                 Field{"std", &S::std}, Field{"max", &S::max}, Field{"rp", &S::rp});
};
ROBOCAL_WIRE_DECLARE(Statistics);

/// The paper's three errors: E_xyz (mm), E_cos (deg), E_tot = E_xyz + h E_cos[rad] (mm).
struct Accuracy {
  double h_mm = 0.0;
  Statistics e_xyz_mm;
  Statistics e_cos_deg;
  Statistics e_tot_mm;
};
template <>
struct WireFields<Accuracy> {
  using S = Accuracy;
  static constexpr auto fields = std::make_tuple(Field{"h_mm", &S::h_mm}, Field{"e_xyz_mm", &S::e_xyz_mm},
                                                 Field{"e_cos_deg", &S::e_cos_deg}, Field{"e_tot_mm", &S::e_tot_mm});
};
ROBOCAL_WIRE_DECLARE(Accuracy);
Accuracy ToWire(const AccuracyReport& report);
AccuracyReport ToCore(const Accuracy& accuracy);

/// Improvement of a calibrated model over the nominal one, in percent (NaN / null where undefined).
struct Improvement {
  double e_xyz_mean = 0.0;
  double e_xyz_rp = 0.0;
  double e_tot_mean = 0.0;
  double e_tot_rp = 0.0;
};
template <>
struct WireFields<Improvement> {
  using S = Improvement;
  static constexpr auto fields = std::make_tuple(Field{"e_xyz_mean", &S::e_xyz_mean}, Field{"e_xyz_rp", &S::e_xyz_rp},
                                                 Field{"e_tot_mean", &S::e_tot_mean}, Field{"e_tot_rp", &S::e_tot_rp});
};
ROBOCAL_WIRE_DECLARE(Improvement);
/// The core's ComputeImprovement of the statistics the wire reports (NaN where undefined).
Improvement ImprovementOf(const AccuracyReport& before, const AccuracyReport& after);

/// The reply of :evaluate.
struct Evaluation {
  std::string campaign;
  int num_validation = 0;
  double h_mm = 0.0;
  Accuracy nominal;
  Accuracy calibrated;
  Improvement improvement_percent;
  /// Set for position campaigns (no orientation measured).
  std::optional<std::string> note;
};
template <>
struct WireFields<Evaluation> {
  using S = Evaluation;
  static constexpr auto fields = std::make_tuple(
      Field{"campaign", &S::campaign}, Field{"num_validation", &S::num_validation}, Field{"h_mm", &S::h_mm},
      Field{"nominal", &S::nominal}, Field{"calibrated", &S::calibrated},
      Field{"improvement_percent", &S::improvement_percent}, Field{"note", &S::note, Presence::kOmitEmpty});
};
ROBOCAL_WIRE_DECLARE(Evaluation);

}  // namespace robocal::api
