// Long-running and deadline-bound work of the service: async plans and fits run as operations on their own
// threads (progress, cancel, a stored document per operation); synchronous ones run on the request's thread
// until the request deadline. One piece decides when work stops and how a stop is described.
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "robocal/api/operations.h"
#include "robocal/server/memory_trimmer.h"
#include "server/storage/storage.h"

namespace robocal::server {

/// Why work stopped before it finished.
enum class Stop { kNone, kDeadline, kCancel };

/// Handed to work as its progress callback: records progress and says whether to go on (false once the
/// deadline has passed or a cancel was asked for; the reason stays in stop()).
class WorkControl {
 public:
  /// Work bound by a deadline (synchronous requests).
  explicit WorkControl(std::chrono::steady_clock::time_point deadline);
  /// Work of an operation: progress goes to `progress`, `cancel` stops it.
  WorkControl(std::atomic<double>* progress, const std::atomic<bool>* cancel);

  /// Records `fraction` (0..1); false when the work must stop.
  bool operator()(double fraction);
  /// The callback form the core's options take.
  std::function<bool(double)> Callback() {
    return [this](double fraction) { return (*this)(fraction); };
  }
  Stop stop() const { return stop_; }

 private:
  std::optional<std::chrono::steady_clock::time_point> deadline_;
  std::atomic<double>* progress_ = nullptr;
  const std::atomic<bool>* cancel_ = nullptr;
  Stop stop_ = Stop::kNone;
};

/// Marks a summary (api::PlanSummaryWire or api::FitSummary) of synchronous work the deadline stopped:
/// NO_CONVERGENCE, deadline_exceeded, and a message saying what was kept ("the best set so far", ...).
template <typename Summary>
void DescribeDeadlineStop(std::chrono::milliseconds deadline, const std::string& kept, const std::string& advice,
                          Summary* summary) {
  summary->termination = Termination::kNoConvergence;
  summary->deadline_exceeded = true;
  summary->message = "stopped at the request deadline (" + std::to_string(deadline.count()) +
                     " ms, request_timeout_s) after " + std::to_string(summary->iterations) + " iterations with " +
                     kept + "; " + advice;
  // The core's brief says "cancelled" for any stop its caller asked for; here the caller was the deadline.
  if constexpr (requires { summary->brief; }) {
    const std::size_t at = summary->brief.find("cancelled");
    if (at != std::string::npos) summary->brief.replace(at, 9, "stopped at the request deadline");
  }
}

struct OperationRunnerOptions {
  /// Operations running at once; more is UNAVAILABLE.
  int max_running = 2;
};

class OperationRunner {
 public:
  /// The work of an operation: runs under `control` and fills the operation's result (op->plan or op->fit).
  /// ApiErrors it throws become the operation's error (FAILED); a stop by cancel makes it CANCELLED.
  using Work = std::function<void(WorkControl& control, api::Operation* op)>;

  OperationRunner(Storage* storage, MemoryTrimmer* trimmer, OperationRunnerOptions options);
  /// Cancels running operations and waits for them (their documents end as CANCELLED).
  ~OperationRunner();
  OperationRunner(const OperationRunner&) = delete;
  OperationRunner& operator=(const OperationRunner&) = delete;

  /// Stores `op` (id, kind, request and campaign set by the caller) as RUNNING and runs `work` on its own
  /// thread; UNAVAILABLE when max_running operations are running. Returns the operation as stored.
  api::Operation Start(api::Operation op, Work work);
  /// The stored operation with the live progress of a running one.
  api::Operation Get(const std::string& id);
  /// Asks a running operation to stop; returns it.
  api::Operation Cancel(const std::string& id);
  /// Operations still running.
  int running();
  /// Marks operations left RUNNING by a previous process as FAILED ("aborted: the server stopped"). Returns how
  /// many were marked.
  int Recover();

 private:
  struct Running {
    std::atomic<double> progress{0.0};
    std::atomic<bool> cancel{false};
    std::atomic<bool> finished{false};
    std::thread thread;
  };
  void JoinFinished();  // with mutex_ held

  Storage* storage_;
  MemoryTrimmer* trimmer_;
  OperationRunnerOptions options_;
  std::mutex mutex_;
  std::map<std::string, std::unique_ptr<Running>> running_;
};

}  // namespace robocal::server
