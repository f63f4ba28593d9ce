// A child process for the kill -9 durability tests: opens the database given as argv[1] (an SQLite path or a
// PostgreSQL URL, as --db takes it), creates campaign "c"
// and appends batches until it is killed, printing "<request_id> <first_sequence> <count>" for every batch
// after AppendMeasurements returned, i.e. after the write was acknowledged.
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "server/storage/storage.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s DATABASE\n", argv[0]);
    return 2;
  }
  try {
    auto storage = robocal::server::OpenStorage(argv[1]);
    storage->Put("campaigns", "c", R"({"robot":"r"})");
    // Bounded so that a test that fails to kill it does not leave it running for ever.
    for (int i = 0; i < 100000; ++i) {
      const std::string request_id = "r" + std::to_string(i);
      std::vector<std::string> batch;
      for (int k = 0; k < 20; ++k)
        batch.push_back(R"({"i":)" + std::to_string(i) + R"(,"k":)" + std::to_string(k) + "}");
      const auto result = storage->AppendMeasurements("c", request_id, "h" + std::to_string(i), "calibration", batch);
      std::printf("%s %lld %lld\n", request_id.c_str(), static_cast<long long>(result.first_sequence),
                  static_cast<long long>(result.count));
      std::fflush(stdout);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "crash_helper: %s\n", e.what());
    return 1;
  }
  return 0;
}
