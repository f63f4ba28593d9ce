// One declaration per wire field. A shape that lists its fields in a WireFields table gets its to_json, its strict
// from_json and the allowed keys of its request parser from that one list, so a field is declared in three
// places: the struct's member, its row in the table, and the OpenAPI spec (tests/service/wire_test.cc checks the
// spec against the shapes). docs/architecture.md, "How to add a field", walks through it.
//
//   struct BatchResult { std::string campaign; std::int64_t count = 0; ... };
//   template <>
//   struct WireFields<BatchResult> {
//     static constexpr auto fields = std::make_tuple(Field{"campaign", &BatchResult::campaign},
//                                                    Field{"count", &BatchResult::count}, ...);
//   };
//
// A shape whose members do not map one to one onto its keys (a pose read in either of two forms, a struct
// flattened into its owner) keeps hand-written to_json / from_json.
#pragma once

#include <cstddef>
#include <optional>
#include <tuple>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>

#include "robocal/api/wire.h"

namespace robocal::api {

/// How a member appears on the wire.
enum class Presence {
  /// Always written (an unset optional as null); required when read.
  kRequired,
  /// Written only when it is not its type's empty value (an empty string or list, an unset optional, false, 0);
  /// optional when read (absent keeps the member's default).
  kOmitEmpty,
  /// Always written; optional when read (absent or null keeps the member's default): a field that older servers
  /// and stored documents do not have.
  kOptionalOnRead,
};

/// A member `member` of S under the key `name`.
template <typename S, typename M>
struct Field {
  const char* name;
  M S::*member;
  Presence presence = Presence::kRequired;
};

/// Specialised for each shape with a field table: `static constexpr auto fields = std::make_tuple(Field{...}, ...)`,
/// in the order the keys are written. A shape that extends another (a resource and its stored form) may join its
/// base's table with std::tuple_cat.
template <typename T>
struct WireFields;

template <typename T, typename = void>
inline constexpr bool kHasWireFields = false;
template <typename T>
inline constexpr bool kHasWireFields<T, std::void_t<decltype(WireFields<T>::fields)>> = true;

namespace detail {

template <typename M>
nlohmann::json FieldValue(const M& value) {
  if constexpr (std::is_same_v<M, double>) {
    return Num(value);
  } else if constexpr (IsOptional<M>::value) {
    return value ? FieldValue(*value) : nlohmann::json();
  } else {
    return nlohmann::json(value);
  }
}

template <typename M>
bool IsEmptyValue(const M& value) {
  if constexpr (IsOptional<M>::value) {
    return !value.has_value();
  } else if constexpr (std::is_arithmetic_v<M>) {
    return value == M{};
  } else if constexpr (requires { value.empty(); }) {
    return value.empty();
  } else {
    return false;
  }
}

}  // namespace detail

/// Writes every field of `value` (by its table) into the object `j`.
template <typename T>
void WriteFields(nlohmann::json& j, const T& value) {
  if (!j.is_object()) j = nlohmann::json::object();
  std::apply(
      [&](const auto&... field) {
        (
            [&] {
              const auto& member = value.*(field.member);
              if (field.presence == Presence::kOmitEmpty && detail::IsEmptyValue(member)) return;
              j[field.name] = detail::FieldValue(member);
            }(),
            ...);
      },
      WireFields<T>::fields);
}

/// Reads every field of `*out` (by its table) from the object `j`: WireError naming the first missing required or
/// mistyped member. Members not in the table are ignored (a newer server may add fields).
template <typename T>
void ReadFields(const nlohmann::json& j, T* out) {
  const WireReader r(j);
  std::apply(
      [&](const auto&... field) {
        ((field.presence == Presence::kRequired ? r.Required(field.name, &(out->*(field.member)))
                                                : static_cast<void>(r.Optional(field.name, &(out->*(field.member))))),
         ...);
      },
      WireFields<T>::fields);
}

/// The keys of T's table, in order: the allowed keys of its request parser (ObjectReader::RejectUnknown).
template <typename T>
std::vector<const char*> WireFieldNames() {
  return std::apply([](const auto&... field) { return std::vector<const char*>{field.name...}; }, WireFields<T>::fields);
}

/// to_json / from_json of every shape with a table (found by nlohmann::json through argument-dependent lookup).
template <typename T>
  requires kHasWireFields<T>
void to_json(nlohmann::json& j, const T& value) {
  j = nlohmann::json::object();
  WriteFields(j, value);
}
template <typename T>
  requires kHasWireFields<T>
void from_json(const nlohmann::json& j, T& value) {
  ReadFields(j, &value);
}

}  // namespace robocal::api
