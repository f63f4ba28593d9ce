// The SQLite implementation of Storage: one connection in WAL mode with synchronous=FULL, every write one
// BEGIN IMMEDIATE transaction, the schema versioned in PRAGMA user_version. One process owns the file
// (Shared() is false), so operation leases are timed by this host's clock. docs/storage.md has the schema
// and the durability argument.
#include <sqlite3.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "server/storage/storage.h"
#include "server/storage/storage_common.h"

namespace robocal::server {
namespace {

using Kind = StorageError::Kind;

/// The schema version this build writes; Migrate() brings older databases up to it step by step.
constexpr int kSqliteSchemaVersion = 2;

/// How long a statement waits for a lock held by another process (e.g. a backup) before failing with
/// kUnavailable. Within the process the mutex already serialises access.
constexpr int kBusyTimeoutMs = 5000;

Kind KindOf(int rc) {
  switch (rc & 0xff) {
    case SQLITE_CONSTRAINT:
      return Kind::kAlreadyExists;
    case SQLITE_FULL:
    case SQLITE_IOERR:
    case SQLITE_CANTOPEN:
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
    case SQLITE_READONLY:
    case SQLITE_PERM:
    case SQLITE_NOMEM:
    case SQLITE_NOLFS:
      return Kind::kUnavailable;
    default:  // SQLITE_CORRUPT, SQLITE_NOTADB, SQLITE_MISUSE, ...
      return Kind::kInternal;
  }
}

std::int64_t NowUnixMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

/// A prepared statement borrowed from the cache; resets itself when it goes out of scope so that it holds
/// no read lock and no stale bindings.
class Statement {
 public:
  Statement(sqlite3* db, sqlite3_stmt* stmt) : db_(db), stmt_(stmt) {}
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  ~Statement() {
    sqlite3_reset(stmt_);
    sqlite3_clear_bindings(stmt_);
  }

  Statement& Bind(int index, const std::string& text) {
    Check(sqlite3_bind_text(stmt_, index, text.data(), static_cast<int>(text.size()), SQLITE_TRANSIENT));
    return *this;
  }
  Statement& Bind(int index, std::int64_t value) {
    Check(sqlite3_bind_int64(stmt_, index, value));
    return *this;
  }
  Statement& Bind(int index, double value) {
    Check(sqlite3_bind_double(stmt_, index, value));
    return *this;
  }
  Statement& BindNull(int index) {
    Check(sqlite3_bind_null(stmt_, index));
    return *this;
  }

  /// True if a row is available; false when done.
  bool Step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    Check(rc);
    return false;
  }
  /// Runs a statement that returns no rows.
  void Run() {
    while (Step()) {
    }
  }

  std::int64_t Int(int column) const { return sqlite3_column_int64(stmt_, column); }
  double Double(int column) const { return sqlite3_column_double(stmt_, column); }
  std::string Text(int column) const {
    const auto* text = reinterpret_cast<const char*>(sqlite3_column_text(stmt_, column));
    return text ? std::string(text, static_cast<std::size_t>(sqlite3_column_bytes(stmt_, column))) : std::string();
  }

 private:
  void Check(int rc) const {
    if (rc != SQLITE_OK) throw StorageError(KindOf(rc), std::string("sqlite: ") + sqlite3_errmsg(db_));
  }

  sqlite3* db_;
  sqlite3_stmt* stmt_;
};

class SqliteStorage final : public Storage {
 public:
  explicit SqliteStorage(const std::string& path) {
    try {
      Open(path);
      Migrate();
    } catch (const StorageError& e) {
      Close();
      // The interface promises kUnavailable for a database that cannot be opened, whatever the cause.
      throw StorageError(Kind::kUnavailable, "cannot open database '" + path + "': " + e.what());
    }
  }
  ~SqliteStorage() override { Close(); }

  Document Create(const std::string& collection, const std::string& id, const std::string& json) override {
    std::lock_guard lock(mutex_);
    Transaction tx(*this);
    Document doc;
    try {
      doc = InsertLocked(collection, id, json);
    } catch (const StorageError& e) {
      if (e.kind() != Kind::kAlreadyExists) throw;
      throw StorageError(Kind::kAlreadyExists, collection + "/" + id + " already exists");
    }
    tx.Commit();
    return doc;
  }

