// Reading request JSON field by field with a path for every value, so that each problem is reported as
// {field, reason} (e.g. "measurements[3].joints: expected 6 values, got 5") and all of them are collected.
#pragma once

#include <algorithm>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

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
  Problems* problems() const { return problems_; }
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

// ------------------------------------------------------------------------------------------------ by the table

/// Reads the members of `*out` a request may set, by its field table (wire.h): each Field row that is not
/// kServerOnly, not Apart(), and whose When holds of the members read so far, by its type, with its RequestRule
/// (range, size, required) and its Rule; members of a shape with a table are read by that table, recursively;
/// absent members keep their defaults. Computed and Nested rows are the parser's own. Every problem is recorded
/// with its path. Does not reject unknown keys (the parser does, once it has read its Apart rows).
template <typename T>
void ReadRequest(ObjectReader& r, T* out);

/// An object at `path` read by ReadRequest, its unknown keys rejected, and then the table's `static void
/// CheckRequest(const T&, const std::string& path, Problems*)` if it has one (a rule across fields). True when no
/// problem was recorded.
template <typename T>
bool ReadRequestObject(const nlohmann::json& value, const std::string& path, Problems* problems, T* out);

/// A finite number from a JSON value (records a violation at `path` otherwise).
bool ReadFiniteNumber(const nlohmann::json& value, const std::string& path, Problems* problems, double* out);
/// An array of finite numbers at `path` with a size in [min_size, max_size].
bool ReadNumberArray(const nlohmann::json& value, const std::string& path, Problems* problems,
                     std::vector<double>* out, std::size_t min_size, std::size_t max_size);

namespace detail {

template <typename M, typename = void>
inline constexpr bool kHasRequestReader = false;
template <typename M>
inline constexpr bool kHasRequestReader<M, std::void_t<decltype(&RequestReader<M>::Read)>> = true;
template <typename M>
inline constexpr bool kAlwaysFalse = false;
template <typename M>
inline constexpr bool kIsNumberArray = false;
template <std::size_t N>
inline constexpr bool kIsNumberArray<std::array<double, N>> = true;
// An element of a list ReadRequest reads one by one: a shape, or a fixed-size number array (orientations as
// [r, p, y]).
template <typename E>
inline constexpr bool kIsElement = kHasRequestReader<E> || kHasWireFields<E> || kIsNumberArray<E>;
template <typename M>
inline constexpr bool kIsElementList = false;
template <typename E>
inline constexpr bool kIsElementList<std::vector<E>> = kIsElement<E>;

/// "must be in [min, max], got x" at `path` when x is outside the rule's range.
bool InRange(double x, const RequestRule& rule, const std::string& path, Problems* problems);
/// InRange of each value, at path[i]; true when all are.
template <typename Values>
bool InRanges(const Values& values, const RequestRule& rule, const std::string& path, Problems* problems) {
  bool ok = true;
  for (std::size_t i = 0; i < values.size(); ++i) ok = InRange(values[i], rule, IndexPath(path, i), problems) && ok;
  return ok;
}
/// The most elements of a list (a row's own size, else the largest list the server takes by default).
inline std::size_t MaxElements(const RequestRule& rule) { return rule.max_size > 0 ? rule.max_size : 10000; }

// One element (kIsElement) at `path`: a shape by its reader or table, a number array by its size and the rule's
// range. True when *out was set.
template <typename E>
bool ReadRequestElement(const nlohmann::json& value, const std::string& path, const RequestRule& rule,
                        Problems* problems, E* out) {
  if constexpr (kIsNumberArray<E>) {
    std::vector<double> numbers;
    if (!ReadNumberArray(value, path, problems, &numbers, out->size(), out->size()) ||
        !InRanges(numbers, rule, path, problems)) {
      return false;
    }
    std::copy(numbers.begin(), numbers.end(), out->begin());
    return true;
  } else if constexpr (kHasRequestReader<E>) {
    return RequestReader<E>::Read(value, path, problems, out);
  } else {
    return ReadRequestObject(value, path, problems, out);
  }
}

// One member's value under `key`, by its type (see ReadRequest). True when *out was set.
template <typename M>
bool ReadRequestValue(ObjectReader& r, const char* key, const RequestRule& rule, M* out) {
  Problems* problems = r.problems();
  if constexpr (IsOptional<M>::value) {
    typename M::value_type value{};
    if (!ReadRequestValue(r, key, rule, &value)) return false;
    *out = std::move(value);
    return true;
  } else if constexpr (std::is_same_v<M, double>) {
    return r.Number(key, rule.required, out, rule.min, rule.max);
  } else if constexpr (std::is_same_v<M, bool>) {
    return r.Bool(key, rule.required, out);
  } else if constexpr (kIsWireEnum<M>) {
    return r.Enum(key, rule.required, out);
  } else if constexpr (std::is_integral_v<M>) {
    // Integers the type holds, within the rule's range (unsigned ones up to INT64_MAX, JSON's integers).
    const double lo = std::max(rule.min, static_cast<double>(std::numeric_limits<M>::lowest()));
    const double hi = std::min({rule.max, static_cast<double>(std::numeric_limits<M>::max()),
                                static_cast<double>(std::numeric_limits<std::int64_t>::max())});
    std::int64_t value = 0;
    const std::int64_t min = lo <= -9.2e18 ? std::numeric_limits<std::int64_t>::min() : static_cast<std::int64_t>(lo);
    const std::int64_t max = hi >= 9.2e18 ? std::numeric_limits<std::int64_t>::max() : static_cast<std::int64_t>(hi);
    if (!r.Int(key, rule.required, &value, min, max)) return false;
    *out = static_cast<M>(value);
    return true;
  } else if constexpr (std::is_same_v<M, std::string>) {
    return r.String(key, rule.required, out, rule.max_size > 0 ? rule.max_size : 256);
  } else if constexpr (kIsNumberArray<M>) {
    M values{};
    if (!r.FixedNumbers(key, rule.required, values.data(), values.size()) ||
        !InRanges(values, rule, JoinPath(r.path(), key), problems)) {
      return false;
    }
    *out = values;
    return true;
  } else if constexpr (std::is_same_v<M, std::vector<double>>) {
    std::vector<double> values;
    if (!r.Numbers(key, rule.required, &values, rule.min_size, MaxElements(rule)) ||
        !InRanges(values, rule, JoinPath(r.path(), key), problems)) {
      return false;
    }
    *out = std::move(values);
    return true;
  } else if constexpr (kHasRequestReader<M> || kHasWireFields<M>) {
    const nlohmann::json* value = r.Get(key);
    if (value == nullptr) {
      if (rule.required && r.ok()) problems->Add(JoinPath(r.path(), key), "required");
      return false;
    }
    M read{};
    if (!ReadRequestElement(*value, JoinPath(r.path(), key), rule, problems, &read)) return false;
    *out = std::move(read);
    return true;
  } else if constexpr (kIsElementList<M>) {
    const nlohmann::json* list = r.Array(key, rule.required, rule.min_size, MaxElements(rule));
    if (list == nullptr) return false;
    M values(list->size());
    bool ok = true;
    for (std::size_t i = 0; i < list->size(); ++i) {
      ok = ReadRequestElement((*list)[i], IndexPath(JoinPath(r.path(), key), i), rule, problems, &values[i]) && ok;
    }
    if (ok) *out = std::move(values);
    return ok;
  } else {
    static_assert(kAlwaysFalse<M>, "unreachable: ReadRequestRow checks kReadable");
    return false;
  }
}

// Whether ReadRequestValue reads a member of type M.
template <typename M>
constexpr bool Readable() {
  if constexpr (IsOptional<M>::value) {
    return Readable<typename M::value_type>();
  } else {
    return std::is_arithmetic_v<M> || kIsWireEnum<M> || std::is_same_v<M, std::string> || kIsNumberArray<M> ||
           std::is_same_v<M, std::vector<double>> || kHasRequestReader<M> || kHasWireFields<M> || kIsElementList<M>;
  }
}
// A row ReadRequest reads, or one it may leave: every Field row a request may set has a readable type or is
// Apart() (checked at compile time, so that a new member of a type the reader does not know is not silently
// left unread).
template <typename S, typename M>
constexpr bool RowReadOrLeft(const Field<S, M>& row) {
  return Readable<M>() || row.request.apart || row.presence == Presence::kServerOnly;
}
template <typename Row>
requires(!FieldRow<Row>) constexpr bool RowReadOrLeft(const Row&) { return true; }

template <typename T, typename S, typename M>
void ReadReadableRow(ObjectReader& r, T* shape, const Field<S, M>& row) {
  if (row.presence == Presence::kServerOnly || row.request.apart) return;
  if (row.when && !row.when(*shape)) return;
  M* member = &(shape->*(row.member));
  if (ReadRequestValue(r, row.name, row.request, member) && row.valid && !row.valid(*member)) {
    r.problems()->Add(JoinPath(r.path(), row.name), row.invalid_reason);
  }
}

template <typename T, typename S, typename M>
void ReadRequestRow(ObjectReader& r, T* shape, const Field<S, M>& row) {
  if constexpr (!Readable<M>()) {
    return;
  } else {
    ReadReadableRow(r, shape, row);
  }
}
template <typename T, typename Row>
requires(!FieldRow<Row>) void ReadRequestRow(ObjectReader&, T*, const Row&) {
}  // Computed and Nested rows: the parser's own

}  // namespace detail

