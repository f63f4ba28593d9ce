// A robocal-server child process, as an operator starts it: the built binary with command-line flags, on a
// free port (--port 0; the port is read from the "listening on" line), stderr (the log) to a file.
#pragma once

#include <gtest/gtest.h>
#include <httplib.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "guarded_client.h"

namespace robocal::server::testing {

class ServerProcess {
 public:
  /// Starts ROBOCAL_SERVER_BINARY --port 0 <args>; stderr goes to `log_path` ("" = /dev/null).
  explicit ServerProcess(const std::vector<std::string>& args, const std::string& log_path = "") {
    int out[2];
    EXPECT_EQ(pipe(out), 0);
    pid_ = fork();
    if (pid_ == 0) {
      dup2(out[1], STDOUT_FILENO);
      close(out[0]);
      std::FILE* err = std::fopen(log_path.empty() ? "/dev/null" : log_path.c_str(), "w");
      if (err != nullptr) dup2(fileno(err), STDERR_FILENO);
      std::vector<std::string> all = {ROBOCAL_SERVER_BINARY, "--port", "0"};
      all.insert(all.end(), args.begin(), args.end());
      std::vector<char*> argv;
      for (std::string& a : all) argv.push_back(a.data());
      argv.push_back(nullptr);
      execv(ROBOCAL_SERVER_BINARY, argv.data());
      _exit(127);
    }
    close(out[1]);
    // The first line says where it listens.
    std::FILE* f = fdopen(out[0], "r");
    char line[512] = {0};
    if (std::fgets(line, sizeof line, f) != nullptr) {
      std::smatch m;
      const std::string text(line);
      if (std::regex_search(text, m, std::regex(R"(listening on (https?)://127\.0\.0\.1:(\d+))"))) {
        scheme_ = m[1].str();
        port_ = std::stoi(m[2].str());
      }
    }
    std::fclose(f);
    EXPECT_GT(port_, 0) << "server did not start: " << line;
  }
  ~ServerProcess() { Kill(); }
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;

  void Kill() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
      pid_ = -1;
    }
  }
  /// Sends SIGTERM and waits; returns the exit code (-1 if it did not exit normally).
  int Terminate() {
    if (pid_ <= 0) return -1;
    kill(pid_, SIGTERM);
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  int port() const { return port_; }
  pid_t pid() const { return pid_; }
  /// Waits until the server's /metrics count at least `n` connections served or queued besides the one asking:
  /// the server's own state (it has taken a test's stalled clients), not a time. False after 30 s (plain http).
  bool WaitForConnections(int n) const {
    httplib::Client client("127.0.0.1", port_);
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (std::chrono::steady_clock::now() < give_up) {
      if (const auto r = client.Get("/metrics"); r && r->status == 200) {
        long long active = 0, queued = 0;
        std::smatch m;
        if (std::regex_search(r->body, m, std::regex(R"(\nrobocal_http_connections_active (\d+))"))) active = std::stoll(m[1]);
        if (std::regex_search(r->body, m, std::regex(R"(\nrobocal_http_connections_queued (\d+))"))) queued = std::stoll(m[1]);
        if (active + queued >= n + 1) return true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return false;
  }
  /// "http" or "https", from the listening line.
  const std::string& scheme() const { return scheme_; }

 private:
  pid_t pid_ = -1;
  int port_ = -1;
  std::string scheme_;
};

/// The lines of a text file.
inline std::vector<std::string> ReadLines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

}  // namespace robocal::server::testing
