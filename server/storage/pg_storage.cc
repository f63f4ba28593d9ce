// The PostgreSQL implementation of Storage, for several server instances on one database: a pool of
// connections, every write one transaction (a returned call is committed), the schema created and migrated at
// start under an advisory lock and versioned in robocal_schema, operation leases timed by the database's clock.
// docs/storage.md has the schema; docs/scaling.md how instances share it.
#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "server/storage/pg_connection.h"
#include "server/storage/storage.h"
#include "server/storage/storage_common.h"

namespace robocal::server {
namespace {

using Kind = StorageError::Kind;
using pg::Int;
using pg::Param;

/// A double in text form that reads back as the same double.
Param Double(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", value);
  return std::string(text);
}

/// The schema version this build writes; Migrate() brings older databases up to it step by step.
constexpr int kPostgresSchemaVersion = 1;

/// The advisory lock that serialises schema migration between instances starting together ("robocal" in
/// ASCII, as a number).
constexpr const char* kMigrationLock = "32210615911276908";

/// Milliseconds since the Unix epoch by the database's clock, so that instances on hosts whose clocks differ
/// still stamp documents in one order.
constexpr const char* kNowMs = "(extract(epoch from clock_timestamp()) * 1000)::bigint";

class PgStorage final : public Storage {
 public:
  PgStorage(const std::string& url, const StorageOptions& options)
      : pool_(url, options.pool_size, std::chrono::milliseconds(options.pool_wait_ms)),
        lease_pool_(url, 1, std::chrono::milliseconds(options.pool_wait_ms)) {
    pool_.Run([&](pg::Connection& c) { Migrate(c); });
  }

  Document Create(const std::string& collection, const std::string& id, const std::string& json) override {
    return pool_.Run([&](pg::Connection& c) -> Document {
      try {
        // In a transaction, so that the statement repeated on a re-established connection (Pool::Run) is
        // never one that may have committed.
        pg::Transaction tx(c);
        Document doc = InsertDocument(c, collection, id, json);
        tx.Commit();
        return doc;
      } catch (const StorageError& e) {
        if (e.kind() != Kind::kAlreadyExists) throw;
        throw StorageError(Kind::kAlreadyExists, collection + "/" + id + " already exists");
      }
    });
  }

  std::optional<Document> Get(const std::string& collection, const std::string& id) override {
    return pool_.Run([&](pg::Connection& c) -> std::optional<Document> {
      return GetDocument(c, collection, id, false);
    });
  }

  Document Update(const std::string& collection, const std::string& id, const std::string& json,
                  std::int64_t expected_version) override {
    return pool_.Run([&](pg::Connection& c) -> Document {
      pg::Transaction tx(c);
      std::optional<Document> doc = GetDocument(c, collection, id, true);
      if (!doc) throw StorageError(Kind::kNotFound, collection + "/" + id + " not found");
      CheckVersion(collection, id, doc->version, expected_version);
      WriteDocument(c, *doc, json);
      tx.Commit();
      return *doc;
    });
  }

  Document Put(const std::string& collection, const std::string& id, const std::string& json) override {
    return pool_.Run([&](pg::Connection& c) -> Document {
      const pg::Result r = c.Run(
          std::string("INSERT INTO documents (collection, id, json, version, created_unix_ms, updated_unix_ms) "
                      "VALUES ($1::text, $2::text, $3::text, 1, ") +
              kNowMs + ", " + kNowMs +
              ") ON CONFLICT (collection, id) DO UPDATE SET json = excluded.json, "
              "version = documents.version + 1, updated_unix_ms = excluded.updated_unix_ms "
              "RETURNING version, created_unix_ms, updated_unix_ms",
          {collection, id, json});
      return Document{collection, id, json, r.Int(0, 0), r.Int(0, 1), r.Int(0, 2)};
    });
  }

  bool Delete(const std::string& collection, const std::string& id) override {
    return pool_.Run([&](pg::Connection& c) -> bool {
      pg::Transaction tx(c);
      const bool deleted =
          c.Run("DELETE FROM documents WHERE collection = $1::text AND id = $2::text RETURNING 1", {collection, id})
              .rows() > 0;
      if (deleted && collection == "campaigns") {
        // A campaign's measurements go with it, so that a campaign created later under the same id starts empty.
        c.Run("DELETE FROM measurements WHERE campaign_id = $1::text", {id});
        c.Run("DELETE FROM batches WHERE campaign_id = $1::text", {id});
      }
      if (deleted && collection == "operations") c.Run("DELETE FROM operation_leases WHERE id = $1::text", {id});
      tx.Commit();
      return deleted;
    });
  }