namespace detail {
// Row I of T's table, unless it is Apart() or kServerOnly: decided at compile time, so that the reading of a
// member the parser reads itself is never instantiated (its type may be one ReadRequest cannot read).
template <typename T, std::size_t I>
void ReadRowAt(ObjectReader& r, T* out) {
  constexpr const auto& row = std::get<I>(WireFields<T>::fields);
  if constexpr (requires { row.request; }) {
    if constexpr (!row.request.apart && row.presence != Presence::kServerOnly) ReadRequestRow(r, out, row);
  }
}
template <typename T, std::size_t... I>
void ReadRows(ObjectReader& r, T* out, std::index_sequence<I...>) {
  (ReadRowAt<T, I>(r, out), ...);
}
}  // namespace detail

template <typename T>
void ReadRequest(ObjectReader& r, T* out) {
  static_assert(
      std::apply([](const auto&... row) { return (detail::RowReadOrLeft(row) && ...); }, WireFields<T>::fields),
      "a row of this table has a type ReadRequest cannot read: mark it Apart() and read it in the "
      "parser, or give the type a RequestReader");
  detail::ReadRows(r, out,
                   std::make_index_sequence<std::tuple_size_v<std::remove_cvref_t<decltype(WireFields<T>::fields)>>>{});
}

template <typename T>
bool ReadRequestObject(const nlohmann::json& value, const std::string& path, Problems* problems, T* out) {
  const std::size_t before = problems->size();
  ObjectReader r(value, path, problems);
  if (!r.ok()) return false;
  ReadRequest(r, out);
  r.RejectUnknown(WireFieldNames<T>());
  if constexpr (requires { WireFields<T>::CheckRequest(*out, path, problems); }) {
    if (problems->size() == before) WireFields<T>::CheckRequest(*out, path, problems);
  }
  return problems->size() == before;
}

}  // namespace robocal::api
