// One contract suite for every Storage implementation (SQLite in memory, SQLite in a file, PostgreSQL, and the
// in-memory fake the service tests use): documents, versions, measurement batches (atomicity, idempotency,
// limits, roles), operation leases. Then what only a file database has: concurrency, reopening, schema
// versions, the integrity check. pg_storage_test.cc has what only a shared database has.
#include "server/storage/storage.h"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "fake_storage.h"
#include "pg_test_database.h"
#include "temp_dir.h"

namespace robocal::server {
namespace {

using Kind = StorageError::Kind;

std::vector<std::string> Batch(int count, const std::string& tag = "m") {
  std::vector<std::string> batch;
  for (int i = 0; i < count; ++i) batch.push_back(R"({")" + tag + R"(":)" + std::to_string(i) + "}");
  return batch;
}

/// Runs `f` and returns the kind of the StorageError it throws; fails the test if it throws none.
template <typename F>
std::optional<Kind> ErrorKind(F&& f) {
  try {
    f();
  } catch (const StorageError& e) {
    return e.kind();
  }
  ADD_FAILURE() << "no StorageError thrown";
  return std::nullopt;
}

enum class Implementation { kSqliteMemory, kSqliteFile, kPostgres, kFake };

class StorageTest : public ::testing::TestWithParam<Implementation> {
 protected:
  StorageTest() {
    switch (GetParam()) {
      case Implementation::kSqliteMemory:
        storage_ = OpenSqliteStorage(":memory:");
        break;
      case Implementation::kSqliteFile:
        storage_ = OpenSqliteStorage(dir_.File("contract.db"));
        break;
      case Implementation::kPostgres:
        database_ = std::make_unique<testing::PgTestDatabase>();
        storage_ = OpenPostgresStorage(database_->Url(), StorageOptions{.pool_size = 2});
        break;
      case Implementation::kFake:
        storage_ = std::make_unique<testing::FakeStorage>();
        break;
    }
  }
  testing::TempDir dir_;
  std::unique_ptr<testing::PgTestDatabase> database_;
  std::unique_ptr<Storage> storage_;
};

TEST_P(StorageTest, CreateGetUpdatePutDelete) {
  const Document created = storage_->Create("robots", "ur5", R"({"a":1})");
  EXPECT_EQ(created.version, 1);
  EXPECT_GT(created.created_unix_ms, 0);
  EXPECT_EQ(created.created_unix_ms, created.updated_unix_ms);

  const auto got = storage_->Get("robots", "ur5");
  ASSERT_TRUE(got.has_value());
  EXPECT_EQ(got->json, R"({"a":1})");
  EXPECT_EQ(got->collection, "robots");
  EXPECT_EQ(got->version, 1);
  EXPECT_FALSE(storage_->Get("plans", "ur5").has_value());

  const Document updated = storage_->Update("robots", "ur5", R"({"a":2})");
  EXPECT_EQ(updated.version, 2);
  EXPECT_EQ(updated.created_unix_ms, created.created_unix_ms);
  EXPECT_EQ(storage_->Get("robots", "ur5")->json, R"({"a":2})");

  EXPECT_EQ(storage_->Put("robots", "ur5", R"({"a":3})").version, 3);
  EXPECT_EQ(storage_->Put("robots", "kr6", R"({"b":1})").version, 1);
  EXPECT_EQ(storage_->Get("robots", "kr6")->json, R"({"b":1})");

  EXPECT_TRUE(storage_->Delete("robots", "ur5"));
  EXPECT_FALSE(storage_->Delete("robots", "ur5"));
  EXPECT_FALSE(storage_->Get("robots", "ur5").has_value());
}

TEST_P(StorageTest, CreateTwiceIsAlreadyExistsAndKeepsTheFirst) {
  storage_->Create("plans", "p1", "{}");
  EXPECT_EQ(ErrorKind([&] { storage_->Create("plans", "p1", R"({"x":1})"); }), Kind::kAlreadyExists);
  EXPECT_EQ(storage_->Get("plans", "p1")->json, "{}");
  // The same id in another collection is another document.
  EXPECT_NO_THROW(storage_->Create("robots", "p1", "{}"));
}

TEST_P(StorageTest, UpdateChecksVersionAndExistence) {
  EXPECT_EQ(ErrorKind([&] { storage_->Update("robots", "none", "{}"); }), Kind::kNotFound);
  storage_->Create("robots", "r", "{}");
  storage_->Update("robots", "r", R"({"v":2})", 1);
  EXPECT_EQ(ErrorKind([&] { storage_->Update("robots", "r", R"({"v":3})", 1); }), Kind::kVersionConflict);
  EXPECT_EQ(storage_->Get("robots", "r")->json, R"({"v":2})");
  EXPECT_EQ(storage_->Update("robots", "r", R"({"v":3})", 2).version, 3);
}

TEST_P(StorageTest, ListPagesInIdOrderWithinACollection) {
  for (const char* id : {"d", "a", "c", "e", "b"})
    storage_->Create("robots", id, std::string(R"({"id":")") + id + "\"}");
  storage_->Create("plans", "a0", "{}");

  std::vector<std::string> ids;
  std::string after;
  for (;;) {
    const auto page = storage_->List("robots", after, 2);
    if (page.empty()) break;
    EXPECT_LE(page.size(), 2u);
    for (const Document& d : page) {
      EXPECT_EQ(d.collection, "robots");
      ids.push_back(d.id);
    }
    after = page.back().id;
  }
  EXPECT_EQ(ids, (std::vector<std::string>{"a", "b", "c", "d", "e"}));
  EXPECT_EQ(storage_->List("robots").size(), 5u);
  EXPECT_EQ(storage_->List("robots", "", 0).size(), 0u);
  EXPECT_EQ(storage_->List("nothing").size(), 0u);
}

TEST_P(StorageTest, AppendNeedsTheCampaign) {
  EXPECT_EQ(ErrorKind([&] { storage_->AppendMeasurements("c", "r1", "h1", "calibration", Batch(3)); }),
            Kind::kNotFound);
  EXPECT_EQ(storage_->CountMeasurements("c"), 0);
}

TEST_P(StorageTest, AppendAssignsSequencesAndCountsTotals) {
  storage_->Create("campaigns", "c", "{}");
  const BatchResult a = storage_->AppendMeasurements("c", "r1", "h1", "calibration", Batch(3));
  EXPECT_FALSE(a.replayed);
  EXPECT_EQ(a.campaign, "c");
  EXPECT_EQ(a.request_id, "r1");
  EXPECT_EQ(a.first_sequence, 1);
  EXPECT_EQ(a.count, 3);
  EXPECT_EQ(a.campaign_total, 3);
  EXPECT_EQ(a.batch_id.size(), 18u);
  EXPECT_EQ(a.batch_id.rfind("b-", 0), 0u);

  const BatchResult b = storage_->AppendMeasurements("c", "r2", "h2", "validation", Batch(2, "v"));
  EXPECT_EQ(b.first_sequence, 4);
  EXPECT_EQ(b.campaign_total, 5);
  EXPECT_NE(a.batch_id, b.batch_id);

  const auto all = storage_->ListMeasurements("c");
  ASSERT_EQ(all.size(), 5u);
  EXPECT_EQ(all[0].json, R"({"m":0})");
  EXPECT_EQ(all[0].batch_id, a.batch_id);
  EXPECT_EQ(all[4].json, R"({"v":1})");
  EXPECT_EQ(all[4].role, "validation");
  EXPECT_EQ(all[4].batch_id, b.batch_id);
}

TEST_P(StorageTest, ReplaySameContentWritesNothing) {
  storage_->Create("campaigns", "c", "{}");
  const BatchResult first = storage_->AppendMeasurements("c", "r1", "h1", "calibration", Batch(3));
  storage_->AppendMeasurements("c", "r2", "h2", "calibration", Batch(2));
  const BatchResult again = storage_->AppendMeasurements("c", "r1", "h1", "calibration", Batch(3));
  EXPECT_TRUE(again.replayed);
  EXPECT_EQ(again.campaign, "c");
  EXPECT_EQ(again.batch_id, first.batch_id);
  EXPECT_EQ(again.first_sequence, 1);
  EXPECT_EQ(again.count, 3);
  EXPECT_EQ(again.campaign_total, 5);
  EXPECT_EQ(storage_->CountMeasurements("c"), 5);
}

TEST_P(StorageTest, SameRequestIdWithOtherContentIsAConflict) {
  storage_->Create("campaigns", "c", "{}");
  storage_->AppendMeasurements("c", "r1", "h1", "calibration", Batch(3));
  EXPECT_EQ(ErrorKind([&] { storage_->AppendMeasurements("c", "r1", "h-other", "calibration", Batch(4)); }),
            Kind::kAlreadyExists);
  EXPECT_EQ(ErrorKind([&] { storage_->AppendMeasurements("c", "r1", "h1", "validation", Batch(3)); }),
            Kind::kAlreadyExists);
  EXPECT_EQ(storage_->CountMeasurements("c"), 3);
  // Request ids are scoped to their campaign.
  storage_->Create("campaigns", "d", "{}");
  EXPECT_FALSE(storage_->AppendMeasurements("d", "r1", "h-other", "calibration", Batch(1)).replayed);
}

TEST_P(StorageTest, EmptyRequestIdNeverReplays) {
  storage_->Create("campaigns", "c", "{}");
  storage_->AppendMeasurements("c", "", "h", "calibration", Batch(1));
  const BatchResult second = storage_->AppendMeasurements("c", "", "h", "calibration", Batch(1));
  EXPECT_FALSE(second.replayed);
  EXPECT_EQ(second.campaign_total, 2);
}

TEST_P(StorageTest, BatchOverTheLimitStoresNothing) {
  storage_->Create("campaigns", "c", "{}");
  storage_->AppendMeasurements("c", "r1", "h1", "calibration", Batch(8), 10);
  EXPECT_EQ(ErrorKind([&] { storage_->AppendMeasurements("c", "r2", "h2", "calibration", Batch(3), 10); }),
            Kind::kResourceExhausted);
  EXPECT_EQ(storage_->CountMeasurements("c"), 8);
  EXPECT_EQ(storage_->ListMeasurements("c").size(), 8u);
  // The rejected request id was not recorded: the same request fits once it is smaller.
  const BatchResult fits = storage_->AppendMeasurements("c", "r2", "h2-small", "calibration", Batch(2), 10);
  EXPECT_FALSE(fits.replayed);
  EXPECT_EQ(fits.first_sequence, 9);
  EXPECT_EQ(fits.campaign_total, 10);
  // A replay of a batch that filled the campaign still replays.
  EXPECT_TRUE(storage_->AppendMeasurements("c", "r2", "h2-small", "calibration", Batch(2), 10).replayed);
}

TEST_P(StorageTest, RoleFilterAndPagingKeepSequenceOrder) {
  storage_->Create("campaigns", "c", "{}");
  for (int i = 0; i < 6; ++i) {
    storage_->AppendMeasurements("c", "r" + std::to_string(i), "h", i % 2 ? "validation" : "calibration", Batch(3));
  }
  EXPECT_EQ(storage_->CountMeasurements("c"), 18);
  EXPECT_EQ(storage_->CountMeasurements("c", "calibration"), 9);
  EXPECT_EQ(storage_->CountMeasurements("c", "validation"), 9);
  EXPECT_EQ(storage_->CountMeasurements("c", "other"), 0);

  const auto validation = storage_->ListMeasurements("c", "validation");
  ASSERT_EQ(validation.size(), 9u);
  for (std::size_t i = 0; i < validation.size(); ++i) {
    EXPECT_EQ(validation[i].role, "validation");
    if (i > 0) {
      EXPECT_GT(validation[i].sequence, validation[i - 1].sequence);
    }
  }
  EXPECT_EQ(validation.front().sequence, 4);

  std::vector<std::int64_t> paged;
  std::int64_t after = 0;
  for (;;) {
    const auto page = storage_->ListMeasurements("c", "calibration", after, 4);
    if (page.empty()) break;
    for (const auto& m : page) paged.push_back(m.sequence);
    after = page.back().sequence;
  }
  EXPECT_EQ(paged, (std::vector<std::int64_t>{1, 2, 3, 7, 8, 9, 13, 14, 15}));
}

TEST_P(StorageTest, DeletingACampaignDeletesItsMeasurements) {
  storage_->Create("campaigns", "c", "{}");
  storage_->AppendMeasurements("c", "r1", "h1", "calibration", Batch(3));
  EXPECT_TRUE(storage_->Delete("campaigns", "c"));
  EXPECT_EQ(storage_->CountMeasurements("c"), 0);
  storage_->Create("campaigns", "c", "{}");
  const BatchResult fresh = storage_->AppendMeasurements("c", "r1", "h-new", "calibration", Batch(1));
  EXPECT_FALSE(fresh.replayed);
  EXPECT_EQ(fresh.first_sequence, 1);
}

TEST_P(StorageTest, ALeaseIsHeldRenewedCancelledAndFinishedByItsOwnerOnly) {
  const Document created = storage_->CreateLeased("op-1", R"({"state":"RUNNING"})", "instance-a", 60000);
  EXPECT_EQ(created.version, 1);
  EXPECT_EQ(storage_->Get("operations", "op-1")->json, R"({"state":"RUNNING"})");
  EXPECT_EQ(ErrorKind([&] { storage_->CreateLeased("op-1", "{}", "instance-b", 60000); }), Kind::kAlreadyExists);

  auto lease = storage_->GetLease("op-1");
  ASSERT_TRUE(lease.has_value());
  EXPECT_EQ(lease->owner, "instance-a");
  EXPECT_EQ(lease->progress, 0.0);
  EXPECT_FALSE(lease->cancel_requested);
  EXPECT_GT(lease->expires_in_ms, 50000);
  EXPECT_LE(lease->expires_in_ms, 60000);

  lease = storage_->RenewLease("op-1", "instance-a", 90000, 0.25);
  ASSERT_TRUE(lease.has_value());
  EXPECT_EQ(lease->progress, 0.25);
  EXPECT_GT(lease->expires_in_ms, 80000);
  EXPECT_EQ(storage_->GetLease("op-1")->progress, 0.25);
  EXPECT_FALSE(storage_->RenewLease("op-1", "instance-b", 90000, 0.5).has_value()) << "b does not hold it";

  EXPECT_TRUE(storage_->RequestCancel("op-1"));
  EXPECT_TRUE(storage_->GetLease("op-1")->cancel_requested);
  EXPECT_TRUE(storage_->RenewLease("op-1", "instance-a", 90000, 0.5)->cancel_requested);

  EXPECT_FALSE(storage_->FinishLeased("op-1", "instance-b", R"({"state":"SUCCEEDED"})"));
  EXPECT_EQ(storage_->Get("operations", "op-1")->json, R"({"state":"RUNNING"})") << "a refused finish writes nothing";
  EXPECT_TRUE(storage_->FinishLeased("op-1", "instance-a", R"({"state":"CANCELLED"})"));
  const auto finished = storage_->Get("operations", "op-1");
  EXPECT_EQ(finished->json, R"({"state":"CANCELLED"})");
  EXPECT_EQ(finished->version, 2);
  EXPECT_FALSE(storage_->GetLease("op-1").has_value());
  EXPECT_FALSE(storage_->RenewLease("op-1", "instance-a", 90000, 1.0).has_value());
  EXPECT_FALSE(storage_->RequestCancel("op-1"));
  EXPECT_FALSE(storage_->FinishLeased("op-1", "instance-a", "{}")) << "a lease ends once";
}

TEST_P(StorageTest, ExpiringLeasesEndsTheExpiredOnesOnlyAndOnce) {
  storage_->CreateLeased("op-live", R"({"state":"RUNNING"})", "a", 60000);
  // A lease of -1 ms has expired when it is created: the owner stopped renewing.
  storage_->CreateLeased("op-dead", R"({"state":"RUNNING"})", "b", -1);
  const auto failed = [](const Document& d) { return R"({"was":)" + d.json + "}"; };

  EXPECT_EQ(storage_->ExpireLeases(false, failed), std::vector<std::string>{"op-dead"});
  EXPECT_EQ(storage_->Get("operations", "op-dead")->json, R"({"was":{"state":"RUNNING"}})");
  EXPECT_FALSE(storage_->GetLease("op-dead").has_value());
  EXPECT_FALSE(storage_->FinishLeased("op-dead", "b", R"({"state":"SUCCEEDED"})")) << "its owner came back too late";
  EXPECT_FALSE(storage_->RenewLease("op-dead", "b", 60000, 0.9).has_value());
  EXPECT_EQ(storage_->Get("operations", "op-dead")->json, R"({"was":{"state":"RUNNING"}})");
  EXPECT_TRUE(storage_->GetLease("op-live").has_value());
  EXPECT_TRUE(storage_->ExpireLeases(false, failed).empty()) << "ended once";

  // All: what a process that owns its database does at start (every lease found belongs to a process gone).
  EXPECT_EQ(storage_->ExpireLeases(true, failed), std::vector<std::string>{"op-live"});
  EXPECT_FALSE(storage_->GetLease("op-live").has_value());
}

TEST_P(StorageTest, DeletingAnOperationEndsItsLease) {
  storage_->CreateLeased("op-1", "{}", "a", 60000);
  EXPECT_TRUE(storage_->Delete("operations", "op-1"));
  EXPECT_FALSE(storage_->GetLease("op-1").has_value());
  // The id can be used again, with a lease of its own.
  storage_->CreateLeased("op-1", "{}", "b", 60000);
  EXPECT_EQ(storage_->GetLease("op-1")->owner, "b");
}

INSTANTIATE_TEST_SUITE_P(EveryImplementation, StorageTest,
                         ::testing::Values(Implementation::kSqliteMemory, Implementation::kSqliteFile,
                                           Implementation::kPostgres, Implementation::kFake),
                         [](const ::testing::TestParamInfo<Implementation>& info) {
                           switch (info.param) {
                             case Implementation::kSqliteMemory:
                               return std::string("SqliteMemory");
                             case Implementation::kSqliteFile:
                               return std::string("SqliteFile");
                             case Implementation::kPostgres:
                               return std::string("Postgres");
                             case Implementation::kFake:
                               return std::string("Fake");
                           }
                           return std::string("Unknown");
                         });

TEST(StorageFileTest, ConcurrentAppendsLoseAndDuplicateNothing) {
  testing::TempDir dir;
  auto storage = OpenSqliteStorage(dir.File("concurrent.db"));
  storage->Create("campaigns", "c", "{}");
  constexpr int kThreads = 4;
  constexpr int kBatchesPerThread = 15;
  constexpr int kBatchSize = 5;
  std::vector<std::vector<BatchResult>> results(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (int b = 0; b < kBatchesPerThread; ++b) {
        const std::string request_id = "t" + std::to_string(t) + "-" + std::to_string(b);
        results[t].push_back(
            storage->AppendMeasurements("c", request_id, "h", "calibration", Batch(kBatchSize, request_id)));
      }
    });
  }
  for (auto& thread : threads) thread.join();

