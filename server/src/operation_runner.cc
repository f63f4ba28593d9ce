// Operations: async work on its own thread with a stored document; deadlines of synchronous work.
#include "robocal/server/operation_runner.h"

#include <unistd.h>

#include <random>
#include <vector>

#include "robocal/api/stored.h"
#include "robocal/api/text.h"
#include "robocal/server/logging.h"
#include "robocal/server/service.h"
#include "service_support.h"

namespace robocal::server {

using api::ApiError;
using api::Status;

WorkControl::WorkControl(std::chrono::steady_clock::time_point deadline) : deadline_(deadline) {}

WorkControl::WorkControl(std::atomic<double>* progress, const std::atomic<bool>* cancel,
                         std::function<bool()> still_owned)
    : progress_(progress), cancel_(cancel), still_owned_(std::move(still_owned)) {}

bool WorkControl::operator()(double fraction) {
  if (progress_ != nullptr) *progress_ = fraction;
  if (stop_ != Stop::kNone) return false;
  if (cancel_ != nullptr && cancel_->load()) stop_ = Stop::kCancel;
  if (deadline_ && std::chrono::steady_clock::now() > *deadline_) stop_ = Stop::kDeadline;
  return stop_ == Stop::kNone;
}

namespace {

/// host:pid:random, unique among the instances on one database (a restarted process on the same host and
/// pid differs by the random part).
std::string DefaultOwner() {
  char host[256] = {};
  if (::gethostname(host, sizeof host - 1) != 0) host[0] = '\0';
  std::random_device random;
  char tail[16];
  std::snprintf(tail, sizeof tail, "%08x", static_cast<unsigned>(random()));
  return std::string(host) + ":" + std::to_string(::getpid()) + ":" + tail;
}

/// An operation document `json` ended as FAILED (UNAVAILABLE) with `message`; unchanged if it had ended, or
/// if it cannot be read (a build that does not know its kind wrote it): its lease still ends, and one unreadable
/// document never holds up the leases after it.
std::string FailedDocument(const Document& doc, const std::string& message) {
  api::Operation op;
  try {
    op = ReadStored<api::StoredOperation>(doc).operation;
  } catch (const std::exception& e) {
    LogEvent(spdlog::level::err, "unreadable operation document; its lease ends, the document stays",
             {{"operation", doc.id}, {"error", api::SafeText(e.what())}});
    return doc.json;
  }
  if (op.done) return doc.json;
  op.state = api::OperationState::kFailed;
  op.done = true;
  op.error = api::MakeErrorInfo(Status::kUnavailable, api::HttpStatusOf(Status::kUnavailable), message);
  op.updated_unix_ms = NowUnixMs();
  return nlohmann::json(api::StoredOperation{op}).dump();
}

std::int64_t Ms(std::chrono::milliseconds d) { return static_cast<std::int64_t>(d.count()); }

}  // namespace

OperationRunner::OperationRunner(Storage* storage, MemoryTrimmer* trimmer, OperationRunnerOptions options)
    : storage_(storage), trimmer_(trimmer), options_(std::move(options)) {
  if (options_.owner.empty()) options_.owner = DefaultOwner();
  keeper_ = std::thread([this] { KeeperLoop(); });
}

void OperationRunner::KeeperLoop() {
  std::unique_lock lock(keeper_mutex_);
  while (!keeper_wake_.wait_for(lock, options_.lease / 3, [this] { return stopping_; })) {
    lock.unlock();
    try {
      KeepLeases();
    } catch (const std::exception& e) {
      // The database is unreachable; the next round tries again (an operation whose lease lapses meanwhile is
      // failed by another instance, and this one's finish is then refused).
      LogEvent(spdlog::level::warn, "cannot renew operation leases", {{"error", e.what()}});
    }
    lock.lock();
  }
}

int OperationRunner::KeepLeases() {
  struct Held {
    std::string id;
    std::shared_ptr<Running> running;
  };
  std::vector<Held> held;
  {
    std::lock_guard lock(mutex_);
    for (auto& [id, r] : running_) {
      if (!r->finished) held.push_back({id, r});
    }
  }
  // An operation that finishes meanwhile has ended its lease: renewing finds none and changes nothing.
  for (const Held& h : held) {
    const auto lease = storage_->RenewLease(h.id, options_.owner, Ms(options_.lease), h.running->progress.load());
    if (!lease || lease->cancel_requested) h.running->cancel = true;
  }
  // Also on a database one process owns: an operation whose final write failed (the disk full, say) has stopped
  // renewing, and its lease lapsing is what ends it FAILED rather than RUNNING until the next start.
  const auto ended = storage_->ExpireLeases(false, [](const Document& doc) {
    return FailedDocument(doc, "aborted: the server instance running it stopped renewing its lease "
                               "(operation_lease_s); plans and fits are deterministic from their request: "
                               "resubmit it to run it again");
  });
  for (const std::string& id : ended) {
    LogEvent(spdlog::level::warn, "operation of a stopped instance marked FAILED", {{"operation", id}});
  }
  return static_cast<int>(ended.size());
}

OperationRunner::~OperationRunner() {
  {
    std::lock_guard lock(keeper_mutex_);
    stopping_ = true;
  }
  keeper_wake_.notify_all();
  keeper_.join();
  // Joined outside the lock: an operation's thread takes mutex_ once more as it finishes (WaitUntilIdle).
  std::vector<std::thread*> threads;
  {
    std::lock_guard lock(mutex_);
    for (auto& [id, op] : running_) {
      op->cancel = true;
      threads.push_back(&op->thread);
    }
  }
  for (std::thread* t : threads) {
    if (t->joinable()) t->join();
  }
}

void OperationRunner::JoinFinished() {
  for (auto it = running_.begin(); it != running_.end();) {
    if (it->second->finished && it->second->thread.joinable()) {
      it->second->thread.join();
      it = running_.erase(it);
    } else {
      ++it;
    }
  }
}

api::Operation OperationRunner::Start(api::Operation op, Work work) {
  std::lock_guard lock(mutex_);
  JoinFinished();
  if (static_cast<int>(running_.size()) >= options_.max_running) {
    throw ApiError(Status::kUnavailable,
                   "too many running operations (limit " + std::to_string(options_.max_running) + ")",
                   {{"async", "limit of running operations reached; retry later"}});
  }
  op.state = api::OperationState::kRunning;
  op.done = false;
  op.progress = 0.0;
  op.created_unix_ms = op.updated_unix_ms = NowUnixMs();
  storage_->CreateLeased(op.id, nlohmann::json(api::StoredOperation{op}).dump(), options_.owner, Ms(options_.lease));
  auto running = std::make_shared<Running>();
  Running* r = running.get();
  running->thread = std::thread([this, work = std::move(work), op, r]() mutable {
    const TrimWhenDone trim(trimmer_, true);  // plans and fits
    WorkControl control(&r->progress, &r->cancel, [this, &op, r] {
      // Owned, lost, or unknown (the database did not answer): unknown is tried twice more, then the operation
      // fails rather than end SUCCEEDED without its result.
      for (int attempt = 0;; ++attempt) {
        try {
          if (storage_->RenewLease(op.id, options_.owner, Ms(options_.lease), r->progress.load())) return true;
          r->cancel = true;
          return false;
        } catch (const StorageError& e) {
          if (attempt == 2) {
            throw ApiError(Status::kUnavailable,
                           std::string("cannot confirm this operation's lease before storing its result (") +
                               e.what() + "); nothing was stored: resubmit it");
          }
        }
      }
    });
    try {
      work(control, &op);
      const bool cancelled = control.stop() == Stop::kCancel;
      op.state = cancelled ? api::OperationState::kCancelled : api::OperationState::kSucceeded;
      op.progress = cancelled ? r->progress.load() : 1.0;
    } catch (const ApiError& e) {
      op.state = api::OperationState::kFailed;
      op.error = api::MakeErrorInfo(e.status(), api::HttpStatusOf(e.status()), e.what(), e.details());
    } catch (const std::exception& e) {
      op.state = api::OperationState::kFailed;
      op.error = api::MakeErrorInfo(Status::kInternal, api::HttpStatusOf(Status::kInternal), e.what());
    }
    op.done = true;
    op.updated_unix_ms = NowUnixMs();
    try {
      if (!storage_->FinishLeased(op.id, options_.owner, nlohmann::json(api::StoredOperation{op}).dump())) {
        // Its lease lapsed (the database was out of reach longer than the lease) and another instance marked it
        // FAILED; that state stands, so that an operation ends once.
        LogEvent(spdlog::level::warn, "operation finished after its lease was taken; it stays FAILED",
                 {{"operation", op.id}});
      }
    } catch (const std::exception&) {
      // Its lease expires and an instance (this one, or the next start) marks it FAILED.
    }
    {
      // Under the lock, so that WaitUntilIdle cannot miss it; JoinFinished (which joins with the lock held) sees
      // `finished` only once this thread no longer needs the lock.
      const std::lock_guard lock(mutex_);
      r->finished = true;
    }
    finished_.notify_all();
  });
  running_[op.id] = std::move(running);
  return op;
}

api::Operation OperationRunner::Get(const std::string& id) {
  CheckId(id, "operation");
  const auto doc = storage_->Get(kOperations, id);
  if (!doc) throw ApiError(Status::kNotFound, "operation \"" + id + "\" not found");
  api::Operation op = ReadStored<api::StoredOperation>(*doc).operation;
  if (!op.done) {
    {
      std::lock_guard lock(mutex_);
      if (auto it = running_.find(id); it != running_.end()) {
        op.progress = it->second->progress.load();
        op.cancel_requested = it->second->cancel.load();
        return op;
      }
    }
    // Another instance runs it: progress as of its last renewal.
    if (const auto lease = storage_->GetLease(id)) {
      op.progress = lease->progress;
      op.cancel_requested = lease->cancel_requested;
    }
  }
  return op;
}

api::Operation OperationRunner::Cancel(const std::string& id) {
  CheckId(id, "operation");
  {
    std::lock_guard lock(mutex_);
    if (auto it = running_.find(id); it != running_.end()) it->second->cancel = true;
  }
  storage_->RequestCancel(id);  // for the instance that runs it, if another; false once it has ended
  return Get(id);
}

int OperationRunner::running() {
  std::lock_guard lock(mutex_);
  int n = 0;
  for (const auto& [id, op] : running_) {
    if (!op->finished) ++n;
  }
  return n;
}

void OperationRunner::WaitUntilIdle() {
  std::unique_lock lock(mutex_);
  finished_.wait(lock, [this] {
    for (const auto& [id, op] : running_) {
      if (!op->finished) return false;
    }
    return true;
  });
}

int OperationRunner::Recover() {
  // One process owns an unshared database: every lease in it belongs to a process that is gone.
  const std::string message = storage_->Shared() ? "aborted: the server instance running it stopped"
                                                 : "aborted: the server stopped while it ran";
  int marked = static_cast<int>(
      storage_->ExpireLeases(!storage_->Shared(), [&](const Document& doc) { return FailedDocument(doc, message); })
          .size());
  // Operations RUNNING without a lease were stored before leases existed (otherwise a document and its lease are
  // created, and ended, in one transaction). The version check leaves alone one that changed meanwhile.
  std::string after;
  for (;;) {
    const auto docs = storage_->List(kOperations, after, 1000);
    if (docs.empty()) break;
    for (const Document& d : docs) {
      try {
        if (ReadStored<api::StoredOperation>(d).operation.done || storage_->GetLease(d.id)) continue;
      } catch (const ApiError& e) {
        LogEvent(spdlog::level::err, "unreadable operation document left as it is",
                 {{"operation", d.id}, {"error", api::SafeText(e.what())}});
        continue;
      }
      try {
        storage_->Update(kOperations, d.id, FailedDocument(d, message), d.version);
        ++marked;
      } catch (const StorageError& e) {
        if (e.kind() != StorageError::Kind::kVersionConflict && e.kind() != StorageError::Kind::kNotFound) throw;
      }
    }
    after = docs.back().id;
  }
  return marked;
}

}  // namespace robocal::server
