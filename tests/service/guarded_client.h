// An HTTP client of a test's server on 127.0.0.1 whose read and write limits are hang guards (120 s) rather than
// the library's 5 s, which a busy machine can overrun.
#pragma once

#include <httplib.h>

namespace robocal::server::testing {

inline httplib::Client GuardedClient(int port) {
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(120, 0);
  client.set_write_timeout(120, 0);
  return client;
}

}  // namespace robocal::server::testing
