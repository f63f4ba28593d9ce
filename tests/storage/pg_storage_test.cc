// What only a database shared by several server instances has (the contract suite in storage_test.cc runs on
// PostgreSQL too): two instances appending to one campaign, a batch retried through another instance, instances
// starting together, leases ended once when instances race, schema versions, lost connections, the integrity
// check, and URLs in messages without their password.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "pg_test_database.h"
#include "server/storage/pg_connection.h"
#include "server/storage/storage.h"

namespace robocal::server {
namespace {

using Kind = StorageError::Kind;

// Measurements whose text holds a quote and a backslash: the batch insert passes them through unchanged.
std::vector<std::string> QuotedBatch(int count, const std::string& tag) {
  std::vector<std::string> batch;
  for (int i = 0; i < count; ++i) batch.push_back(R"({")" + tag + R"(":)" + std::to_string(i) + R"(,"q":"a\"b\\c"})");
  return batch;
}

std::unique_ptr<Storage> Instance(const testing::PgTestDatabase& db) {
  return OpenPostgresStorage(db.Url(), StorageOptions{.pool_size = 3});
}

TEST(PostgresStorageTest, TwoInstancesAppendingToOneCampaignLoseAndDuplicateNothing) {
  testing::PgTestDatabase db;
  auto a = Instance(db);
  auto b = Instance(db);
  a->Create("campaigns", "c", "{}");
  constexpr int kThreads = 4;  // two per instance
  constexpr int kBatches = 12;
  constexpr int kSize = 7;
  std::vector<std::vector<BatchResult>> results(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      Storage& instance = t % 2 == 0 ? *a : *b;
      for (int i = 0; i < kBatches; ++i) {
        const std::string request = "t" + std::to_string(t) + "-" + std::to_string(i);
        results[t].push_back(instance.AppendMeasurements("c", request, "h", "calibration", QuotedBatch(kSize, request)));
      }
    });
  }
  for (auto& thread : threads) thread.join();

  const auto all = b->ListMeasurements("c");
  ASSERT_EQ(all.size(), static_cast<std::size_t>(kThreads * kBatches * kSize));
  for (std::size_t i = 0; i < all.size(); ++i) EXPECT_EQ(all[i].sequence, static_cast<std::int64_t>(i + 1));
  for (int t = 0; t < kThreads; ++t) {
    for (int i = 0; i < kBatches; ++i) {
      const BatchResult& r = results[t][i];
      const std::string tag = "t" + std::to_string(t) + "-" + std::to_string(i);
      for (int k = 0; k < kSize; ++k) {
        const auto& m = all[static_cast<std::size_t>(r.first_sequence - 1 + k)];
        EXPECT_EQ(m.batch_id, r.batch_id);
        EXPECT_EQ(m.json, QuotedBatch(kSize, tag)[static_cast<std::size_t>(k)]) << "stored as sent, quotes and backslashes";
      }
    }
  }
  EXPECT_EQ(a->IntegrityCheck(), "ok");
}

TEST(PostgresStorageTest, ABatchRetriedThroughAnotherInstanceIsStoredOnce) {
  testing::PgTestDatabase db;
  auto a = Instance(db);
  auto b = Instance(db);
  a->Create("campaigns", "c", "{}");
  const BatchResult first = a->AppendMeasurements("c", "req-1", "hash-1", "calibration", QuotedBatch(5, "x"));
  const BatchResult retry = b->AppendMeasurements("c", "req-1", "hash-1", "calibration", QuotedBatch(5, "x"));
  EXPECT_TRUE(retry.replayed);
  EXPECT_EQ(retry.batch_id, first.batch_id);
  EXPECT_EQ(retry.first_sequence, first.first_sequence);
  EXPECT_EQ(b->CountMeasurements("c"), 5);
  try {
    b->AppendMeasurements("c", "req-1", "hash-2", "calibration", QuotedBatch(5, "y"));
    ADD_FAILURE() << "a request id reused for other content was stored";
  } catch (const StorageError& e) {
    EXPECT_EQ(e.kind(), Kind::kAlreadyExists);
  }

  // The same request sent to both instances at once, many times: each is stored once.
  constexpr int kRequests = 30;
  std::vector<BatchResult> via_a(kRequests);
  std::vector<BatchResult> via_b(kRequests);
  std::thread ta([&] {
    for (int i = 0; i < kRequests; ++i) via_a[i] = a->AppendMeasurements("c", "race-" + std::to_string(i), "h", "calibration", QuotedBatch(3, "r"));
  });
  std::thread tb([&] {
    for (int i = 0; i < kRequests; ++i) via_b[i] = b->AppendMeasurements("c", "race-" + std::to_string(i), "h", "calibration", QuotedBatch(3, "r"));
  });
  ta.join();
  tb.join();
  for (int i = 0; i < kRequests; ++i) {
    EXPECT_EQ(via_a[i].batch_id, via_b[i].batch_id) << i;
    EXPECT_NE(via_a[i].replayed, via_b[i].replayed) << "exactly one of the two stored request " << i;
  }
  EXPECT_EQ(a->CountMeasurements("c"), 5 + kRequests * 3);
  EXPECT_EQ(a->IntegrityCheck(), "ok");
}