  const auto all = storage->ListMeasurements("c");
  ASSERT_EQ(all.size(), static_cast<std::size_t>(kThreads * kBatchesPerThread * kBatchSize));
  for (std::size_t i = 0; i < all.size(); ++i) EXPECT_EQ(all[i].sequence, static_cast<std::int64_t>(i + 1));
  std::set<std::int64_t> firsts;
  for (int t = 0; t < kThreads; ++t) {
    for (int b = 0; b < kBatchesPerThread; ++b) {
      const BatchResult& r = results[t][b];
      EXPECT_TRUE(firsts.insert(r.first_sequence).second);
      // Each batch's measurements are contiguous and in upload order.
      const std::string tag = "t" + std::to_string(t) + "-" + std::to_string(b);
      for (int k = 0; k < kBatchSize; ++k) {
        const auto& m = all[static_cast<std::size_t>(r.first_sequence - 1 + k)];
        EXPECT_EQ(m.batch_id, r.batch_id);
        EXPECT_EQ(m.json, R"({")" + tag + R"(":)" + std::to_string(k) + "}");
      }
    }
  }
}

TEST(StorageFileTest, ReopenFindsEverythingAndCreatesParentDirectories) {
  testing::TempDir dir;
  const std::string path = dir.File("a/b/robocal.db");
  std::string batch_id;
  {
    auto storage = OpenSqliteStorage(path);
    storage->Create("robots", "r", R"({"dh":[]})");
    storage->Create("campaigns", "c", "{}");
    storage->Update("robots", "r", R"({"dh":[1]})");
    batch_id = storage->AppendMeasurements("c", "r1", "h1", "validation", Batch(4)).batch_id;
  }
  EXPECT_TRUE(std::filesystem::exists(path));
  auto storage = OpenSqliteStorage(path);
  EXPECT_EQ(storage->SchemaVersion(), 2);
  const auto robot = storage->Get("robots", "r");
  ASSERT_TRUE(robot.has_value());
  EXPECT_EQ(robot->json, R"({"dh":[1]})");
  EXPECT_EQ(robot->version, 2);
  EXPECT_EQ(storage->CountMeasurements("c", "validation"), 4);
  const BatchResult replay = storage->AppendMeasurements("c", "r1", "h1", "validation", Batch(4));
  EXPECT_TRUE(replay.replayed);
  EXPECT_EQ(replay.batch_id, batch_id);
  EXPECT_EQ(storage->IntegrityCheck(), "ok");
}

