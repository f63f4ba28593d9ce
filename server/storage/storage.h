// The storage interface of the calibration service: JSON documents by collection, and append-only
// measurement batches that are atomic and idempotent by request id. SQLite implements it (sqlite_storage.cc);
// the interface leaves room for another database.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace robocal::server {

/// A storage failure the service maps to an HTTP status in one place.
class StorageError : public std::runtime_error {
 public:
  enum class Kind {
    kNotFound,           ///< no document / campaign with that id
    kAlreadyExists,      ///< id taken; or a request_id reused with different content
    kResourceExhausted,  ///< a stored limit would be exceeded (e.g. measurements per campaign)
    kUnavailable,        ///< the database cannot be opened / is busy / disk full
    kInternal,           ///< corruption or a bug
  };
  StorageError(Kind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

/// A stored JSON document. `json` is opaque text to the storage.
struct Document {
  std::string collection;
  std::string id;
  std::string json;
  /// Incremented by every update, starting at 1.
  std::int64_t version = 0;
  /// Milliseconds since the Unix epoch (UTC).
  std::int64_t created_unix_ms = 0;
  std::int64_t updated_unix_ms = 0;
};

/// One stored measurement of a campaign.
struct StoredMeasurement {
  /// 1-based position in the campaign, in upload order; never reused.
  std::int64_t sequence = 0;
  std::string batch_id;
  /// "calibration" or "validation" (not interpreted by the storage).
  std::string role;
  std::string json;
};

/// The outcome of appending a batch.
struct BatchResult {
  std::string batch_id;
  std::string request_id;
  /// True if request_id had been stored before with the same content: nothing was written, the original
  /// batch is returned.
  bool replayed = false;
  std::int64_t first_sequence = 0;
  std::int64_t count = 0;
  /// Measurements in the campaign after the append (all roles).
  std::int64_t campaign_total = 0;
};

/// Thread-safe; every write is one transaction that is durable (fsynced) when the call returns.
class Storage {
 public:
  virtual ~Storage() = default;

  /// Documents. Collections used by the service: "robots", "plans", "campaigns", "calibrations", "operations".
  /// Create throws kAlreadyExists if (collection, id) exists.
  virtual Document Create(const std::string& collection, const std::string& id, const std::string& json) = 0;
  virtual std::optional<Document> Get(const std::string& collection, const std::string& id) = 0;
  /// Replaces the document's json. If expected_version > 0 and differs from the stored version, throws
  /// kAlreadyExists (a concurrent update won). Throws kNotFound if absent.
  virtual Document Update(const std::string& collection, const std::string& id, const std::string& json,
                          std::int64_t expected_version = 0) = 0;
  /// Create or replace.
  virtual Document Put(const std::string& collection, const std::string& id, const std::string& json) = 0;
  /// Returns false if absent. Deleting a "campaigns" document also deletes its measurements and batches.
  virtual bool Delete(const std::string& collection, const std::string& id) = 0;
  /// Documents in id order, starting after `after_id` (empty: from the start), at most `limit`.
  virtual std::vector<Document> List(const std::string& collection, const std::string& after_id = "",
                                     int limit = 1000) = 0;

  /// Appends a batch of measurements to a campaign, all or nothing. `content_hash` identifies the batch's
  /// content: a second call with the same (campaign_id, request_id) and the same hash returns the first
  /// result with replayed = true; with another hash it throws kAlreadyExists. Throws kResourceExhausted if the
  /// campaign would hold more than `max_campaign_total` measurements (0 = no limit). The campaign must exist as
  /// a document in "campaigns" (kNotFound otherwise). An empty request_id disables replay detection.
  virtual BatchResult AppendMeasurements(const std::string& campaign_id, const std::string& request_id,
                                         const std::string& content_hash, const std::string& role,
                                         const std::vector<std::string>& measurements_json,
                                         std::int64_t max_campaign_total = 0) = 0;
  /// Measurements of a campaign in sequence order; role empty means all roles; after_sequence for paging.
  virtual std::vector<StoredMeasurement> ListMeasurements(const std::string& campaign_id,
                                                          const std::string& role = "",
                                                          std::int64_t after_sequence = 0,
                                                          int limit = 1000000) = 0;
  virtual std::int64_t CountMeasurements(const std::string& campaign_id, const std::string& role = "") = 0;

  /// "ok" if the database passes its integrity check, else the problems found.
  virtual std::string IntegrityCheck() = 0;
  /// Schema version of the open database.
  virtual int SchemaVersion() = 0;
};

/// Opens (creating if needed, with parent directories) a SQLite database at `path` in WAL mode with
/// synchronous=FULL; ":memory:" gives a private in-memory database for tests. Throws StorageError
/// (kUnavailable) if it cannot be opened, or if its schema version is newer than this build knows.
std::unique_ptr<Storage> OpenSqliteStorage(const std::string& path);

}  // namespace robocal::server
