// The server's configuration: flags > environment (ROBOCAL_*) > config file (JSON, snake_case keys) > defaults.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace robocal::server {

struct ServerConfig {
  std::string host = "127.0.0.1";
  int port = 8080;
  /// An SQLite file path (one process owns it) or a PostgreSQL URL postgresql://... (instances may share it).
  std::string db = "./var/robocal.db";
  /// PostgreSQL: connections each instance holds open.
  int db_pool_size = 8;
  /// A running async operation's lease, renewed every third of it; when its instance stops renewing, another
  /// instance on the same database marks the operation FAILED once the lease has expired.
  int operation_lease_s = 10;
  /// One bearer token per line, '#' starts a comment; empty: no authentication.
  std::string tokens_file;
  /// Allow binding a non-loopback address without tokens.
  bool allow_insecure_bind = false;
  std::string tls_cert;
  std::string tls_key;
  std::string log_level = "info";   // trace | debug | info | warn | error
  std::string log_format = "text";  // text | json
  std::int64_t max_body_bytes = 8388608;
  std::int64_t max_measurements_per_campaign = 100000;
  int max_plan_configurations = 1000;
  /// Elements of any one array in a request (joint vectors, measurements, targets).
  std::int64_t max_array_length = 10000;
  /// Work and memory of one request, bounded before it starts (api::Limits says what each counts).
  std::int64_t max_plan_evaluations = 1000000;
  std::int64_t max_plan_jacobians = 10000000;
  int max_plan_candidates = 20000;
  std::int64_t max_fit_jacobian_entries = 2000000;
  /// Operations (async plans) running at once.
  int max_running_operations = 2;
  int request_timeout_s = 60;
  /// An idle keep-alive connection is closed after this many seconds (it holds a connection thread).
  int keep_alive_timeout_s = 2;
  /// A request's line, headers and body must all arrive within this time (of the first byte, or of the
  /// connection's accept for its first request): a client that trickles bytes cannot hold a thread longer.
  int request_read_timeout_s = 10;
  /// The client must take a whole reply within this time.
  int write_timeout_s = 60;
  /// Request line and headers together, in bytes.
  std::int64_t max_head_bytes = 65536;
  /// Requests handled at once (service work); further requests wait for a slot.
  int threads = 8;
  /// Connections served at once, one thread each (reading, waiting for a slot, writing, idle keep-alive).
  int max_connections = 256;
  /// Accepted connections waiting for a connection thread; a connection beyond is answered 503 and closed.
  int max_queued_connections = 64;
  std::string config_file;
};

/// The outcome of reading the command line: run, or exit with `exit_code` after printing `message`
/// (to stdout for --help / --version, to stderr for errors, exit code 2).
struct ConfigResult {
  bool run = false;
  int exit_code = 0;
  std::string message;
  ServerConfig config;
};

/// Reads flags (args without argv[0]), the environment (name -> value) and the config file they point at.
ConfigResult LoadConfig(const std::vector<std::string>& args, const std::map<std::string, std::string>& env);

/// The environment of this process as a map (ROBOCAL_* variables only).
std::map<std::string, std::string> RobocalEnvironment();

/// --help text.
std::string UsageText();

/// True for an IPv4 address in 127.0.0.0/8, the IPv6 loopback address and "localhost" (nothing else: a name
/// that merely starts with "127." is not an address).
bool IsLoopbackHost(const std::string& host);

/// Tokens from a tokens file (one per line, "TOKEN" or "NAME TOKEN", '#' comments, blank lines ignored), and into
/// `names` each token's name ("" for a line without one): the name a robot's calibration history records for the
/// requests that present it. Throws std::runtime_error if the file cannot be read, holds no token, a line has
/// more than two words, or a token is not printable ASCII without spaces and '%' (header values are
/// percent-decoded on arrival, so such a token could not be presented as written).
std::vector<std::string> ReadTokensFile(const std::string& path, std::vector<std::string>* names = nullptr);

}  // namespace robocal::server
