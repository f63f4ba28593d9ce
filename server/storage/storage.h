// The storage interface of the calibration service: JSON documents by collection, append-only measurement
// batches that are atomic and idempotent by request id, and leases on running operations. SQLite
// (sqlite_storage.cc, one process) and PostgreSQL (pg_storage.cc, several instances on one database) implement
// it; OpenStorage picks one by the --db value.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "robocal/api/batch_result.h"

namespace robocal::server {

/// A storage failure the service maps to an HTTP status in one place.
class StorageError : public std::runtime_error {
 public:
  enum class Kind {
    kNotFound,           ///< no document / campaign with that id
    kAlreadyExists,      ///< id taken; or a request_id reused with different content
    kVersionConflict,    ///< an update that expected another version: a concurrent update won
    kResourceExhausted,  ///< a stored limit would be exceeded (e.g. measurements per campaign)
    kUnavailable,        ///< the database cannot be opened / is busy / disk full
    kInternal,           ///< corruption or a bug
  };
  /// `message` is for the caller (a reply's text); `detail`, if any, is the database's own text for the log
  /// (statements, driver messages), never sent to a client.
  StorageError(Kind kind, const std::string& message, std::string detail = {})
      : std::runtime_error(message), kind_(kind), detail_(std::move(detail)) {}
  Kind kind() const { return kind_; }
  const std::string& detail() const { return detail_; }

 private:
  Kind kind_;
  std::string detail_;
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

/// The outcome of appending a batch: the wire's reply itself (api/batch_result.h, one struct for both).
using api::BatchResult;

/// The live state of a running operation, shared by every instance on the database: who runs it, how far it
/// got, whether a cancel was asked for (by any instance).
struct OperationLease {
  std::string owner;
  double progress = 0.0;
  bool cancel_requested = false;
  /// Milliseconds until the lease expires by the database's clock; negative once expired.
  std::int64_t expires_in_ms = 0;
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
  /// kVersionConflict (a concurrent update won; CheckVersion). Throws kNotFound if absent.
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

  /// Operation leases. A lease belongs to a document of the "operations" collection and is held by one
  /// `owner` (a server instance) until it expires, `lease_ms` after its last renewal by the database's clock.
  /// Creates the document and its lease in one transaction (kAlreadyExists if the id is taken).
  virtual Document CreateLeased(const std::string& id, const std::string& json, const std::string& owner,
                                std::int64_t lease_ms) = 0;
  /// Extends `owner`'s lease by `lease_ms` from now and records `progress`; returns the lease (with
  /// cancel_requested), or nullopt if `owner` no longer holds it (it expired and was taken, or it ended).
  virtual std::optional<OperationLease> RenewLease(const std::string& id, const std::string& owner,
                                                   std::int64_t lease_ms, double progress) = 0;
  virtual std::optional<OperationLease> GetLease(const std::string& id) = 0;
  /// Records a cancel request on the lease for its owner to see; false if the operation holds no lease.
  virtual bool RequestCancel(const std::string& id) = 0;
  /// Replaces the document's json and ends the lease, in one transaction, if `owner` still holds the lease;
  /// false (nothing written) if it does not: an expired lease was taken and the document already ended.
  virtual bool FinishLeased(const std::string& id, const std::string& owner, const std::string& json) = 0;
  /// Ends every expired lease (every lease when `all`): in one transaction per lease, the document's json is
  /// replaced by `expire(document)` and the lease deleted. Instances may call it at once; each lease is ended by
  /// one of them. Returns the ids ended.
  virtual std::vector<std::string> ExpireLeases(bool all,
                                                const std::function<std::string(const Document&)>& expire) = 0;
  /// True if several server processes may use this database at once (PostgreSQL); false if one process owns
  /// it (an SQLite file, memory), so that at start every lease found belongs to a process that is gone.
  virtual bool Shared() const = 0;

  /// "ok" if the database passes its integrity check, else the problems found.
  virtual std::string IntegrityCheck() = 0;
  /// Schema version of the open database.
  virtual int SchemaVersion() = 0;
};

/// Settings of OpenStorage that only some databases use.
struct StorageOptions {
  /// PostgreSQL: connections held open (each request, operation and lease renewal borrows one).
  int pool_size = 8;
  /// PostgreSQL: how long a call waits for a free connection before kUnavailable.
  std::int64_t pool_wait_ms = 10000;
};

/// `db` with any password in it replaced by "***", for logs, banners and error messages.
std::string RedactUrl(const std::string& db);

/// Whether `db` names a PostgreSQL database (a postgresql:// or postgres:// URL).
bool IsPostgresUrl(const std::string& db);

/// Opens the database `db` names: a PostgreSQL URL (OpenPostgresStorage), else an SQLite path or ":memory:"
/// (OpenSqliteStorage). Never falls back from one to the other. Throws StorageError (kUnavailable).
std::unique_ptr<Storage> OpenStorage(const std::string& db, const StorageOptions& options = {});

/// Connects `options.pool_size` times to the PostgreSQL database at `url` (a libpq connection URI), then creates
/// or migrates the schema in one transaction under an advisory lock, so that instances starting together do not
/// race. Throws StorageError (kUnavailable) if it cannot connect, or if the schema is newer than this build.
std::unique_ptr<Storage> OpenPostgresStorage(const std::string& url, const StorageOptions& options = {});

/// Opens (creating if needed, with parent directories) a SQLite database at `path` in WAL mode with
/// synchronous=FULL; ":memory:" gives a private in-memory database for tests. Throws StorageError
/// (kUnavailable) if it cannot be opened, or if its schema version is newer than this build knows.
std::unique_ptr<Storage> OpenSqliteStorage(const std::string& path);

}  // namespace robocal::server