TEST(PostgresStorageTest, InstancesStartingTogetherCreateTheSchemaOnce) {
  testing::PgTestDatabase db;
  constexpr int kInstances = 6;
  std::vector<std::unique_ptr<Storage>> instances(kInstances);
  std::atomic<int> failures{0};
  std::vector<std::thread> threads;
  for (int i = 0; i < kInstances; ++i) {
    threads.emplace_back([&, i] {
      try {
        instances[i] = OpenPostgresStorage(db.Url(), StorageOptions{.pool_size = 1});
      } catch (const StorageError&) {
        ++failures;
      }
    });
  }
  for (auto& thread : threads) thread.join();
  ASSERT_EQ(failures.load(), 0);
  for (auto& instance : instances) EXPECT_EQ(instance->SchemaVersion(), 1);
  instances[0]->Create("robots", "r", "{}");
  EXPECT_TRUE(instances[kInstances - 1]->Get("robots", "r").has_value());
}

TEST(PostgresStorageTest, InstancesExpiringLeasesAtOnceEndEachOnce) {
  testing::PgTestDatabase db;
  auto a = Instance(db);
  auto b = Instance(db);
  constexpr int kLeases = 40;
  for (int i = 0; i < kLeases; ++i) a->CreateLeased("op-" + std::to_string(i), "{}", "gone", -1);
  std::atomic<int> calls{0};
  const auto expire = [&](const Document& d) {
    ++calls;
    return R"({"ended":")" + d.id + R"("})";
  };
  std::vector<std::string> by_a;
  std::vector<std::string> by_b;
  std::thread ta([&] { by_a = a->ExpireLeases(false, expire); });
  std::thread tb([&] { by_b = b->ExpireLeases(false, expire); });
  ta.join();
  tb.join();
  std::set<std::string> ended(by_a.begin(), by_a.end());
  for (const auto& id : by_b) EXPECT_TRUE(ended.insert(id).second) << id << " ended twice";
  EXPECT_EQ(ended.size(), static_cast<std::size_t>(kLeases));
  EXPECT_EQ(calls.load(), kLeases);
  for (int i = 0; i < kLeases; ++i) {
    const auto doc = b->Get("operations", "op-" + std::to_string(i));
    EXPECT_EQ(doc->json, R"({"ended":"op-)" + std::to_string(i) + R"("})");
    EXPECT_EQ(doc->version, 2);
  }
}

TEST(PostgresStorageTest, RefusesANewerSchemaVersion) {
  testing::PgTestDatabase db;
  { auto storage = Instance(db); }
  pg::Connection(db.Url()).Exec("UPDATE robocal_schema SET version = 99");
  try {
    Instance(db);
    FAIL() << "opened a database with schema version 99";
  } catch (const StorageError& e) {
    EXPECT_EQ(e.kind(), Kind::kUnavailable);
    EXPECT_NE(std::string(e.what()).find("newer"), std::string::npos) << e.what();
  }
}

