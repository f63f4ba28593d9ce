// Long-running and deadline-bound work of the service: async plans and fits run as operations on their own
// threads (progress, cancel, a stored document per operation); synchronous ones run on the request's thread
// until the request deadline. One piece decides when work stops and how a stop is described.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
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
  /// Work of an operation: progress goes to `progress`, `cancel` stops it, `still_owned` renews the
  /// operation's lease and says whether this instance still holds it.
  WorkControl(std::atomic<double>* progress, const std::atomic<bool>* cancel,
              std::function<bool()> still_owned = {});

  /// Records `fraction` (0..1); false when the work must stop.
  bool operator()(double fraction);
  /// The callback form the core's options take.
  std::function<bool(double)> Callback() {
    return [this](double fraction) { return (*this)(fraction); };
  }
  Stop stop() const { return stop_; }
  /// Asked right before work writes its result (a calibration, a plan): true for work bound by a deadline; for
  /// an operation, renews its lease and is false if another instance has taken it over (its lease lapsed), so
  /// that the work of an operation already marked FAILED writes nothing. The renewal leaves a whole lease for
  /// the write.
  bool StillOwned() const { return !still_owned_ || still_owned_(); }

 private:
  std::optional<std::chrono::steady_clock::time_point> deadline_;
  std::atomic<double>* progress_ = nullptr;
  const std::atomic<bool>* cancel_ = nullptr;
  std::function<bool()> still_owned_;
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
  /// Operations running at once (on this instance); more is UNAVAILABLE.
  int max_running = 2;
  /// Every running operation holds a lease in the storage, renewed every third of this; an operation whose
  /// lease has expired is marked FAILED by whichever instance on the database sees it first.
  std::chrono::milliseconds lease{10000};
  /// This instance's name in the leases it holds; empty: host name, process id and 32 random bits.
  std::string owner;
};

/// Operations are rows of the storage, shared by every instance on the database: the instance that starts one
/// runs it under a lease it renews (writing progress and reading cancel requests), GET and :cancel work from
/// any instance, and an operation whose instance stopped renewing is marked FAILED with the reason once its
/// lease has expired. FAILED rather than run again: the work was resolved from the robot and campaign as they
/// were when it was submitted (a campaign may have grown since), and a request that brought an instance down
/// would bring down each instance that took it over. Plans and fits are deterministic from their request, so
/// the client resubmits.
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
  /// Asks a running operation to stop, on whichever instance runs it (that instance sees the request at its
  /// next renewal); returns it.
  api::Operation Cancel(const std::string& id);
  /// Operations still running on this instance.
  int running();
  /// Returns once no operation runs on this instance (each one's final document written).
  void WaitUntilIdle();
  /// At start: marks FAILED the operations no live instance runs: those whose lease has expired, those left
  /// RUNNING without a lease, and, on a database one process owns (SQLite), every one left RUNNING (its
  /// process is gone). Returns how many were marked.
  int Recover();
  /// Renews this instance's leases (progress out, cancel requests in) and marks FAILED the operations whose
  /// lease has expired. The lease keeper calls it every third of the lease; public for tests. Returns how many
  /// operations were marked FAILED.
  int KeepLeases();
  const std::string& owner() const { return options_.owner; }

 private:
  struct Running {
    std::atomic<double> progress{0.0};
    std::atomic<bool> cancel{false};
    std::atomic<bool> finished{false};
    std::thread thread;
  };
  void JoinFinished();  // with mutex_ held
  void KeeperLoop();

  Storage* storage_;
  MemoryTrimmer* trimmer_;
  OperationRunnerOptions options_;
  std::mutex mutex_;
  std::map<std::string, std::shared_ptr<Running>> running_;
  // Notified (with mutex_ taken and released first) each time an operation's thread has finished.
  std::condition_variable finished_;
  // The lease keeper: wakes every third of the lease, or at once to stop.
  std::mutex keeper_mutex_;
  std::condition_variable keeper_wake_;
  bool stopping_ = false;
  std::thread keeper_;
};

}  // namespace robocal::server
