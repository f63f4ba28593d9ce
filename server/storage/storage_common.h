// What the storage implementations share and the service does not see.
#pragma once

#include <string>

namespace robocal::server {

/// A batch id ("b-" and 16 hex digits, 64 random bits). Batch ids only need to be unique, not reproducible, so
/// the generator is seeded from the system; the primary key on batch_id stands behind the odds.
std::string NewBatchId();

}  // namespace robocal::server