  std::vector<Document> List(const std::string& collection, const std::string& after_id, int limit) override {
    std::vector<Document> docs;
    if (limit <= 0) return docs;
    return pool_.Run([&](pg::Connection& c) -> std::vector<Document> {
      const pg::Result r = c.Run(
          "SELECT id, json, version, created_unix_ms, updated_unix_ms FROM documents "
          "WHERE collection = $1::text AND id > $2::text ORDER BY id LIMIT $3::bigint",
          {collection, after_id, Int(limit)});
      for (int i = 0; i < r.rows(); ++i) {
        docs.push_back(Document{collection, r.Text(i, 0), r.Text(i, 1), r.Int(i, 2), r.Int(i, 3), r.Int(i, 4)});
      }
      return docs;
    });
  }

  BatchResult AppendMeasurements(const std::string& campaign_id, const std::string& request_id,
                                 const std::string& content_hash, const std::string& role,
                                 const std::vector<std::string>& measurements_json,
                                 std::int64_t max_campaign_total) override {
    return pool_.Run([&](pg::Connection& c) -> BatchResult {
      pg::Transaction tx(c);
      // The campaign's row lock serialises appends to one campaign across instances: sequences stay dense, and
      // a batch retried through another instance finds the first one's row (the unique key on (campaign_id,
      // request_id) stands behind it).
      if (c.Run("SELECT 1 FROM documents WHERE collection = 'campaigns' AND id = $1::text FOR UPDATE", {campaign_id})
              .rows() == 0) {
        throw StorageError(Kind::kNotFound, "campaign " + campaign_id + " not found");
      }
      // Sequences are dense from 1 and single measurements are never deleted: the largest is the total.
      const std::int64_t total =
          c.Run("SELECT COALESCE(MAX(sequence), 0) FROM measurements WHERE campaign_id = $1::text", {campaign_id})
              .Int(0, 0);
      if (!request_id.empty()) {
        const pg::Result r = c.Run(
            "SELECT batch_id, content_hash, role, first_sequence, count FROM batches "
            "WHERE campaign_id = $1::text AND request_id = $2::text",
            {campaign_id, request_id});
        if (r.rows() > 0) {
          return ReplayBatch(campaign_id, request_id, content_hash, role,
                             {.batch_id = r.Text(0, 0),
                              .content_hash = r.Text(0, 1),
                              .role = r.Text(0, 2),
                              .first_sequence = r.Int(0, 3),
                              .count = r.Int(0, 4)},
                             total);
        }
      }
      const auto count = static_cast<std::int64_t>(measurements_json.size());
      CheckCampaignTotal(campaign_id, total, count, max_campaign_total);
      const StoredBatch batch = NewBatch(content_hash, role, total, count);
      const std::string& batch_id = batch.batch_id;
      const std::int64_t first_sequence = batch.first_sequence;
      // NULL, not "", so that batches without a request id never collide on the unique key.
      const Param request = request_id.empty() ? Param() : Param(request_id);
      c.Run(std::string("INSERT INTO batches (batch_id, campaign_id, request_id, content_hash, role, "
                        "first_sequence, count, created_unix_ms) VALUES ($1::text, $2::text, $3::text, $4::text, "
                        "$5::text, $6::bigint, $7::bigint, ") +
                 kNowMs + ")",
             {batch_id, campaign_id, request, content_hash, role, Int(first_sequence), Int(count)});
      if (count > 0) {
        c.Run(
            "INSERT INTO measurements (campaign_id, sequence, batch_id, role, json) "
            "SELECT $1::text, $2::bigint + t.ordinal - 1, $3::text, $4::text, t.json "
            "FROM unnest($5::text[]) WITH ORDINALITY AS t(json, ordinal)",
            {campaign_id, Int(first_sequence), batch_id, role, pg::TextArray(measurements_json)});
      }
      tx.Commit();
      return AppendedBatch(campaign_id, request_id, batch, total);
    });
  }