  std::optional<Document> Get(const std::string& collection, const std::string& id) override {
    std::lock_guard lock(mutex_);
    return GetLocked(collection, id);
  }

  Document Update(const std::string& collection, const std::string& id, const std::string& json,
                  std::int64_t expected_version) override {
    std::lock_guard lock(mutex_);
    Transaction tx(*this);
    std::optional<Document> doc = GetLocked(collection, id);
    if (!doc) throw StorageError(Kind::kNotFound, collection + "/" + id + " not found");
    CheckVersion(collection, id, doc->version, expected_version);
    WriteLocked(*doc, json);
    tx.Commit();
    return *doc;
  }

  Document Put(const std::string& collection, const std::string& id, const std::string& json) override {
    std::lock_guard lock(mutex_);
    Transaction tx(*this);
    std::optional<Document> doc = GetLocked(collection, id);
    Document result;
    if (doc) {
      WriteLocked(*doc, json);
      result = *doc;
    } else {
      result = InsertLocked(collection, id, json);
    }
    tx.Commit();
    return result;
  }

  bool Delete(const std::string& collection, const std::string& id) override {
    std::lock_guard lock(mutex_);
    Transaction tx(*this);
    Prepare("DELETE FROM documents WHERE collection = ?1 AND id = ?2").Bind(1, collection).Bind(2, id).Run();
    const bool deleted = sqlite3_changes(db_) > 0;
    if (deleted && collection == "campaigns") {
      // A campaign's measurements go with it, so that a campaign created later under the same id starts empty.
      Prepare("DELETE FROM measurements WHERE campaign_id = ?1").Bind(1, id).Run();
      Prepare("DELETE FROM batches WHERE campaign_id = ?1").Bind(1, id).Run();
    }
    if (deleted && collection == "operations") Prepare("DELETE FROM operation_leases WHERE id = ?1").Bind(1, id).Run();
    tx.Commit();
    return deleted;
  }

  std::vector<Document> List(const std::string& collection, const std::string& after_id, int limit) override {
    std::lock_guard lock(mutex_);
    std::vector<Document> docs;
    if (limit <= 0) return docs;
    Statement stmt = Prepare(
        "SELECT id, json, version, created_unix_ms, updated_unix_ms FROM documents "
        "WHERE collection = ?1 AND id > ?2 ORDER BY id LIMIT ?3");
    stmt.Bind(1, collection).Bind(2, after_id).Bind(3, static_cast<std::int64_t>(limit));
    while (stmt.Step()) {
      docs.push_back(Document{collection, stmt.Text(0), stmt.Text(1), stmt.Int(2), stmt.Int(3), stmt.Int(4)});
    }
    return docs;
  }

