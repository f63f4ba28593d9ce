// libpq behind RAII: results, prepared statements, transactions, the pool (pg_connection.h says why libpq).
#include "server/storage/pg_connection.h"

#include <cstdlib>
#include <utility>

#include "server/storage/storage_common.h"

namespace robocal::server::pg {

using Kind = StorageError::Kind;

StorageError::Kind KindOfSqlState(const std::string& sqlstate) {
  if (sqlstate == "23505") return Kind::kAlreadyExists;  // unique_violation
  const std::string klass = sqlstate.substr(0, 2);
  // 08 connection exception, 53 insufficient resources, 57 operator intervention (e.g. admin shutdown),
  // 40 transaction rollback (serialization failure, deadlock), 55P03 lock not available.
  if (klass == "08" || klass == "53" || klass == "57" || klass == "40" || sqlstate == "55P03") {
    return Kind::kUnavailable;
  }
  return Kind::kInternal;
}

Param TextArray(const std::vector<std::string>& values) {
  std::string out = "{";
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (i > 0) out += ',';
    out += '"';
    for (const char c : values[i]) {
      if (c == '"' || c == '\\') out += '\\';
      out += c;
    }
    out += '"';
  }
  out += '}';
  return out;
}

std::string Result::Text(int row, int column) const {
  const char* value = PQgetvalue(result_.get(), row, column);
  return std::string(value, static_cast<std::size_t>(PQgetlength(result_.get(), row, column)));
}

std::int64_t Result::Int(int row, int column) const {
  return std::strtoll(PQgetvalue(result_.get(), row, column), nullptr, 10);
}

double Result::Double(int row, int column) const { return std::strtod(PQgetvalue(result_.get(), row, column), nullptr); }

namespace {

std::string Trimmed(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  return text;
}

// Notices (e.g. "relation ... already exists, skipping" at start) are libpq's to print on stderr, which would
// break the server's JSON log lines; robocal acts on results, not notices.
void DropNotice(void* /*arg*/, const char* /*message*/) {}

}  // namespace

Connection::Connection(const std::string& url, std::int64_t lock_timeout_ms)
    : url_(url), lock_timeout_ms_(lock_timeout_ms), conn_(PQconnectdb(url.c_str()), &PQfinish) {
  Setup();
}

void Connection::Setup() {
  if (!conn_ || PQstatus(conn_.get()) != CONNECTION_OK) {
    const std::string message = conn_ ? Trimmed(PQerrorMessage(conn_.get())) : "out of memory";
    // The reply says only that; the log gets where and why, any password scrubbed (libpq echoes parts of a
    // URL it cannot parse).
    throw StorageError(Kind::kUnavailable, "cannot connect to the database",
                       "cannot connect to " + RedactUrl(url_) + ": " + Scrub(message, PasswordsIn(url_)));
  }
  PQsetNoticeProcessor(conn_.get(), &DropNotice, nullptr);
  prepared_.clear();
  Exec("SET lock_timeout = " + std::to_string(lock_timeout_ms_));
  // A 2xx means committed: a server whose default is synchronous_commit=off would acknowledge commits it can
  // still lose, so the session raises it to on. Other values (local, remote_write, on, remote_apply) wait at
  // least for the local flush and are kept as the administrator set them.
  if (Run("SHOW synchronous_commit").Text(0, 0) == "off") Exec("SET synchronous_commit = on");
}

void Connection::Reconnect() {
  PQreset(conn_.get());
  Setup();
}

void Connection::Fail(PGresult* result, const std::string& what) {
  std::string sqlstate;
  std::string message;
  if (result != nullptr) {
    const char* state = PQresultErrorField(result, PG_DIAG_SQLSTATE);
    if (state != nullptr) sqlstate = state;
    message = PQresultErrorMessage(result);
    PQclear(result);
  }
  if (message.empty()) message = PQerrorMessage(conn_.get());
  const std::string detail = "postgresql: " + what + ": " + Trimmed(message) +
                             (sqlstate.empty() ? "" : " [" + sqlstate + "]");
  // No SQLSTATE, or the connection is gone: the statement did not complete (connection lost).
  if (sqlstate.empty() || !ok()) {
    lost_at_first_ = statements_ == 1;
    throw StorageError(Kind::kUnavailable, "the connection to the database was lost; retry", detail);
  }
  const Kind kind = KindOfSqlState(sqlstate);
  // The caller's text names no statement: the log has it (detail).
  const std::string reason = kind == Kind::kAlreadyExists ? "a unique key is taken"
                             : kind == Kind::kUnavailable ? "the database is busy or shutting down; retry"
                                                          : "the database refused a statement";
  throw StorageError(kind, reason + " (SQLSTATE " + sqlstate + ")", detail);
}

