// Text from a request made safe to echo: in error messages, error bodies and log lines.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace robocal::api {

/// `text` as valid UTF-8 without control characters, at most `max_bytes` long (plus "..." when cut): every
/// byte that is not part of a well-formed UTF-8 sequence, and every control character (U+0000..U+001F,
/// U+007F), becomes the four characters "\xNN" (NN its hex value). Idempotent. Request bytes (paths, ids,
/// the JSON parser's "last read" text) pass through here before they reach a message, so an error body can
/// always be serialised and a log line never carries terminal escapes.
std::string SafeText(std::string_view text, std::size_t max_bytes = 1024);

/// True if `text` is well-formed UTF-8 (RFC 3629: no overlong forms, no surrogates, nothing above U+10FFFF).
bool IsValidUtf8(std::string_view text);

}  // namespace robocal::api
