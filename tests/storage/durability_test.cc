// kill -9 durability: a child process appends batches and reports each acknowledged one; after SIGKILL every
// reported batch must be in the database and the database must pass its integrity check.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "pg_test_database.h"
#include "server/storage/storage.h"
#include "temp_dir.h"

namespace robocal::server {
namespace {

struct Acknowledged {
  std::string request_id;
  long long first_sequence = 0;
  long long count = 0;
};

/// Runs the crash helper on `db`, kills it with SIGKILL while it writes, and checks that every batch it
/// reported as acknowledged is in the database, whole, and that nothing else was stored in part.
void AcknowledgedBatchesSurviveKill9(const std::string& db) {
  int pipe_fds[2];
  ASSERT_EQ(::pipe(pipe_fds), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::dup2(pipe_fds[1], STDOUT_FILENO);
    ::close(pipe_fds[0]);
    ::close(pipe_fds[1]);
    ::execl(ROBOCAL_CRASH_HELPER, ROBOCAL_CRASH_HELPER, db.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  ::close(pipe_fds[1]);

  // Read acknowledgements until enough have arrived, then kill the child while it is still writing.
  constexpr int kWanted = 40;
  std::vector<Acknowledged> acknowledged;
  FILE* in = ::fdopen(pipe_fds[0], "r");
  ASSERT_NE(in, nullptr);
  char line[256];
  while (static_cast<int>(acknowledged.size()) < kWanted && std::fgets(line, sizeof line, in)) {
    char request_id[128];
    Acknowledged ack;
    ASSERT_EQ(std::sscanf(line, "%127s %lld %lld", request_id, &ack.first_sequence, &ack.count), 3) << line;
    ack.request_id = request_id;
    acknowledged.push_back(ack);
  }
  ::kill(child, SIGKILL);
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  // Lines written before the kill but not yet read are acknowledged too.
  while (std::fgets(line, sizeof line, in)) {
    char request_id[128];
    Acknowledged ack;
    if (std::sscanf(line, "%127s %lld %lld", request_id, &ack.first_sequence, &ack.count) == 3) {
      ack.request_id = request_id;
      acknowledged.push_back(ack);
    }
  }
  std::fclose(in);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the helper exited on its own; status " << status;
  ASSERT_GE(acknowledged.size(), static_cast<std::size_t>(kWanted));

  auto storage = OpenStorage(db);
  EXPECT_EQ(storage->IntegrityCheck(), "ok");
  const auto measurements = storage->ListMeasurements("c");
  ASSERT_GE(measurements.size(), acknowledged.size() * 20);
  EXPECT_EQ(measurements.size() % 20, 0u) << "a batch was stored in part";
  for (std::size_t i = 0; i < measurements.size(); ++i) {
    EXPECT_EQ(measurements[i].sequence, static_cast<std::int64_t>(i + 1));
  }
  for (std::size_t i = 0; i < acknowledged.size(); ++i) {
    const Acknowledged& ack = acknowledged[i];
    EXPECT_EQ(ack.request_id, "r" + std::to_string(i));
    EXPECT_EQ(ack.first_sequence, static_cast<long long>(i * 20 + 1));
    // Replaying the acknowledged request finds the stored batch rather than writing a new one.
    const auto replay = storage->AppendMeasurements("c", ack.request_id, "h" + std::to_string(i), "calibration",
                                                    std::vector<std::string>(20, "{}"));
    EXPECT_TRUE(replay.replayed) << ack.request_id;
    EXPECT_EQ(replay.first_sequence, ack.first_sequence);
    EXPECT_EQ(replay.count, ack.count);
    const auto& first = measurements[static_cast<std::size_t>(ack.first_sequence - 1)];
    EXPECT_EQ(first.json, R"({"i":)" + std::to_string(i) + R"(,"k":0})");
    EXPECT_EQ(first.batch_id, replay.batch_id);
  }
}

TEST(DurabilityTest, AcknowledgedBatchesSurviveKill9OnSqlite) {
  testing::TempDir dir;
  AcknowledgedBatchesSurviveKill9(dir.File("var/robocal.db"));
}

TEST(DurabilityTest, AcknowledgedBatchesSurviveKill9OnPostgres) {
  testing::PgTestDatabase database;
  AcknowledgedBatchesSurviveKill9(database.Url());
}

}  // namespace
}  // namespace robocal::server
