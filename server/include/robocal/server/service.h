// The calibration service: what every endpoint does, between parsed JSON and the storage. Knows nothing of
// HTTP; errors are api::ApiError (or StorageError), mapped to HTTP statuses by the server in one place.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "robocal/api/types.h"
#include "robocal/core/robot_model.h"
#include "robocal/server/memory_trimmer.h"
#include "server/storage/storage.h"

namespace robocal::server {

struct ServiceOptions {
  api::Limits limits;
  /// Passed to Storage::AppendMeasurements.
  std::int64_t max_measurements_per_campaign = 100000;
  /// A synchronous plan stops at this deadline with its best set so far (NO_CONVERGENCE, says so); longer
  /// searches belong in `async: true`.
  std::chrono::milliseconds request_deadline{60000};
  /// Operations (async plans and fits) running at once; more is UNAVAILABLE.
  int max_running_operations = 2;
  /// For tests: called in every fit's progress callback (once per iteration) before the deadline and the
  /// cancel flag are checked, so that a test can hold a fit at a known point instead of racing it. Empty in
  /// the server.
  std::function<void()> on_fit_progress;
};

class Service {
 public:
  Service(Storage* storage, ServiceOptions options);
  /// Cancels running operations and waits for them (their documents end as CANCELLED).
  ~Service();

  /// Marks operations left RUNNING by a previous process as FAILED ("aborted: the server stopped").
  /// Returns how many were marked.
  int RecoverOperations();

  /// page_size: "" (default 100) or 1..1000; page_token: "" or the next_page_token of the previous page.
  /// Presets come first, then registered robots in id order.
  nlohmann::json ListRobots(const std::string& page_size = "", const std::string& page_token = "");
  nlohmann::json CreateRobot(const nlohmann::json& body);
  nlohmann::json GetRobot(const std::string& id);
  void DeleteRobot(const std::string& id);
  nlohmann::json RobotForward(const std::string& id, const nlohmann::json& body);

  /// A plan, or (async) an operation whose result names the plan.
  nlohmann::json CreatePlan(const nlohmann::json& body);
  nlohmann::json GetPlan(const std::string& id);

  nlohmann::json CreateCampaign(const nlohmann::json& body);
  /// Campaigns in id order, paged like ListRobots.
  nlohmann::json ListCampaigns(const std::string& page_size = "", const std::string& page_token = "");
  nlohmann::json GetCampaign(const std::string& id);
  nlohmann::json AppendMeasurements(const std::string& campaign, const nlohmann::json& body);
  /// role: "" (all), calibration, validation; after: sequence to start after; limit: page size.
  nlohmann::json ListMeasurements(const std::string& campaign, const std::string& role, const std::string& after,
                                  const std::string& limit);
  /// The fit, stored as the campaign's calibration unless it stopped at the request deadline (then returned
  /// with summary.deadline_exceeded and stored: false); or (async) an operation whose result is the fit,
  /// stored when the operation SUCCEEDS.
  nlohmann::json Fit(const std::string& campaign, const nlohmann::json& body);
  nlohmann::json GetCalibration(const std::string& campaign);
  nlohmann::json Compensate(const std::string& campaign, const nlohmann::json& body);
  nlohmann::json CampaignForward(const std::string& campaign, const nlohmann::json& body);
  nlohmann::json Evaluate(const std::string& campaign, const nlohmann::json& body);

  nlohmann::json GetOperation(const std::string& id);
  nlohmann::json CancelOperation(const std::string& id);

  int running_operations();
  /// The request limits the service enforces (the routes apply max_array_length while parsing bodies).
  const api::Limits& limits() const { return options_.limits; }
  /// For /healthz and metrics.
  Storage* storage() { return storage_; }

 private:
  struct RunningOperation {
    std::atomic<double> progress{0.0};
    std::atomic<bool> cancel{false};
    std::thread thread;
  };

  /// The model of a preset or registered robot (NOT_FOUND otherwise) and its definition JSON.
  RobotModel ResolveRobot(const std::string& id, nlohmann::json* definition);
  nlohmann::json LoadCampaign(const std::string& id);
  /// The work of an operation: gets a progress callback (false: stop) and returns the operation's result,
  /// setting *cancelled if the callback stopped it. ApiErrors it throws become the operation's error.
  using OperationWork = std::function<nlohmann::json(const std::function<bool(double)>& progress, bool* cancelled)>;
  /// Creates the operation document of `kind` (with `fields` merged in) and runs `work` on its own thread;
  /// UNAVAILABLE when max_running_operations are running. Returns the operation.
  nlohmann::json StartOperation(const std::string& kind, const nlohmann::json& fields, OperationWork work);
  /// Computes a plan for `model` (the resolved request.robot); `progress` may cancel it. Returns the stored plan
  /// document.
  nlohmann::json RunPlan(const RobotModel& model, const api::PlanRequest& request, const std::string& plan_id,
                         const std::function<bool(double)>& progress, bool* cancelled);

  Storage* storage_;
  ServiceOptions options_;
  /// Returns the memory of large requests to the system after them.
  MemoryTrimmer trimmer_;
  std::mutex operations_mutex_;
  std::map<std::string, std::unique_ptr<RunningOperation>> running_;
};

/// Milliseconds since the Unix epoch.
std::int64_t NowUnixMs();
/// A fresh identifier "<prefix>-<16 hex digits>".
std::string NewId(const std::string& prefix);

}  // namespace robocal::server