  BatchResult AppendMeasurements(const std::string& campaign_id, const std::string& request_id,
                                 const std::string& content_hash, const std::string& role,
                                 const std::vector<std::string>& measurements_json,
                                 std::int64_t max_campaign_total) override {
    std::lock_guard lock(mutex_);
    Transaction tx(*this);
    if (!GetLocked("campaigns", campaign_id)) {
      throw StorageError(Kind::kNotFound, "campaign " + campaign_id + " not found");
    }
    // Sequences are dense from 1 and single measurements are never deleted, so the largest sequence is the
    // campaign's total; reading it from the primary key avoids counting up to max_campaign_total rows.
    std::int64_t total = 0;
    {
      Statement stmt = Prepare("SELECT COALESCE(MAX(sequence), 0) FROM measurements WHERE campaign_id = ?1");
      stmt.Bind(1, campaign_id);
      if (stmt.Step()) total = stmt.Int(0);
    }

    if (!request_id.empty()) {
      Statement stmt = Prepare(
          "SELECT batch_id, content_hash, role, first_sequence, count FROM batches "
          "WHERE campaign_id = ?1 AND request_id = ?2");
      stmt.Bind(1, campaign_id).Bind(2, request_id);
      if (stmt.Step()) {
        // Nothing written: the transaction rolls back (a no-op) when tx goes out of scope.
        return ReplayBatch(campaign_id, request_id, content_hash, role,
                           {.batch_id = stmt.Text(0),
                            .content_hash = stmt.Text(1),
                            .role = stmt.Text(2),
                            .first_sequence = stmt.Int(3),
                            .count = stmt.Int(4)},
                           total);
      }
    }

    const auto count = static_cast<std::int64_t>(measurements_json.size());
    CheckCampaignTotal(campaign_id, total, count, max_campaign_total);

    const StoredBatch batch = NewBatch(content_hash, role, total, count);
    const std::string& batch_id = batch.batch_id;
    const std::int64_t first_sequence = batch.first_sequence;
    {
      Statement stmt = Prepare(
          "INSERT INTO batches (batch_id, campaign_id, request_id, content_hash, role, first_sequence, count, "
          "created_unix_ms) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)");
      stmt.Bind(1, batch_id).Bind(2, campaign_id);
      // NULL, not "", so that batches without a request id never collide on the unique key.
      if (request_id.empty()) {
        stmt.BindNull(3);
      } else {
        stmt.Bind(3, request_id);
      }
      stmt.Bind(4, content_hash).Bind(5, role).Bind(6, first_sequence).Bind(7, count).Bind(8, NowUnixMs()).Run();
    }
    for (std::int64_t i = 0; i < count; ++i) {
      Prepare("INSERT INTO measurements (campaign_id, sequence, batch_id, role, json) VALUES (?1, ?2, ?3, ?4, ?5)")
          .Bind(1, campaign_id)
          .Bind(2, first_sequence + i)
          .Bind(3, batch_id)
          .Bind(4, role)
          .Bind(5, measurements_json[static_cast<std::size_t>(i)])
          .Run();
    }
    tx.Commit();
    return AppendedBatch(campaign_id, request_id, batch, total);
  }

  std::vector<StoredMeasurement> ListMeasurements(const std::string& campaign_id, const std::string& role,
                                                  std::int64_t after_sequence, int limit) override {
    std::lock_guard lock(mutex_);
    std::vector<StoredMeasurement> out;
    if (limit <= 0) return out;
    Statement stmt = Prepare(
        "SELECT sequence, batch_id, role, json FROM measurements "
        "WHERE campaign_id = ?1 AND (?2 = '' OR role = ?2) AND sequence > ?3 ORDER BY sequence LIMIT ?4");
    stmt.Bind(1, campaign_id).Bind(2, role).Bind(3, after_sequence).Bind(4, static_cast<std::int64_t>(limit));
    while (stmt.Step()) out.push_back(StoredMeasurement{stmt.Int(0), stmt.Text(1), stmt.Text(2), stmt.Text(3)});
    return out;
  }

  std::int64_t CountMeasurements(const std::string& campaign_id, const std::string& role) override {
    std::lock_guard lock(mutex_);
    Statement stmt = Prepare("SELECT COUNT(*) FROM measurements WHERE campaign_id = ?1 AND (?2 = '' OR role = ?2)");
    stmt.Bind(1, campaign_id).Bind(2, role);
    return stmt.Step() ? stmt.Int(0) : 0;
  }

  Document CreateLeased(const std::string& id, const std::string& json, const std::string& owner,
                        std::int64_t lease_ms) override {
    std::lock_guard lock(mutex_);
    Transaction tx(*this);
    Document doc;
    try {
      doc = InsertLocked("operations", id, json);
    } catch (const StorageError& e) {
      if (e.kind() != Kind::kAlreadyExists) throw;
      throw StorageError(Kind::kAlreadyExists, "operations/" + id + " already exists");
    }
    Prepare(
        "INSERT OR REPLACE INTO operation_leases (id, owner, expires_unix_ms, cancel_requested, progress) "
        "VALUES (?1, ?2, ?3, 0, 0)")
        .Bind(1, id)
        .Bind(2, owner)
        .Bind(3, NowUnixMs() + lease_ms)
        .Run();
    tx.Commit();
    return doc;
  }

