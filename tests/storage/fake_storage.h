// An in-memory Storage for the service tests, with the interface's semantics (atomic, idempotent batches,
// limits, a deleted campaign's measurements gone with it). storage_test.cc runs the same contract suite against
// it and against SQLite, so that the service tests never pass on behaviour SQLite does not have.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdio>
#include <map>
#include <mutex>

#include "server/storage/storage.h"

namespace robocal::server::testing {

class FakeStorage : public Storage {
 public:
  Document Create(const std::string& collection, const std::string& id, const std::string& json) override {
    std::lock_guard lock(mutex_);
    auto& c = docs_[collection];
    if (c.count(id)) throw StorageError(StorageError::Kind::kAlreadyExists, collection + "/" + id + " exists");
    return c[id] = Document{collection, id, json, 1, ++clock_, clock_};
  }
  std::optional<Document> Get(const std::string& collection, const std::string& id) override {
    std::lock_guard lock(mutex_);
    auto& c = docs_[collection];
    auto it = c.find(id);
    if (it == c.end()) return std::nullopt;
    return it->second;
  }
  Document Update(const std::string& collection, const std::string& id, const std::string& json,
                  std::int64_t expected_version) override {
    std::lock_guard lock(mutex_);
    auto& c = docs_[collection];
    auto it = c.find(id);
    if (it == c.end()) throw StorageError(StorageError::Kind::kNotFound, id);
    if (expected_version > 0 && expected_version != it->second.version) {
      throw StorageError(StorageError::Kind::kVersionConflict, "version");
    }
    it->second.json = json;
    ++it->second.version;
    it->second.updated_unix_ms = ++clock_;
    return it->second;
  }
  Document Put(const std::string& collection, const std::string& id, const std::string& json) override {
    std::lock_guard lock(mutex_);
    auto& c = docs_[collection];
    auto it = c.find(id);
    if (it == c.end()) return c[id] = Document{collection, id, json, 1, ++clock_, clock_};
    it->second.json = json;
    ++it->second.version;
    it->second.updated_unix_ms = ++clock_;
    return it->second;
  }
  bool Delete(const std::string& collection, const std::string& id) override {
    std::lock_guard lock(mutex_);
    if (docs_[collection].erase(id) == 0) return false;
    if (collection == "operations") leases_.erase(id);
    if (collection == "campaigns") {
      // A campaign's measurements and batch keys go with it, as in SQLite.
      measurements_.erase(id);
      for (auto it = batches_.begin(); it != batches_.end();) {
        it = it->first.first == id ? batches_.erase(it) : std::next(it);
      }
    }
    return true;
  }
  std::vector<Document> List(const std::string& collection, const std::string& after_id, int limit) override {
    std::lock_guard lock(mutex_);
    std::vector<Document> out;
    auto& c = docs_[collection];
    for (auto it = c.upper_bound(after_id); it != c.end() && static_cast<int>(out.size()) < limit; ++it) {
      out.push_back(it->second);
    }
    return out;
  }
  BatchResult AppendMeasurements(const std::string& campaign_id, const std::string& request_id,
                                 const std::string& content_hash, const std::string& role,
                                 const std::vector<std::string>& measurements_json,
                                 std::int64_t max_campaign_total) override {
    std::lock_guard lock(mutex_);
    if (!docs_["campaigns"].count(campaign_id)) throw StorageError(StorageError::Kind::kNotFound, campaign_id);
    auto& list = measurements_[campaign_id];
    const auto key = std::make_pair(campaign_id, request_id);
    // An empty request_id is no idempotency key: every such batch is new.
    if (auto it = request_id.empty() ? batches_.end() : batches_.find(key); it != batches_.end()) {
      // The same key with other content, or the same content for another role, is another batch.
      if (it->second.hash != content_hash || it->second.role != role) {
        throw StorageError(StorageError::Kind::kAlreadyExists, request_id);
      }
      BatchResult r = it->second.result;
      r.replayed = true;
      r.campaign_total = static_cast<std::int64_t>(list.size());
      return r;
    }
    const auto total = static_cast<std::int64_t>(list.size() + measurements_json.size());
    if (max_campaign_total > 0 && total > max_campaign_total) {
      throw StorageError(StorageError::Kind::kResourceExhausted, "too many measurements");
    }
    char batch_id[19];
    std::snprintf(batch_id, sizeof batch_id, "b-%016llx", static_cast<unsigned long long>(++clock_));
    BatchResult r{.campaign = campaign_id,
                  .batch_id = batch_id,
                  .request_id = request_id,
                  .replayed = false,
                  .first_sequence = static_cast<std::int64_t>(list.size()) + 1,
                  .count = static_cast<std::int64_t>(measurements_json.size()),
                  .campaign_total = total,
                  .stale = {}};
    for (const auto& m : measurements_json) {
      list.push_back({static_cast<std::int64_t>(list.size()) + 1, r.batch_id, role, m});
    }
    if (!request_id.empty()) batches_[key] = {content_hash, role, r};
    return r;
  }
  std::vector<StoredMeasurement> ListMeasurements(const std::string& campaign_id, const std::string& role,
                                                  std::int64_t after_sequence, int limit) override {
    std::lock_guard lock(mutex_);
    std::vector<StoredMeasurement> out;
    for (const auto& m : measurements_[campaign_id]) {
      if (m.sequence > after_sequence && (role.empty() || m.role == role) && static_cast<int>(out.size()) < limit) {
        out.push_back(m);
      }
    }
    return out;
  }
  std::int64_t CountMeasurements(const std::string& campaign_id, const std::string& role) override {
    std::lock_guard lock(mutex_);
    std::int64_t n = 0;
    for (const auto& m : measurements_[campaign_id]) n += role.empty() || m.role == role;
    return n;
  }
  Document CreateLeased(const std::string& id, const std::string& json, const std::string& owner,
                        std::int64_t lease_ms) override {
    Document doc = Create("operations", id, json);
    std::lock_guard lock(mutex_);
    leases_[id] = Lease{OperationLease{owner, 0.0, false, 0}, NowMs() + lease_ms};
    return doc;
  }
  std::optional<OperationLease> RenewLease(const std::string& id, const std::string& owner, std::int64_t lease_ms,
                                           double progress) override {
    std::lock_guard lock(mutex_);
    if (fail_renewals) throw StorageError(StorageError::Kind::kUnavailable, "the database did not answer");
    auto it = leases_.find(id);
    if (it == leases_.end() || it->second.lease.owner != owner) return std::nullopt;
    it->second.expires_ms = NowMs() + lease_ms;
    it->second.lease.progress = progress;
    return LeaseOf(it->second);
  }
  std::optional<OperationLease> GetLease(const std::string& id) override {
    std::lock_guard lock(mutex_);
    auto it = leases_.find(id);
    if (it == leases_.end()) return std::nullopt;
    return LeaseOf(it->second);
  }
  bool RequestCancel(const std::string& id) override {
    std::lock_guard lock(mutex_);
    auto it = leases_.find(id);
    if (it == leases_.end()) return false;
    it->second.lease.cancel_requested = true;
    return true;
  }
  bool FinishLeased(const std::string& id, const std::string& owner, const std::string& json) override {
    if (fail_finishes) throw StorageError(StorageError::Kind::kUnavailable, "disk full");
    {
      std::lock_guard lock(mutex_);
      auto it = leases_.find(id);
      if (it == leases_.end() || it->second.lease.owner != owner) return false;
      leases_.erase(it);
    }
    Update("operations", id, json, 0);
    return true;
  }
  std::vector<std::string> ExpireLeases(bool all, const std::function<std::string(const Document&)>& expire) override {
    std::lock_guard lock(mutex_);
    std::vector<std::string> ended;
    const std::int64_t now = NowMs();
    for (auto it = leases_.begin(); it != leases_.end();) {
      if (!all && it->second.expires_ms >= now) {
        ++it;
        continue;
      }
      auto& ops = docs_["operations"];
      if (auto doc = ops.find(it->first); doc != ops.end()) {
        doc->second.json = expire(doc->second);
        ++doc->second.version;
        doc->second.updated_unix_ms = ++clock_;
      }
      ended.push_back(it->first);
      it = leases_.erase(it);
    }
    return ended;
  }
  bool Shared() const override { return shared; }
  /// Tests: Shared()'s answer (a fake standing for a database several instances use).
  bool shared = false;
  /// Tests: RenewLease fails kUnavailable, as when the database does not answer.
  std::atomic<bool> fail_renewals{false};
  /// Tests: FinishLeased fails kUnavailable, as when the disk is full.
  std::atomic<bool> fail_finishes{false};
  /// Tests: makes the lease of `id` expired now, as when its owner stopped renewing it.
  void LapseLease(const std::string& id) {
    std::lock_guard lock(mutex_);
    if (auto it = leases_.find(id); it != leases_.end()) it->second.expires_ms = NowMs() - 1;
  }
  std::string IntegrityCheck() override { return "ok"; }
  int SchemaVersion() override { return 1; }

 private:
  std::mutex mutex_;
  std::int64_t clock_ = 0;
  std::map<std::string, std::map<std::string, Document>> docs_;
  std::map<std::string, std::vector<StoredMeasurement>> measurements_;
  struct Batch {
    std::string hash;
    std::string role;
    BatchResult result;
  };
  std::map<std::pair<std::string, std::string>, Batch> batches_;  // (campaign, request_id)
  struct Lease {
    OperationLease lease;
    std::int64_t expires_ms = 0;  // steady clock
  };
  static std::int64_t NowMs() {
    return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
  }
  OperationLease LeaseOf(const Lease& l) const {
    OperationLease out = l.lease;
    out.expires_in_ms = l.expires_ms - NowMs();
    return out;
  }
  std::map<std::string, Lease> leases_;
};

}  // namespace robocal::server::testing
