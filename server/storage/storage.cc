// Choosing a database by the --db value, and what the implementations share (storage_common.h).
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdio>
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

namespace {

/// RFC 3986 percent-decoding, as libpq applies to a URI's parts; an invalid escape is kept as written.
std::string PercentDecoded(const std::string& text) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '%' && i + 2 < text.size() && std::isxdigit(static_cast<unsigned char>(text[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(text[i + 2]))) {
      out += static_cast<char>(std::stoi(text.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += text[i];
    }
  }
  return out;
}

}  // namespace

// Written here rather than taken from libpq's PQconninfoParse: that refuses a URL it cannot parse (a stray '%',
// an '@' in the password), which is exactly when its error message echoes the password back.
std::vector<std::string> PasswordsIn(const std::string& url) {
  std::vector<std::string> found;
  const auto add = [&](const std::string& raw) {
    if (raw.empty()) return;
    found.push_back(raw);
    if (const std::string decoded = PercentDecoded(raw); decoded != raw) found.push_back(decoded);
    // libpq splits a URL at its first '@' and ':', so its messages may echo only the part of a password after
    // one of them.
    for (std::size_t at = raw.find_first_of("@:"); at != std::string::npos; at = raw.find_first_of("@:", at + 1)) {
      if (raw.size() - at > 3) found.push_back(raw.substr(at + 1));
    }
  };
  const std::size_t scheme = url.find("://");
  if (scheme != std::string::npos) {
    // The user information ends at the last '@' before the path or the parameters.
    const std::size_t start = scheme + 3;
    const std::size_t end = std::min(url.find('/', start), url.find('?', start));
    const std::size_t at = url.rfind('@', end == std::string::npos ? std::string::npos : end);
    if (at != std::string::npos && at >= start) {
      const std::size_t colon = url.find(':', start);
      if (colon != std::string::npos && colon < at) add(url.substr(colon + 1, at - colon - 1));
    }
  }
  // Parameters: password=... (the key itself may be percent-encoded).
  const std::size_t query = url.find('?');
  std::size_t from = query == std::string::npos ? 0 : query + 1;
  while (from <= url.size()) {
    const std::size_t amp = url.find_first_of("& ", from);
    const std::string pair = url.substr(from, amp == std::string::npos ? std::string::npos : amp - from);
    if (const std::size_t eq = pair.find('='); eq != std::string::npos && PercentDecoded(pair.substr(0, eq)) == "password") {
      add(pair.substr(eq + 1));
    }
    if (amp == std::string::npos) break;
    from = amp + 1;
  }
  return found;
}

std::string Scrub(std::string text, std::vector<std::string> secrets) {
  // Longest first: a decoded password may be part of its written form.
  std::sort(secrets.begin(), secrets.end(), [](const auto& a, const auto& b) { return a.size() > b.size(); });
  for (const std::string& secret : secrets) {
    if (secret.empty()) continue;
    for (std::size_t at = text.find(secret); at != std::string::npos; at = text.find(secret, at + 3)) {
      text.replace(at, secret.size(), "***");
    }
  }
  return text;
}

std::string RedactUrl(const std::string& db) { return Scrub(db, PasswordsIn(db)); }

BatchResult ReplayBatch(const std::string& campaign_id, const std::string& request_id, const std::string& content_hash,
                        const std::string& role, const StoredBatch& earlier, std::int64_t total) {
  if (earlier.content_hash != content_hash || earlier.role != role) {
    throw StorageError(StorageError::Kind::kAlreadyExists, "request_id " + request_id + " of campaign " + campaign_id +
                                                               " was used before for a different batch");
  }
  return BatchResult{.campaign = campaign_id,
                     .batch_id = earlier.batch_id,
                     .request_id = request_id,
                     .replayed = true,
                     .first_sequence = earlier.first_sequence,
                     .count = earlier.count,
                     .campaign_total = total,
                     .stale = {}};
}

StoredBatch NewBatch(const std::string& content_hash, const std::string& role, std::int64_t total, std::int64_t count) {
  return {.batch_id = NewRandomId("b"),
          .content_hash = content_hash,
          .role = role,
          .first_sequence = total + 1,
          .count = count};
}

BatchResult AppendedBatch(const std::string& campaign_id, const std::string& request_id, const StoredBatch& batch,
                          std::int64_t total_before) {
  return BatchResult{.campaign = campaign_id,
                     .batch_id = batch.batch_id,
                     .request_id = request_id,
                     .replayed = false,
                     .first_sequence = batch.first_sequence,
                     .count = batch.count,
                     .campaign_total = total_before + batch.count,
                     .stale = {}};
}

void CheckVersion(const std::string& collection, const std::string& id, std::int64_t version,
                  std::int64_t expected_version) {
  if (expected_version > 0 && expected_version != version) {
    throw StorageError(StorageError::Kind::kVersionConflict,
                       collection + "/" + id + " is at version " + std::to_string(version) + ", not " +
                           std::to_string(expected_version) + " (a concurrent update won)");
  }
}

void CheckCampaignTotal(const std::string& campaign_id, std::int64_t total, std::int64_t count,
                        std::int64_t max_campaign_total) {
  if (max_campaign_total > 0 && total + count > max_campaign_total) {
    throw StorageError(StorageError::Kind::kResourceExhausted,
                       "campaign " + campaign_id + " holds " + std::to_string(total) + " measurements; " +
                           std::to_string(count) + " more would exceed the limit of " +
                           std::to_string(max_campaign_total));
  }
}

std::string NewRandomId(const std::string& prefix) {
  static std::mutex mutex;
  // Seeded with 256 bits of the system's entropy: one random_device() is 32 bits, and two processes (instances,
  // restarts) that drew the same seed would hand out the same ids.
  static std::mt19937_64 engine = [] {
    std::random_device device;
    std::seed_seq seed{device(), device(), device(), device(), device(), device(), device(), device()};
    return std::mt19937_64(seed);
  }();
  std::uint64_t bits = 0;
  {
    std::lock_guard lock(mutex);
    bits = engine();
  }
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(bits));
  return prefix + "-" + hex;
}

}  // namespace robocal::server
