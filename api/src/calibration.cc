// Calibration, compensation and evaluation on the wire.
#include "robocal/api/calibration.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>

#include "robocal/api/json_reader.h"
#include "robocal/core/arm_kinematics.h"
#include "robocal/core/drift.h"

namespace robocal::api {

bool WriteConfigurationFlag(const char* flag, int value, nlohmann::json* out) {
  if (value == 0) return false;
  const std::string_view f = flag;
  *out = f == "shoulder" ? ShoulderName(value) : f == "elbow" ? ElbowName(value) : WristName(value);
  return true;
}

void ReadConfigurationFlag(const char* flag, const nlohmann::json* value, const std::string& path, int* out) {
  *out = 0;
  if (value == nullptr || value->is_null()) return;
  std::string name;
  ReadWire(*value, path, &name);
  if (!ParseConfigurationFlag(flag, name, out)) {
    detail::ThrowWire(path, "not a " + std::string(flag) + " flag: \"" + name + "\"");
  }
}

// ---------------------------------------------------------------------------------------------- fit

JointErrorTerms ToCore(const ModelWire& model) {
  JointErrorTerms terms{.compliance = model.compliance, .joint_harmonics = model.joint_harmonics};
  if (!model.joint_maps) return terms;
  const JointMapsWire& w = *model.joint_maps;
  JointMapTerms& maps = terms.maps;
  for (int joint : w.joints) maps.joints.push_back(joint - 1);
  maps.knot_spacing_rad = w.knot_spacing_deg * kRadPerDeg;
  maps.smoothness = w.smoothness;
  if (!w.grids.empty()) {
    for (int joint : maps.joints) {
      const auto grid =
          std::find_if(w.grids.begin(), w.grids.end(), [&](const MapGridWire& g) { return g.joint == joint + 1; });
      if (grid == w.grids.end())
        throw WireError("model.joint_maps.grids", "no grid for joint " + std::to_string(joint + 1));
      maps.first_knot_rad.push_back(grid->first_knot_deg * kRadPerDeg);
      maps.intervals.push_back(grid->intervals);
    }
  }
  return terms;
}

ModelWire ToWire(const JointErrorTerms& terms) {
  ModelWire model{.compliance = terms.compliance, .joint_harmonics = terms.joint_harmonics, .joint_maps = {}};
  if (terms.maps.empty()) return model;
  JointMapsWire w{.joints = {},
                  .knot_spacing_deg = terms.maps.knot_spacing_rad * kDegPerRad,
                  .smoothness = terms.maps.smoothness,
                  .grids = {}};
  for (size_t m = 0; m < terms.maps.joints.size(); ++m) {
    w.joints.push_back(terms.maps.joints[m] + 1);
    if (m < terms.maps.intervals.size()) {
      w.grids.push_back({.joint = terms.maps.joints[m] + 1,
                         .first_knot_deg = terms.maps.first_knot_rad[m] * kDegPerRad,
                         .intervals = terms.maps.intervals[m]});
    }
  }
  model.joint_maps = std::move(w);
  return model;
}

const std::vector<std::string>& ParameterUnits() {
  static const std::vector<std::string> names = {"mm", "deg", "deg/(N*m)"};
  return names;
}

const std::string& ParameterUnitName(ParameterUnit unit) {
  switch (unit) {
    case ParameterUnit::kMm:
      return ParameterUnits()[0];
    case ParameterUnit::kRad:
      return ParameterUnits()[1];
    case ParameterUnit::kRadPerNm:
      return ParameterUnits()[2];
  }
  return ParameterUnits()[0];
}

double ParameterUnitScale(ParameterUnit unit) { return unit == ParameterUnit::kMm ? 1.0 : kDegPerRad; }

RobotModel FitModel(const FitRequest& request, const RobotModel& nominal,
                    const std::vector<Measurement>& measurements) {
  if (request.model_auto) return nominal;
  JointErrorTerms terms = ToCore(request.model);
  if (!terms.maps.empty() && measurements.empty()) terms.maps = {};
  return WithTermsFor(nominal, terms, measurements);
}

namespace {

// "model.joint_maps": {"joints": [1-based, ascending], "knot_spacing_deg": [0.5, 90], "smoothness": >= 0}, the
// joints filled with every revolute joint when absent.
void ParseJointMaps(const nlohmann::json& value, const RobotModel& robot, const ModelWire& model, Problems* problems,
                    std::optional<JointMapsWire>* out) {
  const std::string path = "model.joint_maps";
  JointMapsWire maps;
  ObjectReader r(value, path, problems);
  if (const nlohmann::json* a = r.Array("joints", false, 1, static_cast<std::size_t>(robot.num_joints()))) {
    for (std::size_t k = 0; k < a->size(); ++k) {
      const nlohmann::json& v = (*a)[k];
      const std::string at = IndexPath(path + ".joints", k);
      if (!v.is_number_integer()) {
        problems->Add(at, "expected a joint number, 1 to " + std::to_string(robot.num_joints()));
        continue;
      }
      const std::int64_t joint = v.get<std::int64_t>();
      if (joint < 1 || joint > robot.num_joints()) {
        problems->Add(at, "joint " + std::to_string(joint) + " is not one of robot \"" + robot.name() + "\"'s " +
                              std::to_string(robot.num_joints()) + " joints");
      } else if (robot.joint_type(static_cast<int>(joint) - 1) != JointType::kRevolute) {
        problems->Add(at, "joint " + std::to_string(joint) + " (\"" + robot.joint_name(static_cast<int>(joint) - 1) +
                              "\") is prismatic: error maps are for revolute joints");
      } else if (!maps.joints.empty() && joint <= maps.joints.back()) {
        problems->Add(at, "joints must be ascending, each once");
      } else {
        maps.joints.push_back(static_cast<int>(joint));
      }
    }
  } else {
    for (int i = 0; i < robot.num_joints(); ++i) {
      if (robot.joint_type(i) == JointType::kRevolute) maps.joints.push_back(i + 1);
    }
  }
  ReadRequest(r, &maps);
  r.RejectUnknown(WireFieldNames<JointMapsWire>());
  if (model.joint_harmonics > 0) {
    problems->Add(path,
                  "a model with joint maps takes no joint_harmonics (a map follows a joint's harmonics and "
                  "errors finer than them)");
  }
  *out = std::move(maps);
}

// "model": "geometric" | "auto" | {"compliance", "joint_harmonics", "joint_maps"}, and "cross_validation" for "auto".
void ParseModel(ObjectReader& r, const RobotModel& model, Problems* problems, FitRequest* req) {
  if (const nlohmann::json* v = r.Get("model")) {
    if (v->is_string()) {
      const std::string name = v->get<std::string>();
      if (name == "auto") {
        req->model_auto = true;
      } else if (name != "geometric") {
        problems->Add("model", "expected \"geometric\", \"auto\" or {\"compliance\": bool, \"joint_harmonics\": 0..2}");
      }
    } else if (v->is_object()) {
      ObjectReader m(*v, "model", problems);
      ReadRequest(m, &req->model);
      if (const nlohmann::json* jm = m.Get("joint_maps"))
        ParseJointMaps(*jm, model, req->model, problems, &req->model.joint_maps);
      m.RejectUnknown(WireFieldNames<ModelWire>());
      if (req->model.compliance && !model.has_masses()) {
        problems->Add("model.compliance", "robot \"" + model.name() +
                                              "\" has no link masses: give its joints mass_kg and com_mm, or "
                                              "import it from a URDF with <inertial> elements");
      }
    } else {
      problems->Add("model", "expected \"geometric\", \"auto\" or an object");
    }
  }
}

// "priors": "auto" | {...}: the groups by the table, the named parameters by the model the fit estimates.
void ParsePriors(ObjectReader& r, const RobotModel& model, const std::vector<Reflector>& reflectors, Problems* problems,
                 FitRequest* req) {
  const nlohmann::json* v = r.Get("priors");
  if (v == nullptr) return;
  if (v->is_string()) {
    if (v->get<std::string>() == "auto") {
      req->priors_auto = true;
    } else {
      problems->Add("priors", "expected \"auto\" or an object of standard deviations");
    }
    return;
  }
  PriorsWire priors;
  if (!ReadRequestObject(*v, "priors", problems, &priors) || !v->is_object()) return;
  if (const auto named = v->find("parameters"); named != v->end()) {
    if (!named->is_object()) {
      problems->Add("priors.parameters", "expected an object of parameter names and standard deviations");
      return;
    }
    for (const auto& [name, sigma] : named->items()) {
      const std::string path = "priors.parameters." + name;
      double value = 0.0;
      if (!ReadFiniteNumber(sigma, path, problems, &value)) continue;
      if (ParameterIndex(model, reflectors, name) < 0) {
        problems->Add(path,
                      "robot \"" + model.name() + "\" has no parameter \"" + name + "\" (e.g. joint2.dz, base.rx)");
      } else if (!(value > 0.0 && value <= WireFields<PriorsWire>::kMax)) {
        problems->Add(path, "must be in (0, 1e6], got " + nlohmann::json(value).dump());
      } else {
        priors.parameters[name] = value;
      }
    }
  }
  req->priors = std::move(priors);
}

}  // namespace

FitRequest ParseFitRequest(const nlohmann::json& body, const RobotModel& nominal, const Limits&,
                           const std::vector<Reflector>& reflectors) {
  Problems problems;
  FitRequest req;
  ObjectReader r(body, "", &problems);
  ParseModel(r, nominal, &problems, &req);
  // Parameters are named in the model the fit estimates (joint terms included).
  const RobotModel model = problems.empty() ? FitModel(req, nominal) : nominal;
  ParsePriors(r, model, reflectors, &problems, &req);
  // Read with the request's other members (its row holds for "auto" only).
  if (r.Has("cross_validation") && !req.model_auto && !req.priors_auto) {
    problems.Add("cross_validation", "only for \"model\": \"auto\" or \"priors\": \"auto\"");
  }
  if (req.model_auto && req.priors_auto) {
    problems.Add("priors",
                 "\"auto\" goes with a given model: \"model\": \"auto\" chooses its own (give the priors "
                 "as an object to apply them to every candidate)");
  }

  if (const nlohmann::json* a =
          r.Array("parameters", false, 0, model.parameter_names().size() + 3 * reflectors.size())) {
    for (std::size_t i = 0; i < a->size(); ++i) {
      const nlohmann::json& v = (*a)[i];
      if (!v.is_string()) {
        problems.Add(IndexPath("parameters", i), "expected a parameter name");
      } else if (const int index = ParameterIndex(model, reflectors, v.get<std::string>()); index < 0) {
        problems.Add(IndexPath("parameters", i),
                     "unknown parameter \"" + v.get<std::string>() + "\" (e.g. joint2.dz, base.rx, tool.dx" +
                         (reflectors.empty() ? "" : ", reflector." + reflectors[0].id + ".dx") + ")");
      } else if (std::find(req.parameters.begin(), req.parameters.end(), v.get<std::string>()) !=
                 req.parameters.end()) {
        problems.Add(IndexPath("parameters", i), "\"" + v.get<std::string>() + "\" is given twice");
      } else if (const int n = model.num_error_parameters(); index >= n && reflectors[(index - n) / 3].fixed) {
        problems.Add(IndexPath("parameters", i), "reflector \"" + reflectors[(index - n) / 3].id +
                                                     "\" is fixed: its position is held, not estimated");
      } else {
        req.parameters.push_back(v.get<std::string>());
      }
    }
  }
  ReadRequest(r, &req);
  if (req.scope == FitScope::kFrames && !req.parameters.empty()) {
    problems.Add("scope", "\"frames\" chooses the parameters itself: leave out parameters");
  }
  if (req.model_auto && !req.parameters.empty()) {
    problems.Add("parameters", "\"model\": \"auto\" chooses the parameters with the model: leave out parameters");
  }
  if (req.model.joint_maps && !req.parameters.empty()) {
    problems.Add("parameters",
                 "a model with joint maps places its coefficients over the measurements: leave out "
                 "parameters");
  }
  if (req.scope == FitScope::kFrames && (req.priors || req.priors_auto)) {
    problems.Add("priors", "\"frames\" fits the base and the tool, which have no prior: leave out \"priors\"");
  }
  if (req.scope == FitScope::kFrames &&
      (req.model_auto || req.model.compliance || req.model.joint_harmonics > 0 || req.model.joint_maps)) {
    problems.Add("scope", "\"frames\" fits the base and the tool of the robot as it is: leave out \"model\"");
  }
  r.RejectUnknown(WireFieldNames<FitRequest>());
  problems.ThrowIfAny("invalid fit request");
  return req;
}

IdentificationOptions ToIdentificationOptions(const FitRequest& req, const RobotModel& model, MeasurementType type,
                                              const MeasurementNoise& noise, const std::vector<Reflector>& reflectors) {
  IdentificationOptions options;
  options.reflectors = reflectors;
  options.measurement_type = type;
  options.noise = noise;
  options.identifiability.noise = options.noise;
  for (const std::string& name : req.parameters) options.parameters.push_back(ParameterIndex(model, reflectors, name));
  if (req.scope == FitScope::kFrames) {
    for (int k : FrameParameters(model, type, !reflectors.empty())) options.parameters.push_back(k);
  }
  std::sort(options.parameters.begin(), options.parameters.end());
  options.parameters.erase(std::unique(options.parameters.begin(), options.parameters.end()), options.parameters.end());
  options.register_base = req.register_base;
  options.max_iterations = req.max_iterations;
  options.reject_outliers = req.reject_outliers;
  options.outlier_probability = req.outlier_probability;
  options.estimate_model_error = req.estimate_model_error;
  // "auto" starts from the defaults; the scale is chosen by cross-validation (IdentifyWithPriorChoice).
  if (req.priors) options.priors = ToCore(*req.priors, model, reflectors);
  if (req.priors_auto) options.priors = ParameterPriors{};
  return options;
}

ParameterPriors ToCore(const PriorsWire& w, const RobotModel& model, const std::vector<Reflector>& reflectors) {
  const auto rad = [](double deg) { return deg * kRadPerDeg; };
  ParameterPriors p;
  p.length_mm = w.lengths_mm;
  p.angle_rad = rad(w.angles_deg);
  p.joint_offset_rad = rad(w.joint_offsets_deg);
  p.joint_offset_mm = w.joint_offsets_mm;
  if (w.base_length_mm) p.base_length_mm = *w.base_length_mm;
  if (w.base_angle_deg) p.base_angle_rad = rad(*w.base_angle_deg);
  if (w.tool_length_mm) p.tool_length_mm = *w.tool_length_mm;
  if (w.tool_angle_deg) p.tool_angle_rad = rad(*w.tool_angle_deg);
  const int n_model = model.num_error_parameters();
  for (const auto& [name, sigma] : w.parameters) {
    const int index = ParameterIndex(model, reflectors, name);
    // A reflector's offset is in mm; a model parameter in its own unit (mm, deg, deg/(N*m)).
    const double scale = index >= 0 && index < n_model ? ParameterUnitScale(model.parameter_unit(index)) : 1.0;
    p.parameters[name] = sigma / scale;
  }
  p.scale = w.scale;
  return p;
}

Residuals ToWire(const ResidualStatistics& s) {
  return {.num_measurements = s.num_measurements,
          .rms_position_mm = s.rms_position_mm,
          .max_position_mm = s.max_position_mm,
          .rms_orientation_deg = s.rms_orientation_rad * kDegPerRad,
          .max_orientation_deg = s.max_orientation_rad * kDegPerRad,
          .rms_weighted = s.rms_weighted};
}

ResidualStatistics ToCore(const Residuals& r) {
  return {.num_measurements = r.num_measurements,
          .rms_position_mm = r.rms_position_mm,
          .max_position_mm = r.max_position_mm,
          .rms_orientation_rad = r.rms_orientation_deg / kDegPerRad,
          .max_orientation_rad = r.max_orientation_deg / kDegPerRad,
          .rms_weighted = r.rms_weighted};
}

namespace {

// `num_model_parameters`: indices from there on are reflector offsets (mm).
std::vector<ParameterEstimate> ToWire(const std::vector<IdentifiedParameter>& parameters, const RobotModel& model,
                                      int num_model_parameters) {
  std::vector<ParameterEstimate> out;
  for (const IdentifiedParameter& p : parameters) {
    const ParameterUnit unit = p.index >= num_model_parameters ? ParameterUnit::kMm : model.parameter_unit(p.index);
    const double scale = ParameterUnitScale(unit);
    out.push_back({.name = p.name, .unit = ParameterUnitName(unit), .value = p.value * scale, .std = p.std * scale});
  }
  return out;
}

}  // namespace

std::vector<IdentifiedParameter> ToCore(const std::vector<ParameterEstimate>& parameters, const RobotModel& model,
                                        const std::vector<Reflector>& reflectors, const std::string& path) {
  std::vector<IdentifiedParameter> out;
  for (std::size_t k = 0; k < parameters.size(); ++k) {
    const ParameterEstimate& p = parameters[k];
    const int index = ParameterIndex(model, reflectors, p.name);
    if (index < 0) {
      throw WireError(WirePath(IndexPath(path, k), "name"), "\"" + p.name + "\" is not a parameter of the robot");
    }
    const ParameterUnit unit = index >= model.num_error_parameters() ? ParameterUnit::kMm : model.parameter_unit(index);
    if (p.unit != ParameterUnitName(unit)) {
      throw WireError(WirePath(IndexPath(path, k), "unit"),
                      "\"" + p.unit + "\" is not the unit of " + p.name + " (" + ParameterUnitName(unit) + ")");
    }
    const double scale = ParameterUnitScale(unit);
    out.push_back({.index = index, .name = p.name, .value = p.value / scale, .std = p.std / scale});
  }
  return out;
}

CalibrationResult ToWire(const Calibration& c, const std::vector<std::int64_t>& sequences) {
  CalibrationResult w;
  const int n_model = static_cast<int>(c.errors.size());
  w.parameters = ToWire(c.parameters, c.model, n_model);
  w.model = ToWire(c.model.error_terms());
  if (!c.summary.model_candidates.empty()) {
    ModelChoiceWire choice;
    choice.folds = c.summary.model_folds;
    for (std::size_t k = 0; k < c.summary.model_candidates.size(); ++k) {
      const ModelCandidate& m = c.summary.model_candidates[k];
      choice.candidates.push_back({.model = ToWire(m.terms),
                                   .description = m.terms.Describe(),
                                   .num_parameters = m.num_parameters,
                                   .cv_mean_mm = m.cv_mean_mm,
                                   .cv_rms_mm = m.cv_rms_mm,
                                   .cv_standard_error_mm = m.cv_standard_error_mm,
                                   .failed_folds = m.failed_folds,
                                   .note = m.note,
                                   .chosen = static_cast<int>(k) == c.summary.model_chosen});
    }
    w.model_choice = std::move(choice);
  }
  w.reflectors = ToWire(c.reflectors);
  const IdentificationSummary& s = c.summary;
  if (s.num_priors > 0 || !s.prior_candidates.empty()) {
    PriorsResultWire p{.num_priors = s.num_priors,
                       .effective_parameters = s.effective_parameters,
                       .prior_determined = {},
                       .candidates = {},
                       .folds = s.prior_folds};
    for (const PriorDeterminedParameter& d : s.prior_determined) {
      const ParameterUnit unit = d.index < n_model ? c.model.parameter_unit(d.index) : ParameterUnit::kMm;
      p.prior_determined.push_back({.parameter = d.name,
                                    .prior_std = d.prior_std * ParameterUnitScale(unit),
                                    .unit = ParameterUnitName(unit),
                                    .data_share = d.data_share});
    }
    for (std::size_t k = 0; k < s.prior_candidates.size(); ++k) {
      const PriorScaleCandidate& m = s.prior_candidates[k];
      // No priors (an infinite scale) is null on the wire.
      p.candidates.push_back({.scale = m.scale,
                              .cv_mean_mm = m.cv_mean_mm,
                              .cv_rms_mm = m.cv_rms_mm,
                              .cv_standard_error_mm = m.cv_standard_error_mm,
                              .failed_folds = m.failed_folds,
                              .note = m.note,
                              .chosen = static_cast<int>(k) == s.prior_chosen});
    }
    w.priors = std::move(p);
  }
  w.robust.enabled = s.rejection_rounds > 0;
  w.robust.threshold = s.outlier_threshold;
  w.robust.scale = s.robust_scale;
  w.robust.rounds = s.rejection_rounds;
  for (const OutlierMeasurement& o : s.outliers) {
    const bool mapped = o.measurement >= 0 && static_cast<std::size_t>(o.measurement) < sequences.size();
    const bool named = o.reflector >= 0 && static_cast<std::size_t>(o.reflector) < c.reflectors.size();
    w.outliers.push_back({.sequence = mapped ? sequences[static_cast<std::size_t>(o.measurement)] : o.measurement,
                          .reflector = named ? c.reflectors[static_cast<std::size_t>(o.reflector)].id : std::string(),
                          .normalized_residual = o.normalized_residual,
                          .excluded = true,
                          .cause = o.cause});
  }
  w.parameters_with_outliers = ToWire(s.parameters_with_outliers, c.model, n_model);
  CoreToWire(s, &w);
  w.measurement_type = s.measurement_type;
  w.dropped = ToWire(s.dropped);
  w.base = TransformToPose(c.T_world_base);
  w.tool = TransformToPose(c.T_flange_tool);
  w.registered_base = TransformToPose(c.model.T_world_base());
  w.residuals_before = ToWire(s.before);
  w.residuals_after = ToWire(s.after);
  CoreToWire(s, &w.summary);
  w.summary.brief = s.BriefReport();
  return w;
}

// ---------------------------------------------------------------------------------------------- compensation

namespace {

// "configuration" of a pose target: an object of the three flags, each optional, each one of its two names.
void ParseConfiguration(const nlohmann::json& value, const std::string& path, Problems* problems,
                        ArmConfiguration* out) {
  ObjectReader r(value, path, problems);
  if (!r.ok()) return;
  for (auto [flag, names, target] : {std::tuple{"shoulder", "front or back", &out->shoulder},
                                     {"elbow", "up or down", &out->elbow},
                                     {"wrist", "noflip or flip", &out->wrist}}) {
    std::string text;
    if (!r.String(flag, false, &text, 16)) continue;
    if (!ParseConfigurationFlag(flag, text, target))
      problems->Add(JoinPath(path, flag), std::string("must be ") + names);
  }
  r.RejectUnknown(WireFieldNames<ArmConfiguration>());
}

}  // namespace

CompensateRequest ParseCompensateRequest(const nlohmann::json& body, const RobotModel& model, const Limits& limits) {
  Problems problems;
  CompensateRequest req;
  ObjectReader r(body, "", &problems);
  const bool named_branches = ArmSolver::For(model).has_value();
  if (const nlohmann::json* a = r.Array("targets", true, 1, limits.max_array_length)) {
    req.targets.resize(a->size());
    for (std::size_t i = 0; i < a->size(); ++i) {
      const std::string path = IndexPath("targets", i);
      ObjectReader t((*a)[i], path, &problems);
      CompensationTargetWire& w = req.targets[i];
      const bool has_joints = t.Has("joints"), has_pose = t.Has("pose");
      if (t.ok() && has_joints == has_pose) {
        problems.Add(path, "give exactly one of joints (nominal joint command) or pose");
      } else if (has_joints) {
        ReadJointVector(*t.Get("joints"), JoinPath(path, "joints"), model, &problems, &w.joints);
        if (t.Has("frame") || t.Has("start_joints") || t.Has("configuration")) {
          problems.Add(path, "frame, start_joints and configuration apply to pose targets only");
        }
      } else if (has_pose) {
        PoseWire p;
        if (ParsePose(*t.Get("pose"), JoinPath(path, "pose"), true, &problems, &p)) w.pose = p;
        t.Enum("frame", false, &w.frame);
        if (const nlohmann::json* s = t.Get("start_joints")) {
          ReadJointVector(*s, JoinPath(path, "start_joints"), model, &problems, &w.start_joints);
        }
        if (const nlohmann::json* c = t.Get("configuration")) {
          if (!named_branches) {
            problems.Add(JoinPath(path, "configuration"),
                         "robot '" + model.name() +
                             "' has no named configurations (only 6R arms with a spherical or an offset wrist have)");
          } else {
            ParseConfiguration(*c, JoinPath(path, "configuration"), &problems, &w.configuration);
          }
        }
      }
      PayloadWire payload;
      if (const nlohmann::json* v = t.Get("payload");
          v && ReadRequestObject(*v, JoinPath(path, "payload"), &problems, &payload)) {
        w.payload = payload;
      }
      t.RejectUnknown(WireFieldNames<CompensationTargetWire>());
      if (problems.size() > 100) break;
    }
  }
  r.Bool("sequence", false, &req.sequence);
  if (r.Number("max_joint_jump_deg", false, &req.max_joint_jump_deg) &&
      !(req.max_joint_jump_deg > 0.0 && req.max_joint_jump_deg <= 720.0)) {
    problems.Add("max_joint_jump_deg", "must be in (0, 720] deg");
  }
  r.RejectUnknown(WireFieldNames<CompensateRequest>());
  problems.ThrowIfAny("invalid compensation request");
  return req;
}

Compensation ToWire(const RobotModel& model, const CompensationResult& r) {
  Compensation c;
  if (r.joints.size() == model.num_joints()) c.joints = JointsToWire(model, r.joints);
  c.position_error_mm = r.position_error_mm;
  c.orientation_error_deg = r.orientation_error_rad * kDegPerRad;
  c.free_rotation_deg = r.free_rotation_rad * kDegPerRad;
  c.converged = r.converged;
  c.termination = r.termination;
  c.iterations = r.iterations;
  c.message = r.message;
  c.configuration = r.configuration;
  return c;
}

namespace {

// A JSON number as the shortest text that reads back as the same double; null when not finite (as Num).
void AppendNumber(std::string* out, double value) {
  if (!std::isfinite(value)) {
    *out += "null";
    return;
  }
  char buffer[32];
  const auto end = std::to_chars(buffer, buffer + sizeof buffer, value).ptr;
  out->append(buffer, end);
}

// A JSON string, escaped as the server's dump escapes (bytes that are not UTF-8 replaced).
void AppendString(std::string* out, const std::string& text) {
  *out += nlohmann::json(text).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace

std::string DumpCompensatedTargets(const CompensatedTargets& r) {
  std::string out;
  out.reserve(64 + r.results.size() * 400);
  out += "{\"campaign\":";
  AppendString(&out, r.campaign);
  out += ",\"results\":[";
  // Members in the order the JSON tree keeps them (sorted by name).
  for (std::size_t i = 0; i < r.results.size(); ++i) {
    const Compensation& c = r.results[i];
    if (i > 0) out += ',';
    out += "{\"branch_change\":";
    out += c.branch_change ? "true" : "false";
    out += ",\"configuration\":";
    if (c.configuration) {
      out += "{\"elbow\":\"";
      out += ElbowName(c.configuration->elbow);
      out += "\",\"shoulder\":\"";
      out += ShoulderName(c.configuration->shoulder);
      out += "\",\"wrist\":\"";
      out += WristName(c.configuration->wrist);
      out += "\"}";
    } else {
      out += "null";
    }
    out += ",\"converged\":";
    out += c.converged ? "true" : "false";
    out += ",\"free_rotation_deg\":";
    AppendNumber(&out, c.free_rotation_deg);
    out += ",\"iterations\":";
    out += std::to_string(c.iterations);
    out += ",\"joint_jump\":";
    out += c.joint_jump ? "true" : "false";
    out += ",\"joint_jump_deg\":";
    AppendNumber(&out, c.joint_jump_deg);
    out += ",\"joints\":[";
    for (std::size_t k = 0; k < c.joints.size(); ++k) {
      if (k > 0) out += ',';
      AppendNumber(&out, c.joints[k]);
    }
    out += "],\"message\":";
    AppendString(&out, c.message);
    out += ",\"orientation_error_deg\":";
    AppendNumber(&out, c.orientation_error_deg);
    out += ",\"position_error_mm\":";
    AppendNumber(&out, c.position_error_mm);
    out += ",\"predicted_error_mm\":";
    AppendNumber(&out, c.predicted_error_mm);
    out += ",\"termination\":";
    out += nlohmann::json(c.termination).dump();
    out += '}';
  }
  out += "]}";
  return out;
}

// ---------------------------------------------------------------------------------------------- evaluation

EvaluateRequest ParseEvaluateRequest(const nlohmann::json& body) {
  Problems problems;
  EvaluateRequest req;
  ReadRequestObject(body, "", &problems, &req);
  problems.ThrowIfAny("invalid evaluate request");
  return req;
}

namespace {
Statistics Scaled(const ErrorStatistics& s, double scale) {
  return {.count = s.count, .mean = s.mean * scale, .std = s.std * scale, .max = s.max * scale, .rp = s.rp * scale};
}
ErrorStatistics Unscaled(const Statistics& s, double scale) {
  return {.count = s.count, .mean = s.mean * scale, .std = s.std * scale, .max = s.max * scale, .rp = s.rp * scale};
}
}  // namespace

Accuracy ToWire(const AccuracyReport& r) {
  return {.h_mm = r.h_mm,
          .e_xyz_mm = Scaled(r.e_xyz_mm, 1.0),
          .e_cos_deg = Scaled(r.e_cos_rad, kDegPerRad),
          .e_tot_mm = Scaled(r.e_tot_mm, 1.0)};
}

AccuracyReport ToCore(const Accuracy& a) {
  AccuracyReport r;
  r.h_mm = a.h_mm;
  r.e_xyz_mm = Unscaled(a.e_xyz_mm, 1.0);
  r.e_cos_rad = Unscaled(a.e_cos_deg, kRadPerDeg);
  r.e_tot_mm = Unscaled(a.e_tot_mm, 1.0);
  return r;
}

Improvement ImprovementOf(const AccuracyReport& before, const AccuracyReport& after) {
  const AccuracyImprovement i = ComputeImprovement(before, after);
  return {.e_xyz_mean = i.e_xyz_mean, .e_xyz_rp = i.e_xyz_rp, .e_tot_mean = i.e_tot_mean, .e_tot_rp = i.e_tot_rp};
}

// The shapes' to_json / from_json, instantiated here once (ROBOCAL_WIRE_DECLARE).
ROBOCAL_WIRE_DEFINE(ArmConfiguration);
ROBOCAL_WIRE_DEFINE(MapGridWire);
ROBOCAL_WIRE_DEFINE(JointMapsWire);
ROBOCAL_WIRE_DEFINE(ModelWire);
ROBOCAL_WIRE_DEFINE(CrossValidationWire);
ROBOCAL_WIRE_DEFINE(PriorsWire);
ROBOCAL_WIRE_DEFINE(FitRequest);
ROBOCAL_WIRE_DEFINE(PriorDeterminedWire);
ROBOCAL_WIRE_DEFINE(PriorScaleWire);
ROBOCAL_WIRE_DEFINE(PriorsResultWire);
ROBOCAL_WIRE_DEFINE(ParameterEstimate);
ROBOCAL_WIRE_DEFINE(Residuals);
ROBOCAL_WIRE_DEFINE(FitSummary);
const char* EnumTable<OutlierMeasurement::Cause>::Name(OutlierMeasurement::Cause value) {
  return value == OutlierMeasurement::Cause::kStale ? "stale" : "residual";
}
ROBOCAL_WIRE_DEFINE(OutlierWire);
ROBOCAL_WIRE_DEFINE(RobustFitWire);
ROBOCAL_WIRE_DEFINE(ModelErrorWire);
ROBOCAL_WIRE_DEFINE(ModelCandidateWire);
ROBOCAL_WIRE_DEFINE(ModelChoiceWire);
ROBOCAL_WIRE_DEFINE(CalibrationResult);
ROBOCAL_WIRE_DEFINE(CompensationTargetWire);
ROBOCAL_WIRE_DEFINE(CompensateRequest);
ROBOCAL_WIRE_DEFINE(Compensation);
ROBOCAL_WIRE_DEFINE(CompensatedTargets);
ROBOCAL_WIRE_DEFINE(EvaluateRequest);
ROBOCAL_WIRE_DEFINE(Statistics);
ROBOCAL_WIRE_DEFINE(Accuracy);
ROBOCAL_WIRE_DEFINE(Improvement);
ROBOCAL_WIRE_DEFINE(Evaluation);

}  // namespace robocal::api