void Connection::Exec(const std::string& sql) {
  ++statements_;
  PGresult* result = PQexec(conn_.get(), sql.c_str());
  const ExecStatusType status = result ? PQresultStatus(result) : PGRES_FATAL_ERROR;
  if (status != PGRES_COMMAND_OK && status != PGRES_TUPLES_OK) Fail(result, sql.substr(0, 40));
  PQclear(result);
}

Result Connection::Run(const std::string& sql, const std::vector<Param>& params) {
  ++statements_;
  auto it = prepared_.find(sql);
  if (it == prepared_.end()) {
    const std::string name = "robocal_" + std::to_string(prepared_.size() + 1);
    PGresult* prepared = PQprepare(conn_.get(), name.c_str(), sql.c_str(), 0, nullptr);
    if (prepared == nullptr || PQresultStatus(prepared) != PGRES_COMMAND_OK) Fail(prepared, "prepare " + sql.substr(0, 60));
    PQclear(prepared);
    it = prepared_.emplace(sql, name).first;
  }
  std::vector<const char*> values;
  values.reserve(params.size());
  for (const Param& p : params) values.push_back(p ? p->c_str() : nullptr);
  PGresult* result = PQexecPrepared(conn_.get(), it->second.c_str(), static_cast<int>(values.size()), values.data(),
                                    nullptr, nullptr, 0);
  const ExecStatusType status = result ? PQresultStatus(result) : PGRES_FATAL_ERROR;
  if (status != PGRES_COMMAND_OK && status != PGRES_TUPLES_OK) Fail(result, sql.substr(0, 60));
  return Result(result);
}

Transaction::Transaction(Connection& connection) : connection_(connection) { connection_.Exec("BEGIN"); }

Transaction::~Transaction() {
  if (done_) return;
  try {
    if (connection_.ok()) connection_.Exec("ROLLBACK");
  } catch (const StorageError&) {
    // The connection is broken; the server rolls the transaction back when the session ends.
  }
}

void Transaction::Commit() {
  done_ = true;
  connection_.Exec("COMMIT");
}

Pool::Pool(const std::string& url, int size, std::chrono::milliseconds wait, std::int64_t lock_timeout_ms)
    : wait_(wait), size_(size) {
  if (size < 1) throw StorageError(Kind::kInternal, "db_pool_size must be at least 1");
  for (int i = 0; i < size; ++i) idle_.push_back(std::make_unique<Connection>(url, lock_timeout_ms));
}

Pool::BorrowedConnection::~BorrowedConnection() {
  if (connection_) pool_->Return(std::move(connection_));
}

Pool::BorrowedConnection Pool::Borrow() {
  std::unique_ptr<Connection> connection;
  {
    std::unique_lock lock(mutex_);
    if (!returned_.wait_for(lock, wait_, [&] { return !idle_.empty(); })) {
      throw StorageError(Kind::kUnavailable, "all " + std::to_string(size_) +
                                                 " database connections are busy (db_pool_size); retry later");
    }
    connection = std::move(idle_.back());
    idle_.pop_back();
  }
  BorrowedConnection borrowed(this, std::move(connection));
  if (!borrowed->ok()) borrowed->Reconnect();  // throws kUnavailable; `borrowed` returns the connection to the pool
  borrowed->Borrowed();
  return borrowed;
}

void Pool::Return(std::unique_ptr<Connection> connection) {
  {
    std::lock_guard lock(mutex_);
    idle_.push_back(std::move(connection));
  }
  returned_.notify_one();
}

}  // namespace robocal::server::pg