TEST(PostgresStorageTest, AnUnreachableDatabaseIsUnavailableAndItsPasswordIsNotShown) {
  testing::PgTestDatabase db;
  const std::string socket = testing::PgTestCluster::SocketDir();
  // Passwords libpq cannot parse are the ones its messages echo: a stray '%', an '@' inside, an encoded key.
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"postgresql://robocal:s3cretA@/no_such_database?host=" + socket, "s3cretA"},
      {"postgresql://robocal:sec%zzretB@/no_such_database?host=" + socket, "sec%zzretB"},
      {"postgresql://robocal:p@ss:s3cretC@/no_such_database?host=" + socket, "s3cretC"},
      {"postgresql://robocal@/no_such_database?host=" + socket + "&pass%77ord=s3cretD", "s3cretD"},
      {"postgresql://robocal:s3cret%45@/no_such_database?host=" + socket, "s3cretE"},
  };
  for (const auto& [url, secret] : cases) {
    try {
      OpenPostgresStorage(url);
      ADD_FAILURE() << "connected to a database that does not exist";
    } catch (const StorageError& e) {
      EXPECT_EQ(e.kind(), Kind::kUnavailable);
      const std::string text = std::string(e.what()) + " | " + e.detail();
      EXPECT_EQ(text.find(secret), std::string::npos) << text;
      EXPECT_EQ(std::string(e.what()).find(socket), std::string::npos) << "the caller's text names no host: " << text;
    }
    EXPECT_EQ(RedactUrl(url).find(secret), std::string::npos) << RedactUrl(url);
  }
  EXPECT_EQ(RedactUrl("postgresql://u:pw@h:5432/d?sslmode=require"), "postgresql://u:***@h:5432/d?sslmode=require");
  EXPECT_EQ(RedactUrl("postgresql://h/d?user=u&password=pw&x=1"), "postgresql://h/d?user=u&password=***&x=1");
  EXPECT_EQ(RedactUrl("postgresql://u@h/d"), "postgresql://u@h/d");
}

TEST(PostgresStorageTest, ConnectionsKilledByTheServerAreReestablishedWithoutFailingACall) {
  testing::PgTestDatabase db;
  auto storage = OpenPostgresStorage(db.Url(), StorageOptions{.pool_size = 2});
  storage->Create("campaigns", "c", "{}");
  // An administrator (or a failover) ends every session of the database.
  pg::Connection admin("postgresql://robocal@/postgres?host=" + testing::PgTestCluster::SocketDir());
  admin.Run("SELECT pg_terminate_backend(pid) FROM pg_stat_activity WHERE datname = $1::text", {db.name()});
  // Every pooled connection is dead now; each call finds that at its first statement, which therefore never
  // ran, re-establishes the connection and runs again: no call fails.
  for (int i = 0; i < 6; ++i) storage->AppendMeasurements("c", "r" + std::to_string(i), "h", "calibration", QuotedBatch(2, "k"));
  EXPECT_EQ(storage->CountMeasurements("c"), 12);
  EXPECT_TRUE(storage->Get("campaigns", "c").has_value());
  EXPECT_EQ(storage->IntegrityCheck(), "ok");
  // The lease calls have a connection of their own, re-established the same way.
  admin.Run("SELECT pg_terminate_backend(pid) FROM pg_stat_activity WHERE datname = $1::text", {db.name()});
  storage->CreateLeased("op", "{}", "a", 60000);
  EXPECT_TRUE(storage->RenewLease("op", "a", 60000, 0.5).has_value());
  EXPECT_TRUE(storage->ExpireLeases(false, [](const Document& d) { return d.json; }).empty());
}

TEST(PostgresStorageTest, IntegrityCheckFindsAMissingMeasurement) {
  testing::PgTestDatabase db;
  auto storage = Instance(db);
  storage->Create("campaigns", "c", "{}");
  storage->AppendMeasurements("c", "r", "h", "calibration", QuotedBatch(4, "k"));
  EXPECT_EQ(storage->IntegrityCheck(), "ok");
  pg::Connection(db.Url()).Exec("DELETE FROM measurements WHERE sequence = 2");
  const std::string problems = storage->IntegrityCheck();
  EXPECT_NE(problems.find("campaign with missing sequences: c"), std::string::npos) << problems;
  EXPECT_NE(problems.find("batch whose count differs"), std::string::npos) << problems;
}

TEST(PostgresStorageTest, OpenStorageChoosesByTheUrlAndNeverFallsBack) {
  testing::PgTestDatabase db;
  EXPECT_TRUE(IsPostgresUrl("postgresql://u@h/d"));
  EXPECT_TRUE(IsPostgresUrl("postgres://u@h/d"));
  EXPECT_FALSE(IsPostgresUrl("./var/robocal.db"));
  EXPECT_FALSE(IsPostgresUrl(":memory:"));
  auto storage = OpenStorage(db.Url());
  EXPECT_TRUE(storage->Shared());
  EXPECT_FALSE(OpenStorage(":memory:")->Shared());
  // A PostgreSQL URL that cannot be reached is an error, not an SQLite file of that name.
  try {
    OpenStorage("postgresql://robocal@/absent?host=/nonexistent-socket-dir");
    FAIL() << "opened an unreachable PostgreSQL URL";
  } catch (const StorageError& e) {
    EXPECT_EQ(e.kind(), Kind::kUnavailable);
  }
  EXPECT_FALSE(std::filesystem::exists("postgresql:"));
}

}  // namespace
}  // namespace robocal::server