  std::optional<OperationLease> RenewLease(const std::string& id, const std::string& owner, std::int64_t lease_ms,
                                           double progress) override {
    std::lock_guard lock(mutex_);
    Transaction tx(*this);
    Prepare("UPDATE operation_leases SET expires_unix_ms = ?3, progress = ?4 WHERE id = ?1 AND owner = ?2")
        .Bind(1, id)
        .Bind(2, owner)
        .Bind(3, NowUnixMs() + lease_ms)
        .Bind(4, progress)
        .Run();
    if (sqlite3_changes(db_) == 0) return std::nullopt;
    std::optional<OperationLease> lease = LeaseLocked(id);
    tx.Commit();
    return lease;
  }

  std::optional<OperationLease> GetLease(const std::string& id) override {
    std::lock_guard lock(mutex_);
    return LeaseLocked(id);
  }

  bool RequestCancel(const std::string& id) override {
    std::lock_guard lock(mutex_);
    Transaction tx(*this);
    Prepare("UPDATE operation_leases SET cancel_requested = 1 WHERE id = ?1").Bind(1, id).Run();
    const bool found = sqlite3_changes(db_) > 0;
    tx.Commit();
    return found;
  }

  bool FinishLeased(const std::string& id, const std::string& owner, const std::string& json) override {
    std::lock_guard lock(mutex_);
    Transaction tx(*this);
    Prepare("DELETE FROM operation_leases WHERE id = ?1 AND owner = ?2").Bind(1, id).Bind(2, owner).Run();
    if (sqlite3_changes(db_) == 0) return false;  // rolled back: nothing written
    std::optional<Document> doc = GetLocked("operations", id);
    if (!doc) throw StorageError(Kind::kNotFound, "operations/" + id + " not found");
    WriteLocked(*doc, json);
    tx.Commit();
    return true;
  }

  std::vector<std::string> ExpireLeases(bool all, const std::function<std::string(const Document&)>& expire) override {
    std::lock_guard lock(mutex_);
    std::vector<std::string> ended;
    Transaction tx(*this);
    {
      Statement stmt = Prepare("SELECT id FROM operation_leases WHERE ?1 OR expires_unix_ms < ?2 ORDER BY id");
      stmt.Bind(1, static_cast<std::int64_t>(all ? 1 : 0)).Bind(2, NowUnixMs());
      while (stmt.Step()) ended.push_back(stmt.Text(0));
    }
    for (const std::string& id : ended) {
      if (std::optional<Document> doc = GetLocked("operations", id)) WriteLocked(*doc, expire(*doc));
      Prepare("DELETE FROM operation_leases WHERE id = ?1").Bind(1, id).Run();
    }
    tx.Commit();
    return ended;
  }

  bool Shared() const override { return false; }

  std::string IntegrityCheck() override {
    std::lock_guard lock(mutex_);
    Statement stmt = Prepare("PRAGMA integrity_check");
    std::string result;
    while (stmt.Step()) {
      if (!result.empty()) result += "\n";
      result += stmt.Text(0);
    }
    return result;
  }

  int SchemaVersion() override {
    std::lock_guard lock(mutex_);
    return UserVersion();
  }

 private:
  /// BEGIN IMMEDIATE takes the write lock up front, so a read-then-write transaction cannot fail half-way
  /// with SQLITE_BUSY when another process (e.g. a backup) also writes. Rolls back unless committed.
  class Transaction {
   public:
    explicit Transaction(SqliteStorage& storage) : storage_(storage) { storage_.Exec("BEGIN IMMEDIATE"); }
    Transaction(const Transaction&) = delete;
    Transaction& operator=(const Transaction&) = delete;
    ~Transaction() {
      if (!committed_) sqlite3_exec(storage_.db_, "ROLLBACK", nullptr, nullptr, nullptr);
    }
    void Commit() {
      storage_.Exec("COMMIT");
      committed_ = true;
    }

   private:
    SqliteStorage& storage_;
    bool committed_ = false;
  };