  std::vector<StoredMeasurement> ListMeasurements(const std::string& campaign_id, const std::string& role,
                                                  std::int64_t after_sequence, int limit) override {
    std::vector<StoredMeasurement> out;
    if (limit <= 0) return out;
    return pool_.Run([&](pg::Connection& c) -> std::vector<StoredMeasurement> {
      const pg::Result r = c.Run(
          "SELECT sequence, batch_id, role, json FROM measurements WHERE campaign_id = $1::text "
          "AND ($2::text = '' OR role = $2::text) AND sequence > $3::bigint ORDER BY sequence LIMIT $4::bigint",
          {campaign_id, role, Int(after_sequence), Int(limit)});
      out.reserve(static_cast<std::size_t>(r.rows()));
      for (int i = 0; i < r.rows(); ++i) {
        out.push_back(StoredMeasurement{r.Int(i, 0), r.Text(i, 1), r.Text(i, 2), r.Text(i, 3)});
      }
      return out;
    });
  }

  std::int64_t CountMeasurements(const std::string& campaign_id, const std::string& role) override {
    return pool_.Run([&](pg::Connection& c) -> std::int64_t {
      return c
          .Run("SELECT COUNT(*) FROM measurements WHERE campaign_id = $1::text AND ($2::text = '' OR role = $2::text)",
               {campaign_id, role})
          .Int(0, 0);
    });
  }

  Document CreateLeased(const std::string& id, const std::string& json, const std::string& owner,
                        std::int64_t lease_ms) override {
    return pool_.Run([&](pg::Connection& c) -> Document {
      pg::Transaction tx(c);
      Document doc;
      try {
        doc = InsertDocument(c, "operations", id, json);
      } catch (const StorageError& e) {
        if (e.kind() != Kind::kAlreadyExists) throw;
        throw StorageError(Kind::kAlreadyExists, "operations/" + id + " already exists");
      }
      c.Run(
          "INSERT INTO operation_leases (id, owner, expires_at) VALUES ($1::text, $2::text, "
          "clock_timestamp() + $3::bigint * interval '1 millisecond') ON CONFLICT (id) DO UPDATE SET "
          "owner = excluded.owner, expires_at = excluded.expires_at, cancel_requested = false, progress = 0",
          {id, owner, Int(lease_ms)});
      tx.Commit();
      return doc;
    });
  }

  std::optional<OperationLease> RenewLease(const std::string& id, const std::string& owner, std::int64_t lease_ms,
                                           double progress) override {
    // Renewals and expiry run on a connection of their own, so that requests holding every pooled connection
    // cannot delay a renewal until the lease lapses.
    return lease_pool_.Run([&](pg::Connection& c) -> std::optional<OperationLease> {
      const pg::Result r = c.Run(
          "UPDATE operation_leases SET expires_at = clock_timestamp() + $3::bigint * interval '1 millisecond', "
          "progress = $4::double precision WHERE id = $1::text AND owner = $2::text RETURNING " +
              std::string(kLeaseColumns),
          {id, owner, Int(lease_ms), Double(progress)});
      if (r.rows() == 0) return std::nullopt;
      return LeaseOf(r);
    });
  }

  std::optional<OperationLease> GetLease(const std::string& id) override {
    return pool_.Run([&](pg::Connection& c) -> std::optional<OperationLease> {
      const pg::Result r =
          c.Run("SELECT " + std::string(kLeaseColumns) + " FROM operation_leases WHERE id = $1::text", {id});
      if (r.rows() == 0) return std::nullopt;
      return LeaseOf(r);
    });
  }

  bool RequestCancel(const std::string& id) override {
    return pool_.Run([&](pg::Connection& c) -> bool {
      return c.Run("UPDATE operation_leases SET cancel_requested = true WHERE id = $1::text RETURNING 1", {id}).rows() >
             0;
    });
  }

  bool FinishLeased(const std::string& id, const std::string& owner, const std::string& json) override {
    return pool_.Run([&](pg::Connection& c) -> bool {
      pg::Transaction tx(c);
      if (c.Run("DELETE FROM operation_leases WHERE id = $1::text AND owner = $2::text RETURNING 1", {id, owner})
              .rows() == 0) {
        return false;  // rolled back: nothing written
      }
      std::optional<Document> doc = GetDocument(c, "operations", id, true);
      if (!doc) throw StorageError(Kind::kNotFound, "operations/" + id + " not found");
      WriteDocument(c, *doc, json);
      tx.Commit();
      return true;
    });
  }

