// What the storage implementations share and the service does not see.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "server/storage/storage.h"

namespace robocal::server {

/// `prefix`, "-" and 16 hex digits (64 random bits): batch ids ("b") and the service's resource ids. Ids only need
/// to be unique, not reproducible, so the generator is seeded from the system; primary keys stand behind the odds.
std::string NewRandomId(const std::string& prefix);

/// A batch as a store holds it: what Storage::AppendMeasurements' rules compare and return.
struct StoredBatch {
  std::string batch_id;
  std::string content_hash;
  std::string role;
  std::int64_t first_sequence = 0;
  std::int64_t count = 0;
};
/// Storage::AppendMeasurements' rule for a request id used before: `earlier` is its batch, the campaign holds
/// `total` measurements. The same content and role is that batch replayed (nothing written); anything else is
/// kAlreadyExists, naming the request id.
BatchResult ReplayBatch(const std::string& campaign_id, const std::string& request_id, const std::string& content_hash,
                        const std::string& role, const StoredBatch& earlier, std::int64_t total);
/// A new batch of `count` measurements with `content_hash` and `role`, for a campaign holding `total`: a fresh id
/// ("b-..."), its first sequence total + 1 (sequences are dense from 1).
StoredBatch NewBatch(const std::string& content_hash, const std::string& role, std::int64_t total, std::int64_t count);
/// The result of `batch` appended under `request_id` to a campaign that held `total_before` measurements.
BatchResult AppendedBatch(const std::string& campaign_id, const std::string& request_id, const StoredBatch& batch,
                          std::int64_t total_before);
/// Storage::Update's rule: throws kVersionConflict if `expected_version` > 0 and is not the stored `version`.
void CheckVersion(const std::string& collection, const std::string& id, std::int64_t version,
                  std::int64_t expected_version);
/// Throws kResourceExhausted if `count` more measurements would take a campaign holding `total` beyond
/// `max_campaign_total` (0: no limit).
void CheckCampaignTotal(const std::string& campaign_id, std::int64_t total, std::int64_t count,
                        std::int64_t max_campaign_total);

/// Every password a database URL holds (in its user information or a password parameter), as written and
/// percent-decoded as libpq reads it, so that messages echoing part of the URL (libpq's among them) can be
/// scrubbed of them.
std::vector<std::string> PasswordsIn(const std::string& url);
/// `text` with every non-empty string of `secrets` replaced by "***".
std::string Scrub(std::string text, std::vector<std::string> secrets);

}  // namespace robocal::server