TEST(StorageFileTest, UsesWalMode) {
  testing::TempDir dir;
  const std::string path = dir.File("wal.db");
  { auto storage = OpenSqliteStorage(path); }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "PRAGMA journal_mode", -1, &stmt, nullptr), SQLITE_OK);
  ASSERT_EQ(sqlite3_step(stmt), SQLITE_ROW);
  EXPECT_STREQ(reinterpret_cast<const char*>(sqlite3_column_text(stmt, 0)), "wal");
  sqlite3_finalize(stmt);
  sqlite3_close(db);
}

TEST(StorageFileTest, RefusesANewerSchemaVersion) {
  testing::TempDir dir;
  const std::string path = dir.File("newer.db");
  { auto storage = OpenSqliteStorage(path); }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "PRAGMA user_version = 99", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  try {
    OpenSqliteStorage(path);
    FAIL() << "opened a database with schema version 99";
  } catch (const StorageError& e) {
    EXPECT_EQ(e.kind(), Kind::kUnavailable);
    EXPECT_NE(std::string(e.what()).find("newer"), std::string::npos) << e.what();
  }
}

TEST(StorageFileTest, NotADatabaseIsUnavailable) {
  testing::TempDir dir;
  const std::string path = dir.File("text.db");
  {
    std::FILE* f = std::fopen(path.c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fputs("this is not a database, just some text that is long enough to fill a header........", f);
    std::fclose(f);
  }
  EXPECT_EQ(ErrorKind([&] { OpenSqliteStorage(path); }), Kind::kUnavailable);
}

TEST(StorageFileTest, FreshDatabaseIsAtTheCurrentVersionAndPassesIntegrityCheck) {
  auto storage = OpenSqliteStorage(":memory:");
  EXPECT_EQ(storage->SchemaVersion(), 2);
  EXPECT_EQ(storage->IntegrityCheck(), "ok");
}

TEST(StorageFileTest, AVersion1DatabaseIsMigratedWithItsContents) {
  testing::TempDir dir;
  const std::string path = dir.File("v1.db");
  {
    // Version 1 as released: documents, batches, measurements; no operation leases.
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, R"sql(
      CREATE TABLE documents (collection TEXT NOT NULL, id TEXT NOT NULL, json TEXT NOT NULL, version INTEGER NOT NULL,
        created_unix_ms INTEGER NOT NULL, updated_unix_ms INTEGER NOT NULL, PRIMARY KEY (collection, id)) WITHOUT ROWID;
      CREATE TABLE batches (batch_id TEXT PRIMARY KEY, campaign_id TEXT NOT NULL, request_id TEXT,
        content_hash TEXT NOT NULL, role TEXT NOT NULL, first_sequence INTEGER NOT NULL, count INTEGER NOT NULL,
        created_unix_ms INTEGER NOT NULL, UNIQUE (campaign_id, request_id));
      CREATE TABLE measurements (campaign_id TEXT NOT NULL, sequence INTEGER NOT NULL,
        batch_id TEXT NOT NULL REFERENCES batches (batch_id), role TEXT NOT NULL, json TEXT NOT NULL,
        PRIMARY KEY (campaign_id, sequence)) WITHOUT ROWID;
      INSERT INTO documents VALUES ('operations', 'op-old', '{"state":"RUNNING"}', 1, 1, 1);
      PRAGMA user_version = 1;
    )sql", nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);
  }
  auto storage = OpenSqliteStorage(path);
  EXPECT_EQ(storage->SchemaVersion(), 2);
  EXPECT_EQ(storage->Get("operations", "op-old")->json, R"({"state":"RUNNING"})");
  EXPECT_FALSE(storage->GetLease("op-old").has_value()) << "an operation from before leases holds none";
  storage->CreateLeased("op-new", "{}", "a", 60000);
  EXPECT_EQ(storage->GetLease("op-new")->owner, "a");
  EXPECT_EQ(storage->IntegrityCheck(), "ok");
}

}  // namespace
}  // namespace robocal::server