  std::vector<std::string> ExpireLeases(bool all,
                                        const std::function<std::string(const Document&)>& expire) override {
    std::vector<std::string> ended;
    return lease_pool_.Run([&](pg::Connection& c) -> std::vector<std::string> {
      for (;;) {
        pg::Transaction tx(c);
        // SKIP LOCKED: a lease another instance is ending (or its owner renewing) is left to it.
        const pg::Result r = c.Run(
            "SELECT id FROM operation_leases WHERE $1::boolean OR expires_at < clock_timestamp() "
            "ORDER BY expires_at LIMIT 1 FOR UPDATE SKIP LOCKED",
            {all ? "true" : "false"});
        if (r.rows() == 0) break;
        const std::string id = r.Text(0, 0);
        if (std::optional<Document> doc = GetDocument(c, "operations", id, true)) WriteDocument(c, *doc, expire(*doc));
        c.Run("DELETE FROM operation_leases WHERE id = $1::text", {id});
        tx.Commit();
        ended.push_back(id);
      }
      return ended;
    });
  }

  bool Shared() const override { return true; }

  std::string IntegrityCheck() override {
    return pool_.Run([&](pg::Connection& c) -> std::string {
      std::string problems;
      const auto check = [&](const std::string& what, const std::string& sql) {
        const pg::Result r = c.Run(sql);
        for (int i = 0; i < r.rows(); ++i) problems += (problems.empty() ? "" : "\n") + what + " " + r.Text(i, 0);
      };
      check("campaign with missing sequences:",
            "SELECT campaign_id FROM measurements GROUP BY campaign_id HAVING COUNT(*) <> MAX(sequence) LIMIT 20");
      check("batch whose count differs from its measurements:",
            "SELECT b.batch_id FROM batches b LEFT JOIN measurements m ON m.batch_id = b.batch_id "
            "GROUP BY b.batch_id, b.count HAVING COUNT(m.sequence) <> b.count LIMIT 20");
      check("measurements of a campaign that does not exist:",
            "SELECT DISTINCT m.campaign_id FROM measurements m WHERE NOT EXISTS (SELECT 1 FROM documents d "
            "WHERE d.collection = 'campaigns' AND d.id = m.campaign_id) LIMIT 20");
      return problems.empty() ? "ok" : problems;
    });
  }

  int SchemaVersion() override {
    return pool_.Run([&](pg::Connection& c) -> int {
      return static_cast<int>(c.Run("SELECT version FROM robocal_schema").Int(0, 0));
    });
  }

 private:
  static constexpr const char* kLeaseColumns =
      "owner, progress, cancel_requested, "
      "(extract(epoch from expires_at - clock_timestamp()) * 1000)::bigint";

  static OperationLease LeaseOf(const pg::Result& r) {
    return OperationLease{r.Text(0, 0), r.Double(0, 1), r.Bool(0, 2), r.Int(0, 3)};
  }

  static Document InsertDocument(pg::Connection& c, const std::string& collection, const std::string& id,
                                 const std::string& json) {
    const pg::Result r = c.Run(std::string("INSERT INTO documents (collection, id, json, version, created_unix_ms, "
                                           "updated_unix_ms) VALUES ($1::text, $2::text, $3::text, 1, ") +
                                   kNowMs + ", " + kNowMs + ") RETURNING created_unix_ms",
                               {collection, id, json});
    return Document{collection, id, json, 1, r.Int(0, 0), r.Int(0, 0)};
  }

  static std::optional<Document> GetDocument(pg::Connection& c, const std::string& collection, const std::string& id,
                                             bool for_update) {
    const pg::Result r = c.Run(std::string("SELECT json, version, created_unix_ms, updated_unix_ms FROM documents "
                                           "WHERE collection = $1::text AND id = $2::text") +
                                   (for_update ? " FOR UPDATE" : ""),
                               {collection, id});
    if (r.rows() == 0) return std::nullopt;
    return Document{collection, id, r.Text(0, 0), r.Int(0, 1), r.Int(0, 2), r.Int(0, 3)};
  }

