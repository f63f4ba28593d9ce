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

/// The error of a request_id used before for a batch of other content or role (kAlreadyExists).
StorageError BatchConflict(const std::string& campaign_id, const std::string& request_id);
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
