// The calibration service: robots, plans, campaigns, measurements, fit, compensation, evaluation, operations.
#include "robocal/server/service.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "robocal/api/convert.h"
#include "robocal/api/json_reader.h"
#include "robocal/core/accuracy.h"
#include "robocal/core/compensation.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/identification.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/observability.h"
#include "robocal/core/planning.h"
#include "robocal/core/presets.h"
#include "robocal/server/http_server.h"

namespace robocal::server {
namespace {

using api::ApiError;
using api::Status;
using nlohmann::json;

constexpr const char* kRobots = "robots";
constexpr const char* kPlans = "plans";
constexpr const char* kCampaigns = "campaigns";
constexpr const char* kCalibrations = "calibrations";
constexpr const char* kOperations = "operations";

bool IsPreset(const std::string& id) {
  const auto names = PresetNames();
  return std::find(names.begin(), names.end(), id) != names.end();
}

// An id from a path that cannot name anything is the caller's mistake (400), not a missing resource (404).
void CheckId(const std::string& id, const std::string& what) {
  if (!api::IsValidId(id)) {
    throw ApiError(Status::kInvalidArgument, "invalid " + what + " id \"" + id + "\"",
                   {{what, "must match [a-z0-9][a-z0-9_.-]{0,63}"}});
  }
}

MeasurementType ParseType(const std::string& text) {
  MeasurementType type = MeasurementType::kPose;
  ParseMeasurementType(text, &type);
  return type;
}

// One page of a list: page_size items after page_token. A token is the last id of the previous page with a
// check of the list it came from, so that a token made up or taken from another list is refused instead of
// silently giving an empty or wrong page. Clients treat it as opaque.
struct PageRequest {
  std::size_t size = 100;
  std::string token;  // the last id of the previous page ("" for the first page)
};

std::string PageToken(const std::string& list, const std::string& last_id) {
  return last_id + "~" + api::ContentHash(list + "/" + last_id).substr(0, 8);
}
constexpr std::int64_t kMaxPageSize = 1000;

PageRequest ParsePageRequest(const std::string& list, const std::string& size_text, const std::string& token) {
  api::Problems problems;
  PageRequest page;
  if (!size_text.empty()) {
    std::size_t used = 0;
    long long v = 0;
    try {
      v = std::stoll(size_text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != size_text.size() || v < 1 || v > kMaxPageSize) {
      problems.Add("page_size", "expected an integer in [1, " + std::to_string(kMaxPageSize) + "], got \"" +
                                    size_text.substr(0, 32) + "\"");
    } else {
      page.size = static_cast<std::size_t>(v);
    }
  }
  if (!token.empty()) {
    const std::size_t mark = token.rfind('~');
    const std::string last = mark == std::string::npos ? "" : token.substr(0, mark);
    if (!api::IsValidId(last) || PageToken(list, last) != token) {
      problems.Add("page_token", "not a next_page_token of a previous page of this list");
    } else {
      page.token = last;
    }
  }
  problems.ThrowIfAny("invalid query");
  return page;
}

Measurement ToCore(const RobotModel& model, const api::MeasurementWire& w) {
  Measurement m;
  m.joints = api::JointsToCore(model, w.joints);
  m.T_world_tool = api::PoseToTransform(w.pose);
  return m;
}

// Asks `trimmer` for a trim as a large request's work ends; the trim's delay covers what is freed after this
// (the request's other locals, its request and reply documents).
class TrimWhenDone {
 public:
  TrimWhenDone(MemoryTrimmer* trimmer, bool large) : trimmer_(large ? trimmer : nullptr) {}
  ~TrimWhenDone() {
    if (trimmer_ != nullptr) trimmer_->Schedule();
  }
  TrimWhenDone(const TrimWhenDone&) = delete;
  TrimWhenDone& operator=(const TrimWhenDone&) = delete;

 private:
  MemoryTrimmer* trimmer_;
};

// Requests with at least this many elements (measurements, joint vectors, targets) count as large.
constexpr std::size_t kLargeRequest = 1000;

// Calls `visit` for a campaign's measurements of `role` in sequence order, a page at a time, so that a
// campaign's stored text is never all in memory at once (only what the caller keeps of it).
void ForEachMeasurement(Storage* storage, const std::string& campaign_id, const std::string& role,
                        const std::function<void(const StoredMeasurement&)>& visit) {
  constexpr int kPage = 1000;
  std::int64_t after = 0;
  for (;;) {
    const std::vector<StoredMeasurement> page = storage->ListMeasurements(campaign_id, role, after, kPage);
    for (const StoredMeasurement& m : page) visit(m);
    if (static_cast<int>(page.size()) < kPage) return;
    after = page.back().sequence;
  }
}

// Refuses, before any measurement is loaded, a fit whose Jacobian (rows x measurements x parameters) exceeds
// max_fit_jacobian_entries: its size bounds the fit's memory and the time of each iteration.
void CheckFitSize(const RobotModel& model, const IdentificationOptions& options, std::int64_t measurements,
                  bool parameters_requested, const api::Limits& limits) {
  const std::int64_t parameters =
      parameters_requested ? static_cast<std::int64_t>(options.parameters.size())
                           : static_cast<std::int64_t>(
                                 FindIdentifiableParameters(model, options.measurement_type, options.identifiability)
                                     .identifiable.size());
  const std::int64_t rows = MeasurementRows(options.measurement_type);
  const std::int64_t entries = rows * measurements * parameters;
  if (entries <= limits.max_fit_jacobian_entries) return;
  const std::int64_t most = limits.max_fit_jacobian_entries / std::max<std::int64_t>(1, rows * parameters);
  const std::string reason =
      api::OverLimit(entries,
                     "Jacobian entries (" + std::to_string(rows) + " rows x " + std::to_string(measurements) +
                         " calibration measurements x " + std::to_string(parameters) + " parameters)",
                     "max_fit_jacobian_entries", limits.max_fit_jacobian_entries) +
      "; this fit takes at most " + std::to_string(most) + " calibration measurements";
  std::vector<api::FieldViolation> details = {{"measurements", reason}};
  if (parameters_requested) details.push_back({"parameters", reason});
  throw ApiError(Status::kFailedPrecondition, "the fit is too large: " + reason, details);
}

json ForwardPoses(const RobotModel& model, const Eigen::VectorXd& errors, const api::ForwardRequest& req) {
  KinematicsWorkspace ws(model);
  json poses = json::array();
  for (const auto& q : req.joints) {
    poses.push_back(api::PoseToJson(ForwardKinematics(model, api::JointsToCore(model, q), errors, &ws)));
  }
  return poses;
}

// A pose the service stored itself (always with its quaternion).
Transform StoredTransform(const json& pose) {
  api::PoseWire p;
  p.position_mm = pose.at("position_mm").get<std::array<double, 3>>();
  p.quaternion = pose.at("quaternion").get<std::array<double, 4>>();
  return api::PoseToTransform(p);
}

// The stored calibration, back as the core's Calibration (for compensation, forward and evaluation).
Calibration RestoreCalibration(const RobotModel& nominal, const json& doc) {
  const json& state = doc.at("state");
  RobotModelSpec spec = nominal.spec();
  spec.T_world_base = StoredTransform(state.at("registered_base"));
  const auto errors = state.at("errors").get<std::vector<double>>();
  Calibration c{RobotModel::Build(spec),
                Eigen::Map<const Eigen::VectorXd>(errors.data(), static_cast<Eigen::Index>(errors.size())),
                {},
                {},
                Transform::Identity(),
                Transform::Identity(),
                {}};
  c.T_world_base = StoredTransform(state.at("T_world_base"));
  c.T_flange_tool = StoredTransform(state.at("T_flange_tool"));
  c.summary.termination = Termination::kConvergence;
  return c;
}

}  // namespace

std::int64_t NowUnixMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string NewId(const std::string& prefix) {
  static std::mutex mutex;
  static std::mt19937_64 engine{std::random_device{}()};
  std::lock_guard lock(mutex);
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(engine()));
  return prefix + "-" + buf;
}

Service::Service(Storage* storage, ServiceOptions options) : storage_(storage), options_(std::move(options)) {}

Service::~Service() {
  // Threads never touch running_, so joining outside the lock cannot deadlock.
  std::vector<std::thread*> threads;
  {
    std::lock_guard lock(operations_mutex_);
    for (auto& [id, op] : running_) {
      op->cancel = true;
      threads.push_back(&op->thread);
    }
  }
  for (std::thread* t : threads) {
    if (t->joinable()) t->join();
  }
}

int Service::RecoverOperations() {
  int marked = 0;
  std::string after;
  for (;;) {
    const auto docs = storage_->List(kOperations, after, 1000);
    if (docs.empty()) break;
    for (const Document& d : docs) {
      json op = json::parse(d.json);
      if (op.value("state", "") == "RUNNING") {
        op["state"] = "FAILED";
        op["done"] = true;
        op["error"] = api::ErrorBody(Status::kUnavailable, HttpStatusOf(Status::kUnavailable),
                                    "aborted: the server stopped while it ran")["error"];
        op["updated_unix_ms"] = NowUnixMs();
        storage_->Put(kOperations, d.id, op.dump());
        ++marked;
      }
    }
    after = docs.back().id;
  }
  return marked;
}

// ---------------------------------------------------------------------------------------------- robots

RobotModel Service::ResolveRobot(const std::string& id, json* definition) {
  if (IsPreset(id)) {
    if (definition) *definition = {{"id", id}, {"from_preset", id}};
    return Preset(id);
  }
  CheckId(id, "robot");
  auto doc = storage_->Get(kRobots, id);
  if (!doc) throw ApiError(Status::kNotFound, "robot \"" + id + "\" not found", {{"robot", "unknown robot"}});
  json def = json::parse(doc->json);
  if (definition) *definition = def;
  return RobotModel::Build(api::ToSpec(api::ParseRegisterRobotRequest(def, options_.limits)));
}

json Service::ListRobots(const std::string& page_size, const std::string& page_token) {
  const PageRequest page = ParsePageRequest(kRobots, page_size, page_token);
  // One ordering over presets then registered robots (whose ids never equal a preset's name), so a token is
  // simply the last id returned.
  const std::vector<std::string> presets = PresetNames();
  auto preset = std::find(presets.begin(), presets.end(), page.token);
  const bool in_presets = page.token.empty() || preset != presets.end();
  json robots = json::array();
  std::string last;
  bool more = false;
  if (in_presets) {
    preset = page.token.empty() ? presets.begin() : std::next(preset);
    for (; preset != presets.end(); ++preset) {
      if (robots.size() == page.size) {
        more = true;
        break;
      }
      robots.push_back(api::RobotToJson(*preset, Preset(*preset), true, PresetDescription(*preset)));
      last = *preset;
    }
  }
  if (!more) {
    const std::size_t room = page.size - robots.size();
    auto docs = storage_->List(kRobots, in_presets ? "" : page.token, static_cast<int>(room + 1));
    if (docs.size() > room) {
      more = true;
      docs.resize(room);
    }
    for (const Document& d : docs) {
      const json def = json::parse(d.json);
      const RobotModel model = RobotModel::Build(api::ToSpec(api::ParseRegisterRobotRequest(def, options_.limits)));
      robots.push_back(api::RobotToJson(d.id, model, false, def.value("description", "")));
      last = d.id;
    }
  }
  json result = {{"robots", robots}};
  if (more) result["next_page_token"] = PageToken(kRobots, last);
  return result;
}

json Service::CreateRobot(const json& body) {
  const api::RegisterRobotRequest req = api::ParseRegisterRobotRequest(body, options_.limits);
  if (IsPreset(req.id)) {
    throw ApiError(Status::kAlreadyExists, "\"" + req.id + "\" is a preset", {{"id", "taken by a preset"}});
  }
  const RobotModel model = RobotModel::Build(api::ToSpec(req));
  try {
    storage_->Create(kRobots, req.id, api::ToJson(req).dump());
  } catch (const StorageError& e) {
    if (e.kind() == StorageError::Kind::kAlreadyExists) {
      throw ApiError(Status::kAlreadyExists, "robot \"" + req.id + "\" already exists", {{"id", "already exists"}});
    }
    throw;
  }
  return api::RobotToJson(req.id, model, false, req.description);
}

json Service::GetRobot(const std::string& id) {
  json def;
  const RobotModel model = ResolveRobot(id, &def);
  return api::RobotToJson(id, model, IsPreset(id), IsPreset(id) ? PresetDescription(id) : def.value("description", ""));
}

void Service::DeleteRobot(const std::string& id) {
  if (IsPreset(id)) throw ApiError(Status::kFailedPrecondition, "presets cannot be deleted", {{"robot", "a preset"}});
  CheckId(id, "robot");
  // Campaigns keep a copy of their robot's definition, so deleting a robot never breaks one.
  if (!storage_->Delete(kRobots, id)) throw ApiError(Status::kNotFound, "robot \"" + id + "\" not found");
}

json Service::RobotForward(const std::string& id, const json& body) {
  const RobotModel model = ResolveRobot(id, nullptr);
  const api::ForwardRequest req = api::ParseForwardRequest(body, model, options_.limits);
  const TrimWhenDone trim(&trimmer_, req.joints.size() >= kLargeRequest);
  return {{"robot", id}, {"frame", "world (nominal base)"}, {"poses", ForwardPoses(model, Eigen::VectorXd(), req)}};
}

// ---------------------------------------------------------------------------------------------- plans

json Service::RunPlan(const RobotModel& model, const api::PlanRequest& req, const std::string& plan_id,
                      const std::function<bool(double)>& progress, bool* cancelled) {
  const MeasurementType type = ParseType(req.measurement_type);
  IdentifiabilityOptions id_options;
  id_options.noise = api::ToCore(req.noise);
  id_options.seed = req.seed;
  const IdentifiabilitySummary ident = FindIdentifiableParameters(model, type, id_options);
  if (ident.termination == Termination::kFailure || ident.identifiable.empty()) {
    throw ApiError(Status::kFailedPrecondition, "no identifiable parameters: " + ident.message);
  }
  ObservabilityOptions obs;
  obs.measurement_type = type;
  obs.noise = id_options.noise;
  ParseColumnScaling(req.scaling, &obs.scaling);
  obs.parameters = ident.identifiable;
  ObservabilityIndex objective = ObservabilityIndex::kConditionNumber;
  ParseObservabilityIndex(req.objective, &objective);
  // ParsePlanRequest refused plans whose work exceeds max_plan_evaluations; the limit is also the optimiser's
  // budget, so that no plan can count past it.
  const int evaluation_limit =
      static_cast<int>(std::min<std::int64_t>(options_.limits.max_plan_evaluations, INT32_MAX));

  bool stopped = false;
  auto callback = [&](double fraction) {
    if (!progress(fraction)) {
      stopped = true;
      return false;
    }
    return true;
  };
  Plan plan;
  if (req.optimiser == "random") {
    RandomSelectionOptions o = api::ToRandomSelectionOptions(req);
    o.progress = callback;
    plan = PlanRandom(model, req.num_configurations, obs, o);
  } else if (req.optimiser == "exchange") {
    ExchangeOptions o = api::ToExchangeOptions(req);
    if (o.max_evaluations == 0) o.max_evaluations = evaluation_limit;
    o.progress = callback;
    plan = PlanExchange(model, req.num_configurations, obs, o);
  } else {
    SolisWetsOptions o = api::ToSolisWetsOptions(req);
    if (o.max_evaluations == 0) o.max_evaluations = evaluation_limit;
    o.progress = callback;
    plan = PlanSolisWets(model, req.num_configurations, obs, o);
  }
  if (cancelled) *cancelled = stopped;

  // The paper's baseline: one random set of the same size (seeded from the plan's seed).
  RandomSelectionOptions baseline_options;
  baseline_options.seed = req.seed + 1000003;
  baseline_options.objective = objective;
  const Plan baseline = PlanRandom(model, req.num_configurations, obs, baseline_options);
  Rng rng(req.seed + 2000003);
  const auto validation = RandomConfigurations(model, req.num_validation, &rng);

  json configurations = json::array(), baseline_configurations = json::array();
  for (const auto& q : plan.configurations) configurations.push_back(api::JointsToWire(model, q));
  for (const auto& q : baseline.configurations) baseline_configurations.push_back(api::JointsToWire(model, q));
  json summary = api::PlanSummaryToJson(plan.summary);
  if (stopped) summary["message"] = summary["message"].get<std::string>() + "; stopped early with the best set so far";
  json joint_units = json::array();
  for (int i = 0; i < model.num_joints(); ++i) {
    joint_units.push_back(model.joint_type(i) == JointType::kRevolute ? "deg" : "mm");
  }
  return {{"id", plan_id},
          {"robot", req.robot},
          {"request", api::ToJson(req)},
          {"measurement_type", req.measurement_type},
          {"objective", req.objective},
          {"optimiser", req.optimiser},
          {"joint_units", joint_units},
          {"configurations", configurations},
          {"indices", api::IndicesToJson(plan.summary.final)},
          {"baseline",
           {{"configurations", baseline_configurations},
            {"indices", api::IndicesToJson(baseline.summary.final)},
            {"predicted_accuracy",
             api::PredictedAccuracyToJson(PredictAccuracy(model, obs, baseline.configurations, validation))}}},
          {"identifiable_parameters", ident.identifiable_names},
          {"dropped_parameters", api::DroppedToJson(ident.dropped)},
          {"predicted_accuracy",
           api::PredictedAccuracyToJson(PredictAccuracy(model, obs, plan.configurations, validation))},
          {"summary", summary},
          {"created_unix_ms", NowUnixMs()}};
}

json Service::CreatePlan(const json& body) {
  const api::PlanRequest req = api::ParsePlanRequest(body, options_.limits);
  const RobotModel model = ResolveRobot(req.robot, nullptr);  // NOT_FOUND before any work or operation is created
  if (!req.async) {
    const TrimWhenDone trim(&trimmer_, true);
    const auto deadline = std::chrono::steady_clock::now() + options_.request_deadline;
    bool deadline_hit = false;
    auto progress = [&](double) {
      if (std::chrono::steady_clock::now() > deadline) deadline_hit = true;
      return !deadline_hit;
    };
    const std::string id = NewId("plan");
    json plan = RunPlan(model, req, id, progress, nullptr);
    if (deadline_hit) {
      // The optimiser reports a stop by its callback as "cancelled"; here the caller should learn why.
      json& summary = plan["summary"];
      summary["termination"] = "NO_CONVERGENCE";
      summary["deadline_exceeded"] = true;
      summary["message"] = "stopped at the request deadline (" + std::to_string(options_.request_deadline.count()) +
                           " ms, request_timeout_s) with the best set so far after " +
                           summary["iterations"].dump() + " iterations; use async: true for longer searches";
    }
    storage_->Create(kPlans, id, plan.dump());
    return plan;
  }

  const std::string plan_id = NewId("plan");
  return StartOperation("plan", {{"request", api::ToJson(req)}},
                        [this, model, req, plan_id](const std::function<bool(double)>& progress, bool* cancelled) {
                          const json plan = RunPlan(model, req, plan_id, progress, cancelled);
                          storage_->Create(kPlans, plan_id, plan.dump());
                          return json{{"plan", plan_id}};
                        });
}

json Service::StartOperation(const std::string& kind, const json& fields, OperationWork work) {
  std::lock_guard lock(operations_mutex_);
  // Finished threads are joined here, so that running_ holds only live work.
  for (auto it = running_.begin(); it != running_.end();) {
    auto doc = storage_->Get(kOperations, it->first);
    if (doc && json::parse(doc->json).value("done", false) && it->second->thread.joinable()) {
      it->second->thread.join();
      it = running_.erase(it);
    } else {
      ++it;
    }
  }
  if (static_cast<int>(running_.size()) >= options_.max_running_operations) {
    throw ApiError(Status::kUnavailable,
                   "too many running operations (limit " + std::to_string(options_.max_running_operations) + ")",
                   {{"async", "limit of running operations reached; retry later"}});
  }
  const std::string op_id = NewId("op");
  json op = {{"id", op_id},     {"kind", kind},     {"state", "RUNNING"},
             {"done", false},   {"progress", 0.0},  {"created_unix_ms", NowUnixMs()},
             {"updated_unix_ms", NowUnixMs()}};
  op.update(fields);
  storage_->Create(kOperations, op_id, op.dump());
  auto running = std::make_unique<RunningOperation>();
  RunningOperation* r = running.get();
  running->thread = std::thread([this, work = std::move(work), op_id, op, r]() mutable {
    const TrimWhenDone trim(&trimmer_, true);  // plans and fits
    try {
      bool cancelled = false;
      auto progress = [r](double fraction) {
        r->progress = fraction;
        return !r->cancel.load();
      };
      op["result"] = work(progress, &cancelled);
      op["state"] = cancelled ? "CANCELLED" : "SUCCEEDED";
      op["progress"] = cancelled ? r->progress.load() : 1.0;
    } catch (const ApiError& e) {
      op["state"] = "FAILED";
      op["error"] = api::ErrorBody(e.status(), HttpStatusOf(e.status()), e.what(), e.details())["error"];
    } catch (const std::exception& e) {
      op["state"] = "FAILED";
      op["error"] = api::ErrorBody(Status::kInternal, HttpStatusOf(Status::kInternal), e.what())["error"];
    }
    op["done"] = true;
    op["updated_unix_ms"] = NowUnixMs();
    try {
      storage_->Put(kOperations, op_id, op.dump());
    } catch (const std::exception&) {
      // The next start marks it FAILED; nothing else can be done without storage.
    }
  });
  running_[op_id] = std::move(running);
  return op;
}

json Service::GetPlan(const std::string& id) {
  CheckId(id, "plan");
  auto doc = storage_->Get(kPlans, id);
  if (!doc) throw ApiError(Status::kNotFound, "plan \"" + id + "\" not found");
  return json::parse(doc->json);
}

// ---------------------------------------------------------------------------------------------- operations

json Service::GetOperation(const std::string& id) {
  CheckId(id, "operation");
  auto doc = storage_->Get(kOperations, id);
  if (!doc) throw ApiError(Status::kNotFound, "operation \"" + id + "\" not found");
  json op = json::parse(doc->json);
  if (!op.value("done", false)) {
    std::lock_guard lock(operations_mutex_);
    if (auto it = running_.find(id); it != running_.end()) {
      op["progress"] = it->second->progress.load();
      if (it->second->cancel) op["cancel_requested"] = true;
    }
  }
  return op;
}

json Service::CancelOperation(const std::string& id) {
  CheckId(id, "operation");
  {
    std::lock_guard lock(operations_mutex_);
    if (auto it = running_.find(id); it != running_.end()) it->second->cancel = true;
  }
  return GetOperation(id);
}

int Service::running_operations() {
  std::lock_guard lock(operations_mutex_);
  int n = 0;
  for (auto& [id, op] : running_) {
    auto doc = storage_->Get(kOperations, id);
    if (doc && !json::parse(doc->json).value("done", false)) ++n;
  }
  return n;
}

// ---------------------------------------------------------------------------------------------- campaigns

namespace {

json LoadCampaignDocument(Storage* storage, const std::string& id) {
  CheckId(id, "campaign");
  auto doc = storage->Get(kCampaigns, id);
  if (!doc) throw ApiError(Status::kNotFound, "campaign \"" + id + "\" not found");
  return json::parse(doc->json);
}

RobotModel CampaignModel(const json& campaign, const api::Limits& limits) {
  return RobotModel::Build(api::ToSpec(api::ParseRegisterRobotRequest(campaign.at("robot_definition"), limits)));
}
}  // namespace

json Service::LoadCampaign(const std::string& id) { return LoadCampaignDocument(storage_, id); }

json Service::CreateCampaign(const json& body) {
  api::CreateCampaignRequest req = api::ParseCreateCampaignRequest(body);
  json definition;
  (void)ResolveRobot(req.robot, &definition);
  if (!req.plan.empty()) {
    const json plan = GetPlan(req.plan);
    if (plan.value("robot", "") != req.robot) {
      throw ApiError(Status::kFailedPrecondition, "plan \"" + req.plan + "\" is for robot " + plan.value("robot", ""),
                     {{"plan", "planned for another robot"}});
    }
    if (!body.contains("measurement_type")) req.measurement_type = plan.value("measurement_type", "pose");
  }
  if (req.id.empty()) req.id = NewId("c");
  json campaign = {{"id", req.id},
                   {"description", req.description},
                   {"robot", req.robot},
                   {"robot_definition", definition},
                   {"measurement_type", req.measurement_type},
                   {"plan", req.plan.empty() ? json() : json(req.plan)},
                   {"noise", api::NoiseToJson(req.noise)},
                   {"created_unix_ms", NowUnixMs()}};
  try {
    storage_->Create(kCampaigns, req.id, campaign.dump());
  } catch (const StorageError& e) {
    if (e.kind() == StorageError::Kind::kAlreadyExists) {
      throw ApiError(Status::kAlreadyExists, "campaign \"" + req.id + "\" already exists", {{"id", "already exists"}});
    }
    throw;
  }
  return GetCampaign(req.id);
}

json Service::GetCampaign(const std::string& id) {
  json c = LoadCampaign(id);
  c.erase("robot_definition");
  c["counts"] = {{"calibration", storage_->CountMeasurements(id, "calibration")},
                 {"validation", storage_->CountMeasurements(id, "validation")}};
  c["calibrated"] = storage_->Get(kCalibrations, id).has_value();
  return c;
}

json Service::ListCampaigns(const std::string& page_size, const std::string& page_token) {
  const PageRequest page = ParsePageRequest(kCampaigns, page_size, page_token);
  auto docs = storage_->List(kCampaigns, page.token, static_cast<int>(page.size + 1));
  const bool more = docs.size() > page.size;
  if (more) docs.resize(page.size);
  json list = json::array();
  for (const Document& d : docs) {
    json c = json::parse(d.json);
    c.erase("robot_definition");
    list.push_back(c);
  }
  json result = {{"campaigns", list}};
  if (more) result["next_page_token"] = PageToken(kCampaigns, docs.back().id);
  return result;
}

json Service::AppendMeasurements(const std::string& campaign_id, const json& body) {
  const json campaign = LoadCampaign(campaign_id);
  const RobotModel model = CampaignModel(campaign, options_.limits);
  const api::MeasurementBatchRequest req = api::ParseMeasurementBatchRequest(
      body, model, ParseType(campaign.at("measurement_type")), options_.limits);
  const TrimWhenDone trim(&trimmer_, req.measurements.size() >= kLargeRequest);
  std::vector<std::string> texts;
  texts.reserve(req.measurements.size());
  std::string all = req.role;
  for (const auto& m : req.measurements) {
    texts.push_back(api::ToJson(m).dump());
    all += "\n" + texts.back();
  }
  BatchResult r;
  try {
    r = storage_->AppendMeasurements(campaign_id, req.request_id, api::ContentHash(all), req.role, texts,
                                     options_.max_measurements_per_campaign);
  } catch (const StorageError& e) {
    if (e.kind() == StorageError::Kind::kAlreadyExists) {
      throw ApiError(Status::kAlreadyExists,
                     "request_id \"" + req.request_id + "\" was used before with other content",
                     {{"request_id", "reused with different content"}});
    }
    if (e.kind() == StorageError::Kind::kResourceExhausted) {
      throw ApiError(Status::kResourceExhausted,
                     "the campaign would exceed max_measurements_per_campaign (" +
                         std::to_string(options_.max_measurements_per_campaign) + ")",
                     {{"measurements", "limit max_measurements_per_campaign = " +
                                           std::to_string(options_.max_measurements_per_campaign)}});
    }
    throw;
  }
  return {{"campaign", campaign_id}, {"batch_id", r.batch_id},         {"request_id", r.request_id},
          {"replayed", r.replayed},  {"first_sequence", r.first_sequence}, {"count", r.count},
          {"campaign_total", r.campaign_total}};
}

json Service::ListMeasurements(const std::string& campaign_id, const std::string& role, const std::string& after,
                               const std::string& limit) {
  (void)LoadCampaign(campaign_id);
  api::Problems problems;
  if (!role.empty() && role != "calibration" && role != "validation") {
    problems.Add("role", "expected calibration or validation");
  }
  auto to_int = [&](const std::string& text, const char* field, std::int64_t def, std::int64_t max) {
    if (text.empty()) return def;
    try {
      std::size_t used = 0;
      const long long v = std::stoll(text, &used);
      if (used == text.size() && v >= 0 && v <= max) return static_cast<std::int64_t>(v);
    } catch (const std::exception&) {
    }
    problems.Add(field, "expected an integer in [0, " + std::to_string(max) + "]");
    return def;
  };
  const std::int64_t after_seq = to_int(after, "after", 0, INT64_MAX);
  const std::int64_t page =
      to_int(limit, "limit", 1000, static_cast<std::int64_t>(options_.limits.max_array_length));
  problems.ThrowIfAny("invalid query");
  const auto stored = storage_->ListMeasurements(campaign_id, role, after_seq, static_cast<int>(page));
  json list = json::array();
  for (const StoredMeasurement& m : stored) {
    json j = json::parse(m.json);
    list.push_back({{"sequence", m.sequence}, {"batch_id", m.batch_id}, {"role", m.role},
                    {"joints", j.at("joints")}, {"pose", j.at("pose")}});
  }
  json result = {{"campaign", campaign_id}, {"measurements", list}};
  if (static_cast<std::int64_t>(stored.size()) == page && page > 0) result["next_after"] = stored.back().sequence;
  return result;
}

json Service::Fit(const std::string& campaign_id, const json& body) {
  const json campaign = LoadCampaign(campaign_id);
  const RobotModel model = CampaignModel(campaign, options_.limits);
  const api::FitRequest req = api::ParseFitRequest(body, model, options_.limits);
  const MeasurementType type = ParseType(campaign.at("measurement_type"));
  const std::int64_t count = storage_->CountMeasurements(campaign_id, "calibration");
  if (count == 0) {
    throw ApiError(Status::kFailedPrecondition, "the campaign has no calibration measurements",
                   {{"measurements", "upload measurements with role calibration first"}});
  }
  IdentificationOptions options;
  options.measurement_type = type;
  api::NoiseWire noise;
  noise.position_mm = campaign.at("noise").at("position_mm");
  noise.orientation_deg = campaign.at("noise").at("orientation_deg");
  options.noise = api::ToCore(noise);
  options.identifiability.noise = options.noise;
  for (const std::string& name : req.parameters) options.parameters.push_back(model.ParameterIndex(name));
  std::sort(options.parameters.begin(), options.parameters.end());
  options.parameters.erase(std::unique(options.parameters.begin(), options.parameters.end()),
                           options.parameters.end());
  options.register_base = req.register_base;
  options.max_iterations = req.max_iterations;
  CheckFitSize(model, options, count, !req.parameters.empty(), options_.limits);
  auto measurements = std::make_shared<std::vector<Measurement>>();
  measurements->reserve(static_cast<std::size_t>(count));
  ForEachMeasurement(storage_, campaign_id, "calibration", [&](const StoredMeasurement& s) {
    measurements->push_back(ToCore(model, api::MeasurementFromJson(json::parse(s.json))));
  });

  // Identifies and returns the reply; stores the calibration only if `progress` never stopped the fit: a fit
  // cut short by the deadline or a cancel is not the campaign's calibration, so it is returned, not stored.
  auto fit = [this, campaign_id, campaign, model, measurements, options](
                 const std::function<bool(double)>& progress, bool* stopped) {
    IdentificationOptions o = options;
    *stopped = false;
    o.progress = [&](double fraction) {
      if (options_.on_fit_progress) options_.on_fit_progress();
      if (!progress(fraction)) *stopped = true;
      return !*stopped;
    };
    const Calibration calibration = Identify(model, *measurements, o);
    if (calibration.summary.termination == Termination::kFailure) {
      throw ApiError(Status::kFailedPrecondition, "identification failed: " + calibration.summary.message,
                     {{"measurements", calibration.summary.message}});
    }
    json result = api::CalibrationToJson(calibration);
    result["campaign"] = campaign_id;
    result["robot"] = campaign.at("robot");
    result["measurement_type"] = campaign.at("measurement_type");
    result["created_unix_ms"] = NowUnixMs();
    result["stored"] = !*stopped;
    if (*stopped) return result;
    const api::PoseWire registered = api::TransformToPose(calibration.model.T_world_base());
    const api::PoseWire base = api::TransformToPose(calibration.T_world_base);
    const api::PoseWire tool = api::TransformToPose(calibration.T_flange_tool);
    json doc = {{"result", result},
                {"state",
                 {{"registered_base", api::ToJson(registered)},
                  {"T_world_base", api::ToJson(base)},
                  {"T_flange_tool", api::ToJson(tool)},
                  {"errors", std::vector<double>(calibration.errors.data(),
                                                 calibration.errors.data() + calibration.errors.size())}}}};
    storage_->Put(kCalibrations, campaign_id, doc.dump());
    return result;
  };

  if (req.async) {
    return StartOperation("fit", {{"campaign", campaign_id}, {"request", api::ToJson(req)}},
                          [fit](const std::function<bool(double)>& progress, bool* cancelled) {
                            json result = fit(progress, cancelled);
                            if (*cancelled) {
                              result["summary"]["message"] =
                                  "cancelled after " + result["summary"]["iterations"].dump() +
                                  " iterations; the best parameters so far, not stored";
                            }
                            return result;
                          });
  }
  const TrimWhenDone trim(&trimmer_, true);
  const auto deadline = std::chrono::steady_clock::now() + options_.request_deadline;
  bool deadline_hit = false;
  json result = fit([&](double) { return std::chrono::steady_clock::now() <= deadline; }, &deadline_hit);
  if (deadline_hit) {
    json& summary = result["summary"];
    summary["termination"] = "NO_CONVERGENCE";
    summary["deadline_exceeded"] = true;
    summary["message"] = "stopped at the request deadline (" + std::to_string(options_.request_deadline.count()) +
                         " ms, request_timeout_s) after " + summary["iterations"].dump() +
                         " iterations with the best parameters so far, not stored as the calibration; use async: "
                         "true for longer fits";
  }
  return result;
}

json Service::GetCalibration(const std::string& campaign_id) {
  (void)LoadCampaign(campaign_id);
  auto doc = storage_->Get(kCalibrations, campaign_id);
  if (!doc) throw ApiError(Status::kNotFound, "campaign \"" + campaign_id + "\" has no calibration yet (POST :fit)");
  return json::parse(doc->json).at("result");
}

namespace {

// A campaign with its nominal model and stored calibration (FAILED_PRECONDITION if not calibrated yet).
struct CalibratedCampaign {
  json campaign;
  RobotModel model;
  Calibration calibration;
};

CalibratedCampaign LoadCalibrated(Storage* storage, const std::string& campaign_id, const api::Limits& limits) {
  json campaign = LoadCampaignDocument(storage, campaign_id);
  RobotModel model = CampaignModel(campaign, limits);
  auto doc = storage->Get(kCalibrations, campaign_id);
  if (!doc) {
    throw ApiError(Status::kFailedPrecondition, "campaign \"" + campaign_id + "\" is not calibrated (POST :fit)",
                   {{"campaign", "not calibrated"}});
  }
  Calibration calibration = RestoreCalibration(model, json::parse(doc->json));
  return {std::move(campaign), std::move(model), std::move(calibration)};
}

}  // namespace

json Service::CampaignForward(const std::string& campaign_id, const json& body) {
  const CalibratedCampaign loaded = LoadCalibrated(storage_, campaign_id, options_.limits);
  const RobotModel& model = loaded.model;
  const Calibration& calibration = loaded.calibration;
  const api::ForwardRequest req = api::ParseForwardRequest(body, model, options_.limits);
  const TrimWhenDone trim(&trimmer_, req.joints.size() >= kLargeRequest);
  return {{"campaign", campaign_id}, {"frame", "tracker"},
          {"poses", ForwardPoses(calibration.model, calibration.errors, req)}};
}

json Service::Compensate(const std::string& campaign_id, const json& body) {
  const CalibratedCampaign loaded = LoadCalibrated(storage_, campaign_id, options_.limits);
  const RobotModel& model = loaded.model;
  const Calibration& calibration = loaded.calibration;
  const api::CompensateRequest req = api::ParseCompensateRequest(body, model, options_.limits);
  const TrimWhenDone trim(&trimmer_, req.targets.size() >= kLargeRequest);
  json results = json::array();
  for (const auto& t : req.targets) {
    CompensationResult r;
    if (t.pose) {
      TargetFrame frame = TargetFrame::kTracker;
      ParseTargetFrame(t.frame, &frame);
      Eigen::VectorXd start = t.start_joints.empty()
                                  ? Eigen::VectorXd(((model.lower_limits() + model.upper_limits()) / 2.0).eval())
                                  : api::JointsToCore(model, t.start_joints);
      if (t.start_joints.empty()) {
        // Zero (the robot's home) when inside the limits: a better start than the middle for most arms.
        for (int i = 0; i < model.num_joints(); ++i) {
          if (model.lower_limits()[i] <= 0.0 && model.upper_limits()[i] >= 0.0) start[i] = 0.0;
        }
      }
      r = CompensatePose(calibration, api::PoseToTransform(*t.pose), frame, start);
    } else {
      r = CompensateJoints(calibration, model, api::JointsToCore(model, t.joints));
    }
    results.push_back(api::CompensationResultToJson(model, r));
  }
  return {{"campaign", campaign_id}, {"results", results}};
}

json Service::Evaluate(const std::string& campaign_id, const json& body) {
  const CalibratedCampaign loaded = LoadCalibrated(storage_, campaign_id, options_.limits);
  const json& campaign = loaded.campaign;
  const RobotModel& model = loaded.model;
  const Calibration& calibration = loaded.calibration;
  const api::EvaluateRequest req = api::ParseEvaluateRequest(body);
  const TrimWhenDone trim(&trimmer_, true);
  std::vector<Transform> measured, nominal, calibrated;
  KinematicsWorkspace ws(calibration.model);
  ForEachMeasurement(storage_, campaign_id, "validation", [&](const StoredMeasurement& s) {
    const Measurement m = ToCore(model, api::MeasurementFromJson(json::parse(s.json)));
    measured.push_back(m.T_world_tool);
    nominal.push_back(ForwardKinematics(calibration.model, m.joints, Eigen::VectorXd(), &ws));
    calibrated.push_back(ForwardKinematics(calibration.model, m.joints, calibration.errors, &ws));
  });
  if (measured.empty()) {
    throw ApiError(Status::kFailedPrecondition, "the campaign has no validation measurements",
                   {{"measurements", "upload measurements with role validation first"}});
  }
  const AccuracyReport before = ComputeAccuracy(nominal, measured, req.h_mm);
  const AccuracyReport after = ComputeAccuracy(calibrated, measured, req.h_mm);
  auto percent = [](double b, double a) { return b > 0 ? api::Num(100.0 * (b - a) / b) : json(); };
  json result = {{"campaign", campaign_id},
                 {"num_validation", measured.size()},
                 {"h_mm", req.h_mm},
                 {"nominal", api::AccuracyReportToJson(before)},
                 {"calibrated", api::AccuracyReportToJson(after)},
                 {"improvement_percent",
                  {{"e_xyz_mean", percent(before.e_xyz_mm.mean, after.e_xyz_mm.mean)},
                   {"e_xyz_rp", percent(before.e_xyz_mm.rp, after.e_xyz_mm.rp)},
                   {"e_tot_mean", percent(before.e_tot_mm.mean, after.e_tot_mm.mean)},
                   {"e_tot_rp", percent(before.e_tot_mm.rp, after.e_tot_mm.rp)}}}};
  if (ParseType(campaign.at("measurement_type")) == MeasurementType::kPosition) {
    result["note"] = "position measurements carry no orientation: E_cos and E_tot compare against identity";
  }
  return result;
}

}  // namespace robocal::server