  void Open(const std::string& path) {
    if (path != ":memory:" && !path.empty()) {
      const std::filesystem::path parent = std::filesystem::path(path).parent_path();
      std::error_code ec;
      if (!parent.empty()) std::filesystem::create_directories(parent, ec);
      if (ec)
        throw StorageError(Kind::kUnavailable, "cannot create directory '" + parent.string() + "': " + ec.message());
    }
    // NOMUTEX: mutex_ already serialises every use of the connection.
    const int rc =
        sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX, nullptr);
    if (rc != SQLITE_OK) {
      const std::string message = db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
      throw StorageError(KindOf(rc), message);
    }
    sqlite3_extended_result_codes(db_, 1);
    sqlite3_busy_timeout(db_, kBusyTimeoutMs);
    // Reading the header here turns "file is not a database" into an error at open rather than later.
    UserVersion();
    if (path != ":memory:") {
      // WAL: a commit appends to the log and fsyncs it (synchronous=FULL), which survives a killed process and
      // a power loss; readers (e.g. sqlite3 .backup) do not block the writer.
      Statement stmt = Prepare("PRAGMA journal_mode=WAL");
      if (!stmt.Step() || stmt.Text(0) != "wal") {
        throw StorageError(Kind::kUnavailable, "cannot switch the database to WAL mode");
      }
    }
    Exec("PRAGMA synchronous=FULL");
    Exec("PRAGMA foreign_keys=ON");
  }

  void Close() {
    for (auto& [sql, stmt] : statements_) sqlite3_finalize(stmt);
    statements_.clear();
    if (db_) sqlite3_close_v2(db_);
    db_ = nullptr;
  }

  void Migrate() {
    int version = UserVersion();
    if (version > kSqliteSchemaVersion) {
      throw StorageError(Kind::kUnavailable, "database schema version " + std::to_string(version) +
                                                 " is newer than this build supports (" +
                                                 std::to_string(kSqliteSchemaVersion) +
                                                 "); run a newer robocal-server or restore a backup");
    }
    while (version < kSqliteSchemaVersion) {
      Transaction tx(*this);
      // Another process may have migrated between our read and the write lock.
      version = UserVersion();
      if (version >= kSqliteSchemaVersion) break;
      MigrateStep(version);
      Exec("PRAGMA user_version=" + std::to_string(version + 1));
      tx.Commit();
      ++version;
    }
  }

  /// Brings the schema from `from` to `from + 1`; runs inside a transaction. Add a case per new version;
  /// never change a released step.
  void MigrateStep(int from) {
    switch (from) {
      case 0:
        Exec(R"sql(
          CREATE TABLE documents (
            collection TEXT NOT NULL,
            id TEXT NOT NULL,
            json TEXT NOT NULL,
            version INTEGER NOT NULL,
            created_unix_ms INTEGER NOT NULL,
            updated_unix_ms INTEGER NOT NULL,
            PRIMARY KEY (collection, id)
          ) WITHOUT ROWID;
          CREATE TABLE batches (
            batch_id TEXT PRIMARY KEY,
            campaign_id TEXT NOT NULL,
            request_id TEXT,
            content_hash TEXT NOT NULL,
            role TEXT NOT NULL,
            first_sequence INTEGER NOT NULL,
            count INTEGER NOT NULL,
            created_unix_ms INTEGER NOT NULL,
            UNIQUE (campaign_id, request_id)
          );
          CREATE TABLE measurements (
            campaign_id TEXT NOT NULL,
            sequence INTEGER NOT NULL,
            batch_id TEXT NOT NULL REFERENCES batches (batch_id),
            role TEXT NOT NULL,
            json TEXT NOT NULL,
            PRIMARY KEY (campaign_id, sequence)
          ) WITHOUT ROWID;
          CREATE INDEX measurements_by_role ON measurements (campaign_id, role, sequence);
          CREATE INDEX measurements_by_batch ON measurements (batch_id);
        )sql");
        return;
      case 1:
        // Leases on running operations (Storage::CreateLeased and the calls after it).
        Exec(R"sql(
          CREATE TABLE operation_leases (
            id TEXT PRIMARY KEY,
            owner TEXT NOT NULL,
            expires_unix_ms INTEGER NOT NULL,
            cancel_requested INTEGER NOT NULL DEFAULT 0,
            progress REAL NOT NULL DEFAULT 0
          ) WITHOUT ROWID;
        )sql");
        return;
      default:
        throw StorageError(Kind::kInternal, "no migration from schema version " + std::to_string(from));
    }
  }

