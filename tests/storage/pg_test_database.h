// A PostgreSQL database of its own for each test, on the private test cluster of pg_cluster.sh. Under ctest the
// cluster is a fixture (ROBOCAL_TEST_PG_CLUSTER names its directory); a test binary run by hand starts a cluster
// for its own lifetime and stops it at exit. The database is dropped when the test ends.
#pragma once

#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>

#include "server/storage/pg_connection.h"

namespace robocal::server::testing {

/// The unix socket directory of the test cluster.
class PgTestCluster {
 public:
  static const std::string& SocketDir() {
    static PgTestCluster cluster;
    return cluster.socket_dir_;
  }
  ~PgTestCluster() {
    if (!own_dir_.empty()) {
      Script("stop", own_dir_);
      std::error_code ec;
      std::filesystem::remove_all(own_dir_, ec);
    }
  }

 private:
  PgTestCluster() {
    std::string dir;
    if (const char* fixture = std::getenv("ROBOCAL_TEST_PG_CLUSTER"); fixture != nullptr && *fixture != '\0') {
      dir = fixture;
    } else {
      own_dir_ = (std::filesystem::temp_directory_path() / ("robocal-pg-own-" + std::to_string(::getpid()))).string();
      Script("start", own_dir_);
      dir = own_dir_;
    }
    std::ifstream in(dir + "/socket_dir");
    if (!std::getline(in, socket_dir_) || socket_dir_.empty()) {
      throw std::runtime_error("no PostgreSQL test cluster at " + dir + " (pg_cluster.sh start " + dir + ")");
    }
  }
  static void Script(const std::string& command, const std::string& dir) {
    const std::string line = std::string("bash '") + ROBOCAL_PG_CLUSTER_SCRIPT + "' " + command + " '" + dir + "'";
    if (std::system(line.c_str()) != 0 && command == "start") {
      throw std::runtime_error("cannot start a PostgreSQL test cluster: " + line);
    }
  }

  std::string socket_dir_;
  std::string own_dir_;
};

/// A fresh, empty database, dropped (with any connection still open to it) by the destructor.
class PgTestDatabase {
 public:
  PgTestDatabase() {
    static std::atomic<int> counter{0};
    name_ = "robocal_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++);
    Admin().Exec("CREATE DATABASE " + name_);
  }
  ~PgTestDatabase() {
    try {
      Admin().Exec("DROP DATABASE IF EXISTS " + name_ + " WITH (FORCE)");
    } catch (const std::exception&) {
      // The cluster is thrown away with the fixture; a database left behind costs nothing.
    }
  }
  PgTestDatabase(const PgTestDatabase&) = delete;
  PgTestDatabase& operator=(const PgTestDatabase&) = delete;

  /// The URL robocal-server takes as --db.
  std::string Url() const { return "postgresql://robocal@/" + name_ + "?host=" + PgTestCluster::SocketDir(); }
  const std::string& name() const { return name_; }

 private:
  static pg::Connection Admin() {
    return pg::Connection("postgresql://robocal@/postgres?host=" + PgTestCluster::SocketDir());
  }
  std::string name_;
};

}  // namespace robocal::server::testing
