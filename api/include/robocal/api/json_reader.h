// Reading request JSON field by field with a path for every value, so that each problem is reported as
// {field, reason} (e.g. "measurements[3].joints: expected 6 values, got 5") and all of them are collected.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "robocal/api/error.h"
#include "robocal/api/wire.h"

namespace robocal::api {

/// "a" + "b" -> "a.b"; "" + "b" -> "b".
std::string JoinPath(const std::string& path, const std::string& key);
/// "a" + 3 -> "a[3]".
std::string IndexPath(const std::string& path, std::size_t index);

/// Objects and arrays in a request nest at most this deep (the deepest real request nests 5 levels).
inline constexpr std::size_t kMaxJsonDepth = 32;

/// Parses request text. Malformed JSON (or a body that is not an object) throws ApiError(kInvalidArgument)
/// with the byte offset of the problem; a key repeated within one object is refused with its path (the parser
/// alone would keep the last one silently); nesting deeper than kMaxJsonDepth is refused.
/// Arrays and objects with more than `max_elements` elements are refused (with their path) before any value is
/// built: an 8 MB body of small numbers would otherwise cost about 25 times its size as parsed values.
nlohmann::json ParseBody(const std::string& body, std::size_t max_elements = SIZE_MAX);

/// Reads the members of one JSON object. Every getter records a violation in `problems` and returns false
/// (leaving *out untouched) when the member is missing (if required), of the wrong type, non-finite or out of
/// range. Optional members keep their default when absent.
class ObjectReader {
 public:
  /// If `value` is not an object, records "expected an object" and every getter returns false.
  ObjectReader(const nlohmann::json& value, std::string path, Problems* problems);

  bool ok() const { return object_ != nullptr; }
  const std::string& path() const { return path_; }
  bool Has(const std::string& key) const;
  /// The member, or nullptr if absent.
  const nlohmann::json* Get(const std::string& key) const;

  bool String(const std::string& key, bool required, std::string* out, std::size_t max_length = 256);
  bool Bool(const std::string& key, bool required, bool* out);
  /// A finite number within [min, max].
  bool Number(const std::string& key, bool required, double* out, double min = -1e300, double max = 1e300);
  /// An integer within [min, max] (JSON numbers with a fraction are rejected).
  bool Int(const std::string& key, bool required, std::int64_t* out, std::int64_t min, std::int64_t max);
  bool Int(const std::string& key, bool required, int* out, int min, int max);
  /// A string from `allowed`.
  bool Enum(const std::string& key, bool required, const std::vector<std::string>& allowed, std::string* out);
  /// One of a wire enum's names (wire.h's table for E).
  template <typename E>
  bool Enum(const std::string& key, bool required, E* out) {
    std::string text;
    if (!Enum(key, required, WireNames<E>(), &text)) return false;
    return FromWireName(text, out);
  }
  /// An array of finite numbers with a size in [min_size, max_size].
  bool Numbers(const std::string& key, bool required, std::vector<double>* out, std::size_t min_size,
               std::size_t max_size);
  /// An array of exactly `size` finite numbers.
  bool FixedNumbers(const std::string& key, bool required, double* out, std::size_t size);
  /// An array with a size in [min_size, max_size]; returns its elements (nullptr on failure).
  const nlohmann::json* Array(const std::string& key, bool required, std::size_t min_size, std::size_t max_size);

  /// Records "unknown field" for members not in `known` (catches misspelt option names); a shape with a field
  /// table passes WireFieldNames<T>() (wire.h).
  void RejectUnknown(std::initializer_list<const char*> known);
  void RejectUnknown(std::span<const char* const> known);

 private:
  const nlohmann::json* Member(const std::string& key, bool required);

  const nlohmann::json* object_ = nullptr;
  std::string path_;
  Problems* problems_;
};

/// A finite number from a JSON value (records a violation at `path` otherwise).
bool ReadFiniteNumber(const nlohmann::json& value, const std::string& path, Problems* problems, double* out);
/// An array of finite numbers at `path` with a size in [min_size, max_size].
bool ReadNumberArray(const nlohmann::json& value, const std::string& path, Problems* problems,
                     std::vector<double>* out, std::size_t min_size, std::size_t max_size);

}  // namespace robocal::api