  std::optional<OperationLease> LeaseLocked(const std::string& id) {
    Statement stmt =
        Prepare("SELECT owner, progress, cancel_requested, expires_unix_ms - ?2 FROM operation_leases WHERE id = ?1");
    stmt.Bind(1, id).Bind(2, NowUnixMs());
    if (!stmt.Step()) return std::nullopt;
    return OperationLease{stmt.Text(0), stmt.Double(1), stmt.Int(2) != 0, stmt.Int(3)};
  }

  int UserVersion() {
    Statement stmt = Prepare("PRAGMA user_version");
    return stmt.Step() ? static_cast<int>(stmt.Int(0)) : 0;
  }

  void Exec(const std::string& sql) {
    char* error = nullptr;
    const int rc = sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error);
    if (rc != SQLITE_OK) {
      const std::string message = error ? error : sqlite3_errstr(rc);
      sqlite3_free(error);
      throw StorageError(KindOf(rc), "sqlite: " + message);
    }
  }

  /// Prepared once per SQL text and kept for the connection's life.
  Statement Prepare(const std::string& sql) {
    auto it = statements_.find(sql);
    if (it == statements_.end()) {
      sqlite3_stmt* stmt = nullptr;
      const int rc =
          sqlite3_prepare_v3(db_, sql.c_str(), static_cast<int>(sql.size()), SQLITE_PREPARE_PERSISTENT, &stmt, nullptr);
      if (rc != SQLITE_OK) throw StorageError(KindOf(rc), std::string("sqlite: ") + sqlite3_errmsg(db_));
      it = statements_.emplace(sql, stmt).first;
    }
    return Statement(db_, it->second);
  }

  // The one INSERT of a new document (version 1), shared by Create and Put; caller holds the lock and a
  // transaction.
  Document InsertLocked(const std::string& collection, const std::string& id, const std::string& json) {
    const std::int64_t now = NowUnixMs();
    Prepare(
        "INSERT INTO documents (collection, id, json, version, created_unix_ms, updated_unix_ms) "
        "VALUES (?1, ?2, ?3, 1, ?4, ?4)")
        .Bind(1, collection)
        .Bind(2, id)
        .Bind(3, json)
        .Bind(4, now)
        .Run();
    return Document{collection, id, json, 1, now, now};
  }

  std::optional<Document> GetLocked(const std::string& collection, const std::string& id) {
    Statement stmt = Prepare(
        "SELECT json, version, created_unix_ms, updated_unix_ms FROM documents WHERE collection = ?1 AND id = ?2");
    stmt.Bind(1, collection).Bind(2, id);
    if (!stmt.Step()) return std::nullopt;
    return Document{collection, id, stmt.Text(0), stmt.Int(1), stmt.Int(2), stmt.Int(3)};
  }

  /// Replaces doc's json in the database and updates `doc` to the stored state.
  void WriteLocked(Document& doc, const std::string& json) {
    const std::int64_t now = NowUnixMs();
    Prepare(
        "UPDATE documents SET json = ?3, version = version + 1, updated_unix_ms = ?4 "
        "WHERE collection = ?1 AND id = ?2")
        .Bind(1, doc.collection)
        .Bind(2, doc.id)
        .Bind(3, json)
        .Bind(4, now)
        .Run();
    doc.json = json;
    doc.version += 1;
    doc.updated_unix_ms = now;
  }

  // One connection behind one mutex: SQLite admits a single writer at a time anyway, every call is short
  // (milliseconds), and a connection must not interleave two threads' transactions. A reader pool would only
  // pay off under read loads far beyond a calibration cell's.
  std::mutex mutex_;
  sqlite3* db_ = nullptr;
  std::unordered_map<std::string, sqlite3_stmt*> statements_;
};

}  // namespace

std::unique_ptr<Storage> OpenSqliteStorage(const std::string& path) { return std::make_unique<SqliteStorage>(path); }

}  // namespace robocal::server
