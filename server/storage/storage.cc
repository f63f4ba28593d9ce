// Choosing a database by the --db value, and what the implementations share (storage_common.h).
#include <mutex>
#include <random>
#include <string>

#include "server/storage/storage.h"
#include "server/storage/storage_common.h"

namespace robocal::server {

bool IsPostgresUrl(const std::string& db) {
  return db.rfind("postgresql://", 0) == 0 || db.rfind("postgres://", 0) == 0;
}

std::unique_ptr<Storage> OpenStorage(const std::string& db, const StorageOptions& options) {
  if (IsPostgresUrl(db)) return OpenPostgresStorage(db, options);
  return OpenSqliteStorage(db);
}

std::string RedactUrl(const std::string& url) {
  std::string out = url;
  // URI form: scheme://user:password@host...
  const std::size_t scheme = out.find("://");
  if (scheme != std::string::npos) {
    const std::size_t start = scheme + 3;
    const std::size_t at = out.find('@', start);
    const std::size_t slash = out.find('/', start);
    if (at != std::string::npos && (slash == std::string::npos || at < slash)) {
      const std::size_t colon = out.find(':', start);
      if (colon != std::string::npos && colon < at) out.replace(colon + 1, at - colon - 1, "***");
    }
  }
  // Parameter form, in the query string or a keyword/value string: password=...
  for (std::size_t at = out.find("password="); at != std::string::npos; at = out.find("password=", at + 12)) {
    const std::size_t value = at + 9;
    const std::size_t end = out.find_first_of("& ", value);
    out.replace(value, (end == std::string::npos ? out.size() : end) - value, "***");
  }
  return out;
}

std::string NewBatchId() {
  static std::mutex mutex;
  // 256 bits of the system's entropy (one random_device() is 32): instances drawing the same seed would
  // collide on every batch id.
  static std::mt19937_64 random = [] {
    std::random_device device;
    std::seed_seq seed{device(), device(), device(), device(), device(), device(), device(), device()};
    return std::mt19937_64(seed);
  }();
  static constexpr char kHex[] = "0123456789abcdef";
  std::uint64_t bits = 0;
  {
    std::lock_guard lock(mutex);
    bits = random();
  }
  std::string id = "b-";
  for (int i = 0; i < 16; ++i, bits >>= 4) id += kHex[bits & 0xf];
  return id;
}

}  // namespace robocal::server
