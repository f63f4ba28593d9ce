// An in-memory Storage for the service tests, with the interface's semantics (atomic, idempotent batches,
// limits). Used until the SQLite storage is available on this branch, and for tests that need no disk.
#pragma once

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
      throw StorageError(StorageError::Kind::kAlreadyExists, "version");
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
    return it->second;
  }
  bool Delete(const std::string& collection, const std::string& id) override {
    std::lock_guard lock(mutex_);
    return docs_[collection].erase(id) > 0;
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
    if (auto it = batches_.find(key); it != batches_.end()) {
      if (it->second.first != content_hash) throw StorageError(StorageError::Kind::kAlreadyExists, request_id);
      BatchResult r = it->second.second;
      r.replayed = true;
      r.campaign_total = static_cast<std::int64_t>(list.size());
      return r;
    }
    const auto total = static_cast<std::int64_t>(list.size() + measurements_json.size());
    if (max_campaign_total > 0 && total > max_campaign_total) {
      throw StorageError(StorageError::Kind::kResourceExhausted, "too many measurements");
    }
    BatchResult r{"batch-" + std::to_string(++clock_), request_id, false,
                  static_cast<std::int64_t>(list.size()) + 1,
                  static_cast<std::int64_t>(measurements_json.size()), total};
    for (const auto& m : measurements_json) {
      list.push_back({static_cast<std::int64_t>(list.size()) + 1, r.batch_id, role, m});
    }
    batches_[key] = {content_hash, r};
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
  std::string IntegrityCheck() override { return "ok"; }
  int SchemaVersion() override { return 1; }

 private:
  std::mutex mutex_;
  std::int64_t clock_ = 0;
  std::map<std::string, std::map<std::string, Document>> docs_;
  std::map<std::string, std::vector<StoredMeasurement>> measurements_;
  std::map<std::pair<std::string, std::string>, std::pair<std::string, BatchResult>> batches_;
};

}  // namespace robocal::server::testing