  /// Replaces doc's json (its row locked by the caller's transaction) and updates `doc` to the stored state.
  static void WriteDocument(pg::Connection& c, Document& doc, const std::string& json) {
    const pg::Result r = c.Run(std::string("UPDATE documents SET json = $3::text, version = version + 1, "
                                           "updated_unix_ms = ") +
                                   kNowMs + " WHERE collection = $1::text AND id = $2::text RETURNING version, "
                                            "updated_unix_ms",
                               {doc.collection, doc.id, json});
    doc.json = json;
    doc.version = r.Int(0, 0);
    doc.updated_unix_ms = r.Int(0, 1);
  }

  void Migrate(pg::Connection& c) {
    pg::Transaction tx(c);
    // Instances starting together queue here; the first creates or migrates, the others find it done.
    c.Exec(std::string("SELECT pg_advisory_xact_lock(") + kMigrationLock + ")");
    c.Exec("CREATE TABLE IF NOT EXISTS robocal_schema (version integer NOT NULL)");
    pg::Result r = c.Run("SELECT version FROM robocal_schema");
    int version = 0;
    if (r.rows() == 0) {
      c.Exec("INSERT INTO robocal_schema (version) VALUES (0)");
    } else {
      version = static_cast<int>(r.Int(0, 0));
    }
    if (version > kPostgresSchemaVersion) {
      throw StorageError(Kind::kUnavailable,
                         "database schema version " + std::to_string(version) + " is newer than this build supports (" +
                             std::to_string(kPostgresSchemaVersion) + "); run a newer robocal-server");
    }
    if (version == kPostgresSchemaVersion) return;  // nothing to do: the transaction rolls back
    for (; version < kPostgresSchemaVersion; ++version) MigrateStep(c, version);
    c.Run("UPDATE robocal_schema SET version = $1::integer", {Int(kPostgresSchemaVersion)});
    tx.Commit();
  }

  /// Brings the schema from `from` to `from + 1`, inside Migrate's transaction. Add a case per new version;
  /// never change a released step. Ids sort byte-wise (COLLATE "C"), as in SQLite, so pages are the same on
  /// every backend and every instance.
  static void MigrateStep(pg::Connection& c, int from) {
    switch (from) {
      case 0:
        c.Exec(R"sql(
          CREATE TABLE documents (
            collection text COLLATE "C" NOT NULL,
            id text COLLATE "C" NOT NULL,
            json text NOT NULL,
            version bigint NOT NULL,
            created_unix_ms bigint NOT NULL,
            updated_unix_ms bigint NOT NULL,
            PRIMARY KEY (collection, id)
          );
          CREATE TABLE batches (
            batch_id text PRIMARY KEY,
            campaign_id text COLLATE "C" NOT NULL,
            request_id text,
            content_hash text NOT NULL,
            role text NOT NULL,
            first_sequence bigint NOT NULL,
            count bigint NOT NULL,
            created_unix_ms bigint NOT NULL,
            UNIQUE (campaign_id, request_id)
          );
          CREATE TABLE measurements (
            campaign_id text COLLATE "C" NOT NULL,
            sequence bigint NOT NULL,
            batch_id text NOT NULL REFERENCES batches (batch_id),
            role text NOT NULL,
            json text NOT NULL,
            PRIMARY KEY (campaign_id, sequence)
          );
          CREATE INDEX measurements_by_role ON measurements (campaign_id, role, sequence);
          CREATE INDEX measurements_by_batch ON measurements (batch_id);
          CREATE TABLE operation_leases (
            id text COLLATE "C" PRIMARY KEY,
            owner text NOT NULL,
            expires_at timestamptz NOT NULL,
            cancel_requested boolean NOT NULL DEFAULT false,
            progress double precision NOT NULL DEFAULT 0
          );
          CREATE INDEX operation_leases_by_expiry ON operation_leases (expires_at);
        )sql");
        return;
      default:
        throw StorageError(Kind::kInternal, "no migration from schema version " + std::to_string(from));
    }
  }

  pg::Pool pool_;
  pg::Pool lease_pool_;
};

}  // namespace

std::unique_ptr<Storage> OpenPostgresStorage(const std::string& url, const StorageOptions& options) {
  try {
    return std::make_unique<PgStorage>(url, options);
  } catch (const StorageError& e) {
    // The interface promises kUnavailable for a database that cannot be opened, whatever the cause.
    if (e.kind() == Kind::kUnavailable) throw;
    throw StorageError(Kind::kUnavailable, std::string("cannot open the database: ") + e.what());
  }
}

}  // namespace robocal::server
