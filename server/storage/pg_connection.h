// A thin RAII layer over libpq for the PostgreSQL storage: results freed on scope exit, statements prepared
// once per connection with their parameters bound (never spliced into SQL), transactions that roll back unless
// committed, and a fixed-size pool. libpq is the C client PostgreSQL ships; Debian's C++ binding (libpqxx 6.4)
// predates the API its current documentation describes, and the storage needs only these few calls.
#pragma once

#include <libpq-fe.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "server/storage/storage.h"

namespace robocal::server::pg {

/// One statement parameter in text form; nullopt is SQL NULL.
using Param = std::optional<std::string>;
inline Param Int(std::int64_t value) { return std::to_string(value); }
/// A text[] parameter in PostgreSQL's array literal form (every element quoted, '"' and '\\' escaped), so that
/// a batch of rows is one statement: INSERT ... SELECT FROM unnest($n::text[]).
Param TextArray(const std::vector<std::string>& values);

/// The StorageError kind of a failed statement, by its SQLSTATE (PostgreSQL manual, appendix A): a unique key
/// taken is kAlreadyExists; a lost connection, exhausted resources, an administrator's shutdown, a lock timeout,
/// a serialization failure or deadlock are kUnavailable (a retry may succeed); anything else is kInternal.
StorageError::Kind KindOfSqlState(const std::string& sqlstate);

/// A statement's result; frees it on scope exit.
class Result {
 public:
  explicit Result(PGresult* result) : result_(result, &PQclear) {}
  int rows() const { return PQntuples(result_.get()); }
  bool IsNull(int row, int column) const { return PQgetisnull(result_.get(), row, column) != 0; }
  std::string Text(int row, int column) const;
  std::int64_t Int(int row, int column) const;
  double Double(int row, int column) const;
  bool Bool(int row, int column) const { return Text(row, column) == "t"; }

 private:
  std::unique_ptr<PGresult, void (*)(PGresult*)> result_;
};

/// One connection. Not thread-safe: the pool hands it to one thread at a time.
class Connection {
 public:
  /// Connects; throws StorageError (kUnavailable) naming the URL, its password hidden, if it cannot. Every
  /// session gets lock_timeout = `lock_timeout_ms` (a call waits no longer for a row another holds, and fails
  /// kUnavailable) and keeps notices off stderr.
  explicit Connection(const std::string& url, std::int64_t lock_timeout_ms = 5000);
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  /// Runs `sql` (no parameters; several statements allowed), e.g. BEGIN or DDL. Throws StorageError.
  void Exec(const std::string& sql);
  /// Runs `sql` with $1.. bound to `params`, prepared on this connection the first time it is seen.
  Result Run(const std::string& sql, const std::vector<Param>& params = {});
  /// True unless the connection was lost; a lost one is re-established by Reconnect().
  bool ok() const { return PQstatus(conn_.get()) == CONNECTION_OK; }
  /// Re-establishes a lost connection (its prepared statements are gone with it). Throws kUnavailable.
  void Reconnect();
  /// Called by the pool when it hands the connection out.
  void Borrowed() {
    statements_ = 0;
    lost_at_first_ = false;
  }
  /// True if the first statement since it was borrowed found the connection lost: it had died while idle in
  /// the pool (a database restart, a failover, an administrator ending sessions), and that statement never ran.
  bool lost_at_first() const { return lost_at_first_; }

 private:
  [[noreturn]] void Fail(PGresult* result, const std::string& what);
  void Setup();

  std::string url_;
  std::int64_t lock_timeout_ms_;
  int statements_ = 0;
  bool lost_at_first_ = false;
  std::unique_ptr<PGconn, void (*)(PGconn*)> conn_;
  /// SQL text -> prepared statement name.
  std::unordered_map<std::string, std::string> prepared_;
};

/// BEGIN on construction, ROLLBACK on scope exit unless Commit() ran. A commit that returns is durable under
/// the session's synchronous_commit (never "off": Connection raises it to "on").
class Transaction {
 public:
  explicit Transaction(Connection& connection);
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  ~Transaction();
  void Commit();

 private:
  Connection& connection_;
  bool done_ = false;
};

/// `size` connections opened at construction; Borrow() waits up to `wait` for a free one.
class Pool {
 public:
  Pool(const std::string& url, int size, std::chrono::milliseconds wait, std::int64_t lock_timeout_ms = 5000);

  /// A borrowed connection, returned to the pool on scope exit.
  class BorrowedConnection {
   public:
    BorrowedConnection(Pool* pool, std::unique_ptr<Connection> connection)
        : pool_(pool), connection_(std::move(connection)) {}
    BorrowedConnection(BorrowedConnection&&) = default;
    BorrowedConnection(const BorrowedConnection&) = delete;
    BorrowedConnection& operator=(const BorrowedConnection&) = delete;
    ~BorrowedConnection();
    Connection& operator*() { return *connection_; }
    Connection* operator->() { return connection_.get(); }

   private:
    Pool* pool_;
    std::unique_ptr<Connection> connection_;
  };

  /// A connection (re-established first if it was lost); kUnavailable if none is free within the wait.
  BorrowedConnection Borrow();

  /// Runs `work(connection)` on a borrowed connection. If its first statement found the connection dead (it
  /// died while idle in the pool), nothing of the work reached the database, so it runs once more on the
  /// connection re-established: a restart of the database costs no request. Work must therefore begin with
  /// BEGIN, a read, or a write that may be repeated.
  template <typename Work>
  auto Run(Work&& work) {
    for (int attempt = 0;; ++attempt) {
      BorrowedConnection connection = Borrow();
      try {
        return work(*connection);
      } catch (const StorageError&) {
        if (attempt > 0 || !connection->lost_at_first()) throw;
      }
    }
  }

 private:
  void Return(std::unique_ptr<Connection> connection);

  std::mutex mutex_;
  std::condition_variable returned_;
  std::vector<std::unique_ptr<Connection>> idle_;
  std::chrono::milliseconds wait_;
  int size_;
};

}  // namespace robocal::server::pg
