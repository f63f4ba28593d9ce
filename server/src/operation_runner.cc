// Operations: async work on its own thread with a stored document; deadlines of synchronous work.
#include "robocal/server/operation_runner.h"

#include <vector>

#include "robocal/api/stored.h"
#include "robocal/server/service.h"
#include "service_support.h"

namespace robocal::server {

using api::ApiError;
using api::Status;

WorkControl::WorkControl(std::chrono::steady_clock::time_point deadline) : deadline_(deadline) {}

WorkControl::WorkControl(std::atomic<double>* progress, const std::atomic<bool>* cancel)
    : progress_(progress), cancel_(cancel) {}

bool WorkControl::operator()(double fraction) {
  if (progress_ != nullptr) *progress_ = fraction;
  if (stop_ != Stop::kNone) return false;
  if (cancel_ != nullptr && cancel_->load()) stop_ = Stop::kCancel;
  if (deadline_ && std::chrono::steady_clock::now() > *deadline_) stop_ = Stop::kDeadline;
  return stop_ == Stop::kNone;
}

OperationRunner::OperationRunner(Storage* storage, MemoryTrimmer* trimmer, OperationRunnerOptions options)
    : storage_(storage), trimmer_(trimmer), options_(options) {}

OperationRunner::~OperationRunner() {
  // Threads never touch running_, so joining outside the lock cannot deadlock.
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
  storage_->Create(kOperations, op.id, nlohmann::json(api::StoredOperation{op}).dump());
  auto running = std::make_unique<Running>();
  Running* r = running.get();
  running->thread = std::thread([this, work = std::move(work), op, r]() mutable {
    const TrimWhenDone trim(trimmer_, true);  // plans and fits
    WorkControl control(&r->progress, &r->cancel);
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
      storage_->Put(kOperations, op.id, nlohmann::json(api::StoredOperation{op}).dump());
    } catch (const std::exception&) {
      // The next start marks it FAILED; nothing else can be done without storage.
    }
    r->finished = true;
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
    std::lock_guard lock(mutex_);
    if (auto it = running_.find(id); it != running_.end()) {
      op.progress = it->second->progress.load();
      op.cancel_requested = it->second->cancel.load();
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

int OperationRunner::Recover() {
  int marked = 0;
  std::string after;
  for (;;) {
    const auto docs = storage_->List(kOperations, after, 1000);
    if (docs.empty()) break;
    for (const Document& d : docs) {
      api::Operation op = ReadStored<api::StoredOperation>(d).operation;
      if (op.state == api::OperationState::kRunning) {
        op.state = api::OperationState::kFailed;
        op.done = true;
        op.error = api::MakeErrorInfo(Status::kUnavailable, api::HttpStatusOf(Status::kUnavailable),
                                      "aborted: the server stopped while it ran");
        op.updated_unix_ms = NowUnixMs();
        storage_->Put(kOperations, d.id, nlohmann::json(api::StoredOperation{op}).dump());
        ++marked;
      }
    }
    after = docs.back().id;
  }
  return marked;
}

}  // namespace robocal::server
