// robocal-server: configuration, storage, the HTTP server, and graceful shutdown on SIGTERM / SIGINT.
#include <pthread.h>

#include <csignal>
#include <cstdio>
#include <iostream>
#include <optional>
#include <thread>

#include "robocal/server/config.h"
#include "robocal/server/http_server.h"
#include "robocal/server/logging.h"
#include "robocal/server/memory_trimmer.h"
#include "robocal/server/service.h"
#include "server/storage/storage.h"

namespace robocal::server {
namespace {

// The bearer tokens of --tokens-file and their names, or the exit code when the server must not start: the file
// cannot be read, or a host that is not loopback would be served without tokens.
std::optional<int> LoadServerTokens(const ServerConfig& config, std::vector<std::string>* tokens,
                                    std::vector<std::string>* token_names) {
  if (!config.tokens_file.empty()) {
    try {
      *tokens = ReadTokensFile(config.tokens_file, token_names);
    } catch (const std::exception& e) {
      std::cerr << "robocal-server: " << e.what() << "\n";
      return 2;
    }
  }
  if (!IsLoopbackHost(config.host) && tokens->empty() && !config.allow_insecure_bind) {
    std::cerr << "robocal-server: refusing to bind " << config.host
              << " (not loopback) without --tokens-file; pass --allow-insecure-bind to do it anyway\n";
    return 2;
  }
  return std::nullopt;
}

// The database of --db, or null (logged as critical) when it cannot be opened; `db_shown` names it in the log.
std::unique_ptr<Storage> OpenServerStorage(const ServerConfig& config, const std::string& db_shown) {
  try {
    return OpenStorage(config.db, StorageOptions{.pool_size = config.db_pool_size});
  } catch (const std::exception& e) {
    const auto* storage_error = dynamic_cast<const StorageError*>(&e);
    LogEvent(spdlog::level::critical, "cannot open the database",
             {{"db", db_shown},
              {"error", e.what()},
              {"detail", storage_error != nullptr ? storage_error->detail() : std::string()}});
    return nullptr;
  }
}

ServiceOptions ServiceOptionsOf(const ServerConfig& config) {
  ServiceOptions options;
  options.limits.max_plan_configurations = config.max_plan_configurations;
  options.limits.max_array_length = static_cast<std::size_t>(config.max_array_length);
  options.limits.max_plan_evaluations = config.max_plan_evaluations;
  options.limits.max_plan_jacobians = config.max_plan_jacobians;
  options.limits.max_plan_candidates = config.max_plan_candidates;
  options.limits.max_fit_jacobian_entries = config.max_fit_jacobian_entries;
  options.max_running_operations = config.max_running_operations;
  options.max_measurements_per_campaign = config.max_measurements_per_campaign;
  options.request_deadline = std::chrono::seconds(config.request_timeout_s);
  options.operation_lease = std::chrono::seconds(config.operation_lease_s);
  return options;
}

// Marks FAILED the operations no live instance runs, as the server starts.
void RecoverOperationsAtStart(Service* service) {
  try {
    if (const int aborted = service->RecoverOperations(); aborted > 0) {
      LogEvent(spdlog::level::warn, "operations no live instance runs marked FAILED", {{"count", aborted}});
    }
  } catch (const std::exception& e) {
    // The database went away between opening and here; the lease keeper ends the same operations later.
    LogEvent(spdlog::level::err, "cannot recover operations at start", {{"error", e.what()}});
  }
}

// The URL the server listens on (an IPv6 host in brackets).
std::string ListeningUrl(const ServerConfig& config, bool tls, int port) {
  return std::string(tls ? "https" : "http") + "://" +
         (config.host.find(':') != std::string::npos ? "[" + config.host + "]" : config.host) + ":" +
         std::to_string(port);
}

}  // namespace
}  // namespace robocal::server

int main(int argc, char** argv) {
  using namespace robocal::server;
  ConfigureMemoryAllocator();  // before any thread starts
  const ConfigResult loaded = LoadConfig(std::vector<std::string>(argv + 1, argv + argc), RobocalEnvironment());
  if (!loaded.run) {
    (loaded.exit_code == 0 ? std::cout : std::cerr) << loaded.message;
    return loaded.exit_code;
  }
  const ServerConfig& config = loaded.config;
  SetupLogging(config.log_level, config.log_format);

  std::vector<std::string> tokens, token_names;
  if (const std::optional<int> exit_code = LoadServerTokens(config, &tokens, &token_names)) return *exit_code;

  // Signals go to one waiting thread, not to whichever thread the kernel picks, so shutdown is orderly.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  // A URL's password stays out of the logs and the banner.
  const std::string db_shown = RedactUrl(config.db);
  std::unique_ptr<Storage> storage = OpenServerStorage(config, db_shown);
  if (!storage) return 1;
  auto service = std::make_unique<Service>(storage.get(), ServiceOptionsOf(config));
  RecoverOperationsAtStart(service.get());

  std::unique_ptr<HttpServer> server;
  try {
    server = std::make_unique<HttpServer>(config, service.get(), tokens, token_names);
  } catch (const std::exception& e) {
    std::cerr << "robocal-server: " << e.what() << "\n";
    return 2;
  }
  const int port = server->Bind();
  if (port < 0) {
    std::cerr << "robocal-server: cannot bind " << config.host << ":" << config.port
              << " (the port is in use, or the host is not an address of this machine)\n";
    return 1;
  }
  const std::string url = ListeningUrl(config, server->tls(), port);
  std::printf("robocal-server listening on %s (db %s)\n", url.c_str(), db_shown.c_str());
  std::fflush(stdout);
  LogEvent(spdlog::level::info, "listening",
           {{"url", url}, {"db", db_shown}, {"auth", tokens.empty() ? "off" : "bearer"}, {"version", ROBOCAL_VERSION}});

  std::thread waiter([&] {
    int signal = 0;
    sigwait(&signals, &signal);
    LogEvent(spdlog::level::info, "shutting down", {{"signal", signal == SIGTERM ? "SIGTERM" : "SIGINT"}});
    server->Stop();
  });
  const bool ok = server->Listen();
  if (!ok) {
    // Listen failed without a signal: wake the waiter so it can be joined.
    pthread_kill(waiter.native_handle(), SIGTERM);
  }
  waiter.join();
  server.reset();
  service.reset();  // cancels and joins running operations
  LogEvent(spdlog::level::info, "stopped");
  return ok ? 0 : 1;
}
