// The building blocks every wire shape of the robocal HTTP API (v1) is made of: strict reading of responses and
// stored documents (WireReader), one name table per enum, numbers that may be null, poses, identifiers, the
// server's size limits. Wire units are mm and degrees; names carry their unit where a reader could guess wrong.
//
// Each resource family has its own header (robots.h, plans.h, campaigns.h, calibration.h, operations.h,
// error.h, health.h) with, per shape, one struct and its field table ("field tables" below), which gives its
// to_json / from_json (found by nlohmann::json through argument-dependent lookup, so `nlohmann::json(x)` and
// `j.get<T>()` work). Requests also have a validating parser (`Parse*Request`) that collects every problem with
// its field; from_json is the strict structural reader of what a server or a stored document wrote: a missing
// required field is an error naming it.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "robocal/api/error.h"
#include "robocal/core/cell.h"
#include "robocal/core/compensation.h"
#include "robocal/core/error_model.h"
#include "robocal/core/observability.h"
#include "robocal/core/planning.h"
#include "robocal/core/robot_model.h"
#include "robocal/core/termination.h"
#include "robocal/core/transforms.h"
#include "robocal/core/units.h"

namespace robocal::api {

// ------------------------------------------------------------------------------------------------ enums

/// The API's own enum-like fields (the core has no such enums).
enum class Optimiser { kSolisWets, kRandom, kExchange };
/// What a measurement is for: the fit, the held-out evaluation, or an ISO 9283 test (docs/iso9283.md).
enum class MeasurementRole { kCalibration, kValidation, kTest };
enum class OperationKind { kPlan, kFit };
enum class OperationState { kRunning, kSucceeded, kFailed, kCancelled };
/// What a fit estimates: every identifiable parameter, or the base and the tool frames only.
enum class FitScope { kAll, kFrames };

/// The wire names of an enum: one table per enum, specialised below. Core enums take their names from the
/// core's ToString, so that the wire and the core's reports agree.
template <typename E>
struct EnumTable;

#define ROBOCAL_API_ENUM_TABLE(E, ...)                               \
  template <>                                                        \
  struct EnumTable<E> {                                              \
    static constexpr auto values = std::to_array<E>({__VA_ARGS__}); \
    static const char* Name(E value);                                \
  }
ROBOCAL_API_ENUM_TABLE(MeasurementType, MeasurementType::kPosition, MeasurementType::kPositionAxis,
                       MeasurementType::kPose);
ROBOCAL_API_ENUM_TABLE(Termination, Termination::kConvergence, Termination::kNoConvergence, Termination::kDegraded,
                       Termination::kFailure);
ROBOCAL_API_ENUM_TABLE(JointType, JointType::kRevolute, JointType::kPrismatic);
ROBOCAL_API_ENUM_TABLE(GeometryConvention, GeometryConvention::kStandardDh, GeometryConvention::kModifiedDh,
                       GeometryConvention::kTransform);
ROBOCAL_API_ENUM_TABLE(TargetFrame, TargetFrame::kTracker, TargetFrame::kBase);
ROBOCAL_API_ENUM_TABLE(ColumnScaling, ColumnScaling::kColumnNorm, ColumnScaling::kExpectedDeviation,
                       ColumnScaling::kNone);
ROBOCAL_API_ENUM_TABLE(ObservabilityIndex, ObservabilityIndex::kConditionNumber, ObservabilityIndex::kO1,
                       ObservabilityIndex::kO2, ObservabilityIndex::kO3, ObservabilityIndex::kO4,
                       ObservabilityIndex::kO5, ObservabilityIndex::kLogDet, ObservabilityIndex::kPredictedError);
ROBOCAL_API_ENUM_TABLE(Optimiser, Optimiser::kSolisWets, Optimiser::kRandom, Optimiser::kExchange);
ROBOCAL_API_ENUM_TABLE(MeasurementRole, MeasurementRole::kCalibration, MeasurementRole::kValidation,
                       MeasurementRole::kTest);
ROBOCAL_API_ENUM_TABLE(OperationKind, OperationKind::kPlan, OperationKind::kFit);
ROBOCAL_API_ENUM_TABLE(FitScope, FitScope::kAll, FitScope::kFrames);
ROBOCAL_API_ENUM_TABLE(MalformedCandidates, MalformedCandidates::kThrow, MalformedCandidates::kReject);
ROBOCAL_API_ENUM_TABLE(OperationState, OperationState::kRunning, OperationState::kSucceeded, OperationState::kFailed,
                       OperationState::kCancelled);
ROBOCAL_API_ENUM_TABLE(CellRule, CellRule::kJointRange, CellRule::kObstacle, CellRule::kSelfCollision,
                       CellRule::kDistance, CellRule::kIncidence, CellRule::kBeam);
ROBOCAL_API_ENUM_TABLE(Status, Status::kInvalidArgument, Status::kFailedPrecondition, Status::kNotFound,
                       Status::kAlreadyExists, Status::kAborted, Status::kUnauthenticated, Status::kPermissionDenied,
                       Status::kResourceExhausted, Status::kInternal, Status::kUnavailable, Status::kDeadlineExceeded);
#undef ROBOCAL_API_ENUM_TABLE

template <typename E, typename = void>
inline constexpr bool kIsWireEnum = false;
template <typename E>
inline constexpr bool kIsWireEnum<E, std::void_t<decltype(EnumTable<E>::values)>> = true;

/// The wire name of `value`.
template <typename E>
const char* WireName(E value) {
  return EnumTable<E>::Name(value);
}
/// Every wire name of E, in table order (for ObjectReader::Enum and error messages).
template <typename E>
std::vector<std::string> WireNames() {
  std::vector<std::string> names;
  for (E v : EnumTable<E>::values) names.emplace_back(EnumTable<E>::Name(v));
  return names;
}
/// The value named `text`; false if there is none.
template <typename E>
bool FromWireName(const std::string& text, E* out) {
  for (E v : EnumTable<E>::values) {
    if (text == EnumTable<E>::Name(v)) {
      *out = v;
      return true;
    }
  }
  return false;
}

// ------------------------------------------------------------------------------------------------ reading

/// A response or stored document that does not have the shape its type requires: `path` names the member
/// ("summary.termination", "joints[2].min_deg"), `reason` what is wrong with it.
class WireError : public std::runtime_error {
 public:
  WireError(std::string path, std::string reason);
  const std::string& path() const { return path_; }
  const std::string& reason() const { return reason_; }

 private:
  std::string path_;
  std::string reason_;
};

/// "a" + "b" -> "a.b"; "a" + "[2].c" -> "a[2].c"; "" + "b" -> "b".
std::string WirePath(const std::string& path, const std::string& member);

/// Reads `value` at `path` into *out: numbers (null is NaN: non-finite numbers are written as null), integers
/// (no fraction, within the type's range), strings, booleans, wire enums, vectors, fixed arrays, optionals (null
/// or absent is nullopt) and every type with a from_json. Throws WireError naming the path.
template <typename T>
void ReadWire(const nlohmann::json& value, const std::string& path, T* out);

/// Reads the members of one object of a response or stored document. Members it does not ask for are ignored
/// (a newer server may add fields); asked-for members must have their type.
class WireReader {
 public:
  /// Throws WireError if `value` is not an object.
  WireReader(const nlohmann::json& value, std::string path = "");
  /// The member `key`; WireError "required" if absent.
  template <typename T>
  void Required(const char* key, T* out) const {
    ReadWire(Member(key), WirePath(path_, key), out);
  }
  /// The member `key` if present (and not null); false otherwise, *out untouched.
  template <typename T>
  bool Optional(const char* key, T* out) const {
    const auto it = object_->find(key);
    if (it == object_->end() || it->is_null()) return false;
    ReadWire(*it, WirePath(path_, key), out);
    return true;
  }
  bool Has(const char* key) const { return object_->contains(key); }
  const nlohmann::json& Member(const char* key) const;
  const std::string& path() const { return path_; }

 private:
  const nlohmann::json* object_;
  std::string path_;
};

namespace detail {
template <typename T>
struct IsVector : std::false_type {};
template <typename T>
struct IsVector<std::vector<T>> : std::true_type {};
// An object of names to values (a program's files, its tools): std::map keyed by string.
template <typename T>
struct IsStringMap : std::false_type {};
template <typename V>
struct IsStringMap<std::map<std::string, V>> : std::true_type {};
template <typename T>
struct IsOptional : std::false_type {};
template <typename T>
struct IsOptional<std::optional<T>> : std::true_type {};
template <typename T>
struct IsArray : std::false_type {};
template <typename T, std::size_t N>
struct IsArray<std::array<T, N>> : std::true_type {};
[[noreturn]] void ThrowWire(const std::string& path, const std::string& reason);
std::string IndexPathOf(const std::string& path, std::size_t index);
}  // namespace detail

template <typename T>
void ReadWire(const nlohmann::json& value, const std::string& path, T* out) {
  if constexpr (std::is_same_v<T, double>) {
    if (value.is_null()) {
      *out = std::numeric_limits<double>::quiet_NaN();
    } else if (value.is_number()) {
      *out = value.get<double>();
    } else {
      detail::ThrowWire(path, "expected a number");
    }
  } else if constexpr (std::is_same_v<T, bool>) {
    if (!value.is_boolean()) detail::ThrowWire(path, "expected true or false");
    *out = value.get<bool>();
  } else if constexpr (std::is_integral_v<T>) {
    if (!value.is_number_integer()) detail::ThrowWire(path, "expected an integer");
    if (value.is_number_unsigned()) {
      const auto v = value.get<std::uint64_t>();
      if (v > static_cast<std::uint64_t>(std::numeric_limits<T>::max())) detail::ThrowWire(path, "out of range");
      *out = static_cast<T>(v);
    } else {
      const auto v = value.get<std::int64_t>();
      if (v < static_cast<std::int64_t>(std::numeric_limits<T>::min()) ||
          (v > 0 && static_cast<std::uint64_t>(v) > static_cast<std::uint64_t>(std::numeric_limits<T>::max()))) {
        detail::ThrowWire(path, "out of range");
      }
      *out = static_cast<T>(v);
    }
  } else if constexpr (std::is_same_v<T, std::string>) {
    if (!value.is_string()) detail::ThrowWire(path, "expected a string");
    *out = value.get<std::string>();
  } else if constexpr (kIsWireEnum<T>) {
    if (!value.is_string()) detail::ThrowWire(path, "expected a string");
    if (!FromWireName(value.get<std::string>(), out)) {
      std::string names;
      for (const std::string& n : WireNames<T>()) names += (names.empty() ? "" : ", ") + n;
      detail::ThrowWire(path, "unknown value \"" + value.get<std::string>() + "\" (expected one of " + names + ")");
    }
  } else if constexpr (detail::IsOptional<T>::value) {
    if (value.is_null()) {
      out->reset();
    } else {
      typename T::value_type v{};
      ReadWire(value, path, &v);
      *out = std::move(v);
    }
  } else if constexpr (detail::IsVector<T>::value) {
    if (!value.is_array()) detail::ThrowWire(path, "expected an array");
    T list(value.size());
    for (std::size_t i = 0; i < value.size(); ++i) ReadWire(value[i], detail::IndexPathOf(path, i), &list[i]);
    *out = std::move(list);
  } else if constexpr (detail::IsArray<T>::value) {
    if (!value.is_array() || value.size() != std::tuple_size_v<T>) {
      detail::ThrowWire(path, "expected an array of " + std::to_string(std::tuple_size_v<T>) + " values");
    }
    for (std::size_t i = 0; i < value.size(); ++i) ReadWire(value[i], detail::IndexPathOf(path, i), &(*out)[i]);
  } else if constexpr (detail::IsStringMap<T>::value) {
    if (!value.is_object()) detail::ThrowWire(path, "expected an object");
    T map;
    for (const auto& [key, member] : value.items()) ReadWire(member, WirePath(path, key), &map[key]);
    *out = std::move(map);
  } else if constexpr (std::is_same_v<T, nlohmann::json>) {
    *out = value;
  } else {
    // A struct: its from_json reports paths relative to `value`.
    try {
      from_json(value, *out);
    } catch (const WireError& e) {
      throw WireError(WirePath(path, e.path()), e.reason());
    }
  }
}

/// Reads a whole document of type T (a response body or a stored document).
template <typename T>
T FromWire(const nlohmann::json& value) {
  T out{};
  ReadWire(value, "", &out);
  return out;
}

// ------------------------------------------------------------------------------------------------ writing

/// A number, or null if not finite (JSON has no Inf or NaN: an infinite condition number is written as null).
nlohmann::json Num(double value);
nlohmann::json Nums(const std::vector<double>& values);

}  // namespace robocal::api

// Wire enums serialise as their names wherever nlohmann::json meets them (reading goes through ReadWire, which
// names the path of an unknown value).
namespace nlohmann {
template <typename E>
struct adl_serializer<E, std::enable_if_t<robocal::api::kIsWireEnum<E>>> {
  static void to_json(json& j, E value) { j = robocal::api::WireName(value); }
  static void from_json(const json& j, E& value) { robocal::api::ReadWire(j, "", &value); }
};
}  // namespace nlohmann

namespace robocal::api {

// ------------------------------------------------------------------------------------------------ field tables

// One declaration per wire field. A shape that lists its fields in a WireFields table gets its to_json, its
// strict from_json, the allowed keys and the reading of its request parser (ReadRequest, json_reader.h: type,
// range, size, required) from that one list, so a field is declared in three places: the struct's member, its
// row in the table, and the OpenAPI spec's description of it (tests/service/spec_test.cc checks the spec's types,
// bounds and required lists against the tables). docs/architecture.md, "How to add a field", walks through it.
//
//   struct BatchResult { std::string campaign; std::int64_t count = 0; ... };
//   template <>
//   struct WireFields<BatchResult> {
//     static constexpr auto fields = std::make_tuple(Field{"campaign", &BatchResult::campaign},
//                                                    Field{"count", &BatchResult::count}, ...);
//   };
//
// A row is one of:
//   - Field{key, &S::member[, presence]}: the member as it is (its own to_json / from_json, or its own table);
//   - Field{...}.When(condition): a key that belongs to one form of the shape only (a compensation target's
//     "frame" to a pose target, a joint's "min_deg" to a revolute joint): written when condition(shape) holds,
//     read when it holds of the members read before it (rows are read in table order);
//   - Computed<S>{key, write, read}: a key whose value is not one member as it is (a choice written as a string
//     or an object, a flag by name, a member written in another form): two functions of the whole shape;
//   - Nested{key, std::make_tuple(rows...)}: members of the shape written as one object under `key` (a stored
//     calibration's "state"), always written and required when read.
// A Field row may end in .Core(&CoreType::member[, unit]): the core member it is (CoreToWire, WireToCore). A
// resource that extends a request (CampaignDefinition, RobotJoint) takes the request's rows by ResourceRows.
// A table may also give `static void Check(const S&)`, run after a read: a rule across fields ("robot" or
// "campaign"), throwing WireError.

/// How a member appears on the wire.
enum class Presence {
  /// Always written (an unset optional as null); required when read.
  kRequired,
  /// Written only when it is not its type's empty value (an empty string or list, an unset optional, false, 0, an
  /// array of zeros); optional when read (absent keeps the member's default).
  kOmitEmpty,
  /// Always written; optional when read (absent or null keeps the member's default): a field that older servers
  /// and stored documents do not have.
  kOptionalOnRead,
  /// Always written; when read, absent or null is the type's empty value (false, 0, empty) rather than the
  /// member's default: a switch that older stored documents lack because what it switches on did not exist yet.
  kAbsentIsEmpty,
  /// Written only when set, as kOmitEmpty (a request leaves it to the server); required when read (the resource
  /// the server returns always has it).
  kSetByServer,
  /// Written only when set, as kOmitEmpty, and optional when read, but never sent by a client: the server keeps
  /// it (a stored definition's URDF document, a robot's provenance), so it is not among a request's allowed keys
  /// (WireFieldNames).
  kServerOnly,
};

/// What a request may send under a key, beside its type (ReadRequest, json_reader.h; the OpenAPI spec's
/// minimum, maximum, minItems, maxItems, maxLength and required, which tests/service/spec_test.cc checks against
/// it): a number's range (of each element of a list or array of numbers, and of an integer), a list's size, a
/// string's length, whether a request must send it, and whether its parser reads it apart (a member whose
/// reading needs more than its own value: measurements need the robot's joints).
struct RequestRule {
  /// Beyond +-1e300 is no bound (ObjectReader::Number's defaults): the spec then gives none.
  static constexpr double kNoBound = 1e300;
  double min = -kNoBound;
  double max = kNoBound;
  /// A list's fewest and most elements (0: no own limit below the server's max_array_length); a string's most
  /// characters (0: 256).
  std::size_t min_size = 0;
  std::size_t max_size = 0;
  bool required = false;
  bool apart = false;
};

/// A request member whose reading has rules its field table cannot state (a pose's two orientation forms, a
/// tracker model's pairs): specialise with `static bool Read(const nlohmann::json& value, const std::string& path,
/// Problems* problems, M* out)`, true when *out was set. ReadRequest (json_reader.h) then reads every member of
/// that type with it.
template <typename M>
struct RequestReader;

/// The class a member pointer type points into.
template <typename P>
struct MemberClass;
template <typename C, typename M>
struct MemberClass<M C::*> {
  using type = C;
};

/// How a row's wire value relates to its core member's (Field::Core): the same value, or degrees for the core's
/// radians (wire = core * kDegPerRad, core = wire * kRadPerDeg, each element of an array). kDegForRadDividing
/// converts back by dividing (core = wire / kDegPerRad), as stored fits' model errors have always been read: the
/// two differ in the last bit for some values.
enum class CoreUnit { kSame, kDegForRad, kDegForRadDividing };

template <typename S, typename M, typename C, typename CM>
struct LinkedField;

/// A member `member` of S under the key `name`.
template <typename S, typename M>
struct Field {
  const char* name;
  M S::*member;
  Presence presence = Presence::kRequired;
  /// Null: the key belongs to every form of the shape (see When).
  bool (*when)(const S&) = nullptr;
  /// What a request may send (see RequestRule; the builders below set it).
  RequestRule request{};
  /// A rule of the value a request sends beyond its range, and the reason given when it fails (an id's form).
  bool (*valid)(const M&) = nullptr;
  const char* invalid_reason = nullptr;
  /// How the resource that extends this shape (a request's) writes and reads the row (ResourceRows): by default
  /// always written and required when read, and written in the forms `when` names.
  Presence in_resource = Presence::kRequired;
  bool every_form_in_resource = false;
  /// A key that stored documents written before it existed lack (FillLaterKeys): read there as the member's
  /// default, while replies must have it.
  bool later = false;

  /// The same row for one form of the shape only: written when `condition` holds of the shape, read when it
  /// holds of the members read so far (otherwise the member keeps its default and the key is not read).
  constexpr Field When(bool (*condition)(const S&)) const {
    Field f = *this;
    f.when = condition;
    return f;
  }
  /// A number's range in its wire unit (each element's, for lists and arrays of numbers).
  constexpr Field Range(double min, double max) const {
    Field f = *this;
    f.request.min = min;
    f.request.max = max;
    return f;
  }
  /// A list's fewest and most elements, or (min 0) a string's most characters.
  constexpr Field Size(std::size_t min, std::size_t max) const {
    Field f = *this;
    f.request.min_size = min;
    f.request.max_size = max;
    return f;
  }
  /// A request must send the key.
  constexpr Field Mandatory() const {
    Field f = *this;
    f.request.required = true;
    return f;
  }
  /// The request's parser reads the key itself (ReadRequest leaves it).
  constexpr Field Apart() const {
    Field f = *this;
    f.request.apart = true;
    return f;
  }
  /// A value a request sends must satisfy `rule`; `reason` is given when it does not.
  constexpr Field Rule(bool (*rule)(const M&), const char* reason) const {
    Field f = *this;
    f.valid = rule;
    f.invalid_reason = reason;
    return f;
  }
  /// How the resource that extends this shape has the row (ResourceRows), when not always written.
  constexpr Field InResource(Presence in) const {
    Field f = *this;
    f.in_resource = in;
    return f;
  }
  /// Older stored documents may lack the key (see `later`).
  constexpr Field Later() const {
    Field f = *this;
    f.later = true;
    return f;
  }
  /// The resource writes the row in every form, where the shape itself has it in the forms `When` names (a
  /// joint's centre of mass: a definition gives it with a mass, the robot resource states it always).
  constexpr Field EveryFormInResource() const {
    Field f = *this;
    f.every_form_in_resource = true;
    return f;
  }
  /// The row carries the core member `core` of C (CoreToWire, WireToCore): the one place that says which core
  /// value the key is, and in which unit. Last in a row's chain (it returns the linked row).
  template <typename C, typename CM>
  constexpr LinkedField<S, M, C, CM> Core(CM C::*core, CoreUnit unit = CoreUnit::kSame) const {
    return {*this, core, unit};
  }
};

/// A row linked to a core member (Field::Core): a Field everywhere a row is read, written or checked.
template <typename S, typename M, typename C, typename CM>
struct LinkedField : Field<S, M> {
  CM C::*core;
  CoreUnit unit = CoreUnit::kSame;
};

/// A Field row, linked or not: the overloads for the other rows (Computed, Nested) exclude it, so that a linked
/// row is never taken for one of them.
template <typename Row>
concept FieldRow = requires(const Row& row) {
  row.member;
  row.presence;
};
// Spelt out: clang before 17 does not deduce an aggregate's template arguments from its members.
template <typename S, typename M>
Field(const char*, M S::*) -> Field<S, M>;
template <typename S, typename M>
Field(const char*, M S::*, Presence) -> Field<S, M>;

/// A key written and read by two functions of the whole shape (see above).
template <typename S>
struct Computed {
  const char* name;
  /// The key's value into `*value`; false: the key is left out.
  bool (*write)(const S& shape, nlohmann::json* value);
  /// Reads the key's value (null: the key is absent) into `*shape`; WireError at `path` (the key's) when bad.
  void (*read)(const nlohmann::json* value, const std::string& path, S* shape);
  /// Whether `write` always writes the key (the spec then lists it as required in replies).
  bool always_written = false;
  /// Whether a request must give the key (its parser refuses one without it; the spec lists it as required).
  bool required_in_request = false;
};

/// Rows of the shape written as the object `name` (see above).
template <typename Rows>
struct Nested {
  const char* name;
  Rows rows;
};
template <typename Rows>
Nested(const char*, Rows) -> Nested<Rows>;

/// Specialised for each shape with a field table: `static constexpr auto fields = std::make_tuple(Field{...}, ...)`,
/// in the order the keys are read. A shape that extends another (a resource and its stored form) may join its
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
  } else if constexpr (std::is_same_v<M, std::vector<double>>) {
    return Nums(value);
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
  } else if constexpr (IsArray<M>::value) {
    for (const auto& x : value) {
      if (!IsEmptyValue(x)) return false;
    }
    return true;
  } else if constexpr (requires { value.empty(); }) {
    return value.empty();
  } else {
    return false;
  }
}

// T is S or a shape derived from it (a table may list its base's rows).
template <typename T, typename S, typename M>
void WriteRow(nlohmann::json& j, const T& shape, const Field<S, M>& field) {
  if (field.when && !field.when(shape)) return;
  const M& member = shape.*(field.member);
  const bool omittable = field.presence == Presence::kOmitEmpty || field.presence == Presence::kSetByServer ||
                         field.presence == Presence::kServerOnly;
  if (omittable && IsEmptyValue(member)) return;
  j[field.name] = FieldValue(member);
}

template <typename T, typename S>
void WriteRow(nlohmann::json& j, const T& shape, const Computed<S>& field) {
  nlohmann::json value;
  if (field.write(shape, &value)) j[field.name] = std::move(value);
}

template <typename T, typename S, typename M>
void ReadRow(const WireReader& r, T* shape, const Field<S, M>& field) {
  if (field.when && !field.when(*shape)) return;
  M* member = &(shape->*(field.member));
  switch (field.presence) {
    case Presence::kRequired:
    case Presence::kSetByServer:
      r.Required(field.name, member);
      break;
    case Presence::kOmitEmpty:
    case Presence::kOptionalOnRead:
    case Presence::kServerOnly:
      r.Optional(field.name, member);
      break;
    case Presence::kAbsentIsEmpty:
      if (!r.Optional(field.name, member)) *member = M{};
      break;
  }
}

template <typename T, typename S>
void ReadRow(const WireReader& r, T* shape, const Computed<S>& field) {
  const nlohmann::json* value = r.Has(field.name) ? &r.Member(field.name) : nullptr;
  field.read(value, WirePath(r.path(), field.name), shape);
}

template <typename T, typename Rows>
void WriteRow(nlohmann::json& j, const T& shape, const Nested<Rows>& group) {
  nlohmann::json object = nlohmann::json::object();
  std::apply([&](const auto&... row) { (WriteRow(object, shape, row), ...); }, group.rows);
  j[group.name] = std::move(object);
}

template <typename T, typename Rows>
void ReadRow(const WireReader& r, T* shape, const Nested<Rows>& group) {
  const WireReader object(r.Member(group.name), WirePath(r.path(), group.name));
  std::apply([&](const auto&... row) { (ReadRow(object, shape, row), ...); }, group.rows);
}

}  // namespace detail

template <typename C, typename W>
void CoreToWire(const C& core, W* wire);
template <typename W, typename C>
void WireToCore(const W& wire, C* core);

namespace detail {

template <typename M>
constexpr bool IsDoubleArray() {
  if constexpr (IsArray<M>::value) {
    return std::is_same_v<typename M::value_type, double>;
  }
  return false;
}

template <typename CM, typename M>
void LinkToWire(const CM& core, CoreUnit unit, M* wire) {
  const bool degrees = unit != CoreUnit::kSame;
  if constexpr (std::is_same_v<M, double>) {
    *wire = degrees ? core * kDegPerRad : core;
  } else if constexpr (IsDoubleArray<M>()) {
    for (std::size_t k = 0; k < wire->size(); ++k) {
      (*wire)[k] = degrees ? core[static_cast<Eigen::Index>(k)] * kDegPerRad : core[static_cast<Eigen::Index>(k)];
    }
  } else if constexpr (kHasWireFields<M> && !std::is_same_v<M, CM>) {
    CoreToWire(core, wire);
  } else {
    *wire = core;
  }
}

template <typename CM, typename M>
void LinkToCore(const M& wire, CoreUnit unit, CM* core) {
  const auto back = [unit](double value) {
    return unit == CoreUnit::kDegForRad           ? value * kRadPerDeg
           : unit == CoreUnit::kDegForRadDividing ? value / kDegPerRad
                                                  : value;
  };
  if constexpr (std::is_same_v<M, double>) {
    *core = back(wire);
  } else if constexpr (IsDoubleArray<M>()) {
    for (std::size_t k = 0; k < wire.size(); ++k) (*core)[static_cast<Eigen::Index>(k)] = back(wire[k]);
  } else if constexpr (kHasWireFields<M> && !std::is_same_v<M, CM>) {
    WireToCore(wire, core);
  } else {
    *core = wire;
  }
}

}  // namespace detail

/// Sets every member of `*wire` whose row of W's table is linked to a member of C (Field::Core) from `core`, in
/// the row's unit; a member that is itself a shape with a table, by its own links. Other members are untouched:
/// what is not one core member as it is (a joint's limits in its unit, ids of stored rows) stays the
/// conversion's own work. Rows are taken whatever their `When`: every linked member is converted.
template <typename C, typename W>
void CoreToWire(const C& core, W* wire) {
  const auto one = [&](const auto& row) {
    if constexpr (requires { row.core; }) {
      using Row = std::remove_cvref_t<decltype(row)>;
      if constexpr (std::is_base_of_v<typename MemberClass<decltype(Row::core)>::type, C>) {
        detail::LinkToWire(core.*(row.core), row.unit, &(wire->*(row.member)));
      }
    }
  };
  std::apply([&](const auto&... row) { (one(row), ...); }, WireFields<W>::fields);
}

/// The converse of CoreToWire: every member of `*core` that a row of W's table is linked to, from `wire`.
template <typename W, typename C>
void WireToCore(const W& wire, C* core) {
  const auto one = [&](const auto& row) {
    if constexpr (requires { row.core; }) {
      using Row = std::remove_cvref_t<decltype(row)>;
      if constexpr (std::is_base_of_v<typename MemberClass<decltype(Row::core)>::type, C>) {
        detail::LinkToCore(wire.*(row.member), row.unit, &(core->*(row.core)));
      }
    }
  };
  std::apply([&](const auto&... row) { (one(row), ...); }, WireFields<W>::fields);
}

/// The rows of a shape (a request's) as the resource that extends it has them: each Field row with its
/// `in_resource` presence (by default always written and required when read) and, with EveryFormInResource,
/// without its `When`; other rows as they are. A resource's table is `std::tuple_cat(ResourceRows(base rows),
/// its own rows)`, so that a field the request and its resource share has one row.
template <typename Rows>
constexpr auto ResourceRows(const Rows& rows) {
  const auto one = [](auto row) {
    if constexpr (requires { row.in_resource; }) {
      row.presence = row.in_resource;
      if (row.every_form_in_resource) row.when = nullptr;
    }
    return row;
  };
  return std::apply([&](const auto&... row) { return std::make_tuple(one(row)...); }, rows);
}

/// Fills in, in a stored document of T, each key of a Later() row that is absent or null with the member's default
/// (what the document meant before the key existed), so that T's strict reading takes it.
template <typename T>
void FillLaterKeys(nlohmann::json* doc) {
  if (!doc->is_object()) return;
  static const T defaults{};
  const auto one = [&](const auto& row) {
    if constexpr (FieldRow<std::remove_cvref_t<decltype(row)>>) {
      if (!row.later || (doc->contains(row.name) && !(*doc)[row.name].is_null())) return;
      (*doc)[row.name] = detail::FieldValue(defaults.*(row.member));
    }
  };
  std::apply([&](const auto&... row) { (one(row), ...); }, WireFields<T>::fields);
}

/// Writes every field of `value` (by its table) into the object `j`.
template <typename T>
void WriteFields(nlohmann::json& j, const T& value) {
  if (!j.is_object()) j = nlohmann::json::object();
  std::apply([&](const auto&... field) { (detail::WriteRow(j, value, field), ...); }, WireFields<T>::fields);
}

/// Reads every field of `*out` (by its table, in its order) from the object `j`, strictly: WireError naming the
/// first missing required or mistyped member, then the table's Check if it has one. Keys not in the table are
/// ignored (a newer server may add fields); refusing unknown keys is the request parsers' work (RejectUnknown).
template <typename T>
void ReadFields(const nlohmann::json& j, T* out) {
  const WireReader r(j);
  std::apply([&](const auto&... field) { (detail::ReadRow(r, out, field), ...); }, WireFields<T>::fields);
  if constexpr (requires { WireFields<T>::Check(*out); }) WireFields<T>::Check(*out);
}

namespace detail {
// The keys a request may send of T's rows for which `keep` holds, in order: kServerOnly rows left out, and a key
// under two rows (a member under one key per form, min_deg / min_mm) listed once.
template <typename T, typename Keep>
std::vector<const char*> RequestKeys(const Keep& keep) {
  std::vector<const char*> keys;
  const auto add = [&](const auto& row) {
    if constexpr (requires { row.presence; }) {
      if (row.presence == Presence::kServerOnly) return;
    }
    if (!keep(row)) return;
    for (const char* key : keys) {
      if (std::string_view(key) == row.name) return;
    }
    keys.push_back(row.name);
  };
  std::apply([&](const auto&... row) { (add(row), ...); }, WireFields<T>::fields);
  return keys;
}
}  // namespace detail

/// The keys of T's table a request may send, in order (kServerOnly rows left out, each key once): the allowed keys
/// of its request parser (ObjectReader::RejectUnknown). Built once per shape: a batch's parser asks for them once
/// per measurement.
template <typename T>
const std::vector<const char*>& WireFieldNames() {
  static const std::vector<const char*> names = detail::RequestKeys<T>([](const auto&) { return true; });
  return names;
}

/// The keys of WireFieldNames<T>() that belong to the form of `value` (rows whose When holds of it): the allowed
/// keys of a parser once it knows the form (an Euler orientation's keys are not a quaternion's).
template <typename T>
std::vector<const char*> WireFieldNamesOf(const T& value) {
  return detail::RequestKeys<T>([&](const auto& row) {
    if constexpr (requires { row.when; }) {
      return !row.when || row.when(value);
    }
    return true;
  });
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

// Each shape's to_json / from_json is instantiated once, in its family's source (ROBOCAL_WIRE_DEFINE there), and
// declared after its table (ROBOCAL_WIRE_DECLARE), so that the files that write and read a shape do not each
// instantiate its table again (a quarter of the compile time of the files that use many shapes).
#define ROBOCAL_WIRE_DECLARE(T)                                \
  extern template void to_json<T>(nlohmann::json&, const T&); \
  extern template void from_json<T>(const nlohmann::json&, T&)
#define ROBOCAL_WIRE_DEFINE(T)                          \
  template void to_json<T>(nlohmann::json&, const T&); \
  template void from_json<T>(const nlohmann::json&, T&)

// The error shapes of error.h (defined there, before these tables).
template <>
struct WireFields<FieldViolation> {
  static constexpr auto fields =
      std::make_tuple(Field{"field", &FieldViolation::field}, Field{"reason", &FieldViolation::reason});
};
ROBOCAL_WIRE_DECLARE(FieldViolation);
template <>
struct WireFields<ErrorInfo> {
  using S = ErrorInfo;
  static constexpr auto fields = std::make_tuple(Field{"code", &S::code}, Field{"status", &S::status},
                                                 Field{"message", &S::message}, Field{"details", &S::details});
};
ROBOCAL_WIRE_DECLARE(ErrorInfo);

// ------------------------------------------------------------------------------------------------ common

/// Lengths beyond this are typing mistakes, not geometry: 1000 km in mm (poses, robots, cells).
inline constexpr double kMaxLengthMm = 1e9;

/// Size and work limits applied while parsing, to each request's total before any work starts. The server
/// fills them from its configuration; each bounds what its comment says.
struct Limits {
  /// Joint vectors / targets / measurements in one request.
  std::size_t max_array_length = 10000;
  /// Configurations of one plan (M).
  int max_plan_configurations = 1000;
  /// Objective evaluations of one plan at most (PlanWork::evaluations: all restarts, and the exchange
  /// optimiser's screening of candidates).
  std::int64_t max_plan_evaluations = 1000000;
  /// Identification Jacobians of single configurations one plan computes at most (PlanWork::jacobians plus the
  /// predicted accuracy's 2 x num_validation): the time of M x evaluations.
  std::int64_t max_plan_jacobians = 10000000;
  /// The exchange optimiser's candidate pool (its memory: rows x L + joints doubles per candidate, at most
  /// 2.7 kB for 12 joints).
  int max_plan_candidates = 20000;
  /// Entries of a fit's Jacobian, rows per measurement x calibration measurements x parameters (the fit holds
  /// a few copies of it, 8 bytes an entry).
  std::int64_t max_fit_jacobian_entries = 2000000;
};

/// The reason given for a request value over one of the limits above: names the limit, so that a caller knows
/// what bounds the request and an operator what to raise. E.g. "16200000 Jacobian entries (...) exceed the
/// server's limit max_fit_jacobian_entries = 2000000".
std::string OverLimit(std::int64_t value, const std::string& what, const std::string& limit_name, std::int64_t limit);

/// Identifiers of robots, plans, campaigns, operations: [a-z0-9][a-z0-9_.-]{0,63}, so that they never
/// collide with the ':' of custom methods or with path separators.
bool IsValidId(const std::string& id);
/// The reason given for an identifier IsValidId refuses.
inline constexpr const char* kIdRule = "must match [a-z0-9][a-z0-9_.-]{0,63}";
/// An upload's idempotency key (a batch's or an import's request_id): not empty, no control characters.
bool IsValidRequestId(const std::string& request_id);
inline constexpr const char* kRequestIdRule =
    "must not be empty nor hold control characters (it makes retries of this upload safe)";

/// The content hash that makes measurement uploads idempotent: 16 hex digits of the 64-bit FNV-1a hash of
/// `text`. Client (a request_id derived from a batch) and server (a batch's content) share it so that both
/// agree on what "the same batch" means.
std::string ContentHash(const std::string& text);

/// A pose in the wire form {"position_mm":[x,y,z],"quaternion":[w,x,y,z]}. As request input, "rpy_deg":[r,p,y]
/// (fixed-axis x-y-z, R = Rz(y) Ry(p) Rx(r)) may stand instead of "quaternion"; the quaternion is normalised
/// (and rejected if its norm is far from 1). Orientation may be omitted only where the context allows it
/// (position measurements); it is then the identity and has_orientation is false. Responses write poses with
/// rpy_deg beside the quaternion (PoseResultWire), for people reading them.
struct PoseWire {
  std::array<double, 3> position_mm{0.0, 0.0, 0.0};
  std::array<double, 4> quaternion{1.0, 0.0, 0.0, 0.0};
  bool has_orientation = true;
};
/// Validates a request pose at `path`; false (with problems recorded) if invalid.
bool ParsePose(const nlohmann::json& value, const std::string& path, bool orientation_required,
               Problems* problems, PoseWire* out);
/// A pose member of a request: orientation required.
template <>
struct RequestReader<PoseWire> {
  static bool Read(const nlohmann::json& value, const std::string& path, Problems* problems, PoseWire* out) {
    return ParsePose(value, path, true, problems, out);
  }
};
namespace detail {
// The orientation of a pose: the quaternion (left out without orientation), read optionally (absent: identity,
// has_orientation false) or, in a result, required; rpy_deg derived from it, never read.
bool WritePoseQuaternion(const PoseWire& pose, nlohmann::json* value);
void ReadPoseQuaternion(const nlohmann::json* value, const std::string& path, PoseWire* pose);
void ReadResultQuaternion(const nlohmann::json* value, const std::string& path, PoseWire* pose);
bool WritePoseRpy(const PoseWire& pose, nlohmann::json* value);
void SkipDerived(const nlohmann::json* value, const std::string& path, PoseWire* pose);
}  // namespace detail
/// {"position_mm", "quaternion"}: requests and stored documents.
template <>
struct WireFields<PoseWire> {
  static constexpr auto fields = std::make_tuple(
      Field{"position_mm", &PoseWire::position_mm}.Mandatory(),
      Computed<PoseWire>{"quaternion", &detail::WritePoseQuaternion, &detail::ReadPoseQuaternion},
      // A request's alternative to the quaternion (ParsePose reads it); never written here.
      Computed<PoseWire>{"rpy_deg", +[](const PoseWire&, nlohmann::json*) { return false; }, &detail::SkipDerived});
};
ROBOCAL_WIRE_DECLARE(PoseWire);

/// A pose of a response, {"position_mm", "quaternion", "rpy_deg"}: the quaternion required, rpy_deg derived (for
/// people reading it).
struct PoseResultWire : PoseWire {
  PoseResultWire() = default;
  PoseResultWire(const PoseWire& pose) : PoseWire(pose) {}  // implicit: every pose can be a result's
};
template <>
struct WireFields<PoseResultWire> {
  static constexpr auto fields = std::make_tuple(
      Field{"position_mm", &PoseWire::position_mm},
      Computed<PoseWire>{"quaternion", &detail::WritePoseQuaternion, &detail::ReadResultQuaternion, true},
      Computed<PoseWire>{"rpy_deg", &detail::WritePoseRpy, &detail::SkipDerived, true});
};
ROBOCAL_WIRE_DECLARE(PoseResultWire);

/// A joint range {"min", "max"} in the joint's wire unit (deg or mm): a cell's allowed ranges, the ranges a
/// calibration was measured over.
struct JointRangeWire {
  double min = 0.0;
  double max = 0.0;
};
template <>
struct WireFields<JointRangeWire> {
  using S = JointRangeWire;
  static constexpr auto fields = std::make_tuple(Field{"min", &S::min}.Mandatory(), Field{"max", &S::max}.Mandatory());
};
ROBOCAL_WIRE_DECLARE(JointRangeWire);

/// A payload on the flange: {"mass_kg": m, "com_mm": [x, y, z]} (kg; centre of mass in mm, flange frame; com_mm
/// may be left out for a payload centred on the flange). With a compliance model the robot deflects under it
/// (docs/identification.md, "Beyond geometry").
struct PayloadWire {
  double mass_kg = 0.0;
  std::array<double, 3> com_mm{0.0, 0.0, 0.0};
};
/// The heaviest payload taken (kg): more than any industrial robot lifts.
inline constexpr double kMaxPayloadKg = 10000.0;
template <>
struct WireFields<PayloadWire> {
  using S = PayloadWire;
  static constexpr auto fields =
      std::make_tuple(Field{"mass_kg", &S::mass_kg}.Mandatory().Range(0.0, kMaxPayloadKg),
                      // Within 100 m of the flange: beyond is a unit mistake.
                      Field{"com_mm", &S::com_mm, Presence::kOptionalOnRead}.Range(-1e5, 1e5));
};
ROBOCAL_WIRE_DECLARE(PayloadWire);
Payload ToCore(const PayloadWire& payload);
Transform PoseToTransform(const PoseWire& pose);
/// One sign per rotation (w >= 0), so that equal poses serialise equally.
PoseWire TransformToPose(const Transform& pose);

/// {"name", "reason"}: a parameter left out of a fit or plan, and why.
struct DroppedParameterWire {
  std::string name;
  std::string reason;
};
template <>
struct WireFields<DroppedParameterWire> {
  using S = DroppedParameterWire;
  static constexpr auto fields = std::make_tuple(
      Field{"name", &S::name},
      Field{"reason", &S::reason});
};
ROBOCAL_WIRE_DECLARE(DroppedParameterWire);
std::vector<DroppedParameterWire> ToWire(const std::vector<DroppedParameter>& dropped);

/// Tracker noise on the wire (1-sigma): position per axis (mm) and orientation (deg).
struct NoiseWire {
  double position_mm = 0.015;
  double orientation_deg = 0.0057295779513082;  // 1e-4 rad
};
template <>
struct WireFields<NoiseWire> {
  using S = NoiseWire;
  static constexpr auto fields = std::make_tuple(Field{"position_mm", &S::position_mm}.Range(1e-9, 1e3),
                                                 Field{"orientation_deg", &S::orientation_deg}.Range(1e-9, 90.0));
};
ROBOCAL_WIRE_DECLARE(NoiseWire);
MeasurementNoise ToCore(const NoiseWire& noise);

/// The tracker's uncertainty model on the wire (core TrackerUncertainty; docs/identification.md, "Weighting"):
/// {"radial_um": [a, b], "transverse_um": [a, b], "orientation_deg": o, "mpe_sigmas": k}, the MPE along the
/// beam and across it as a (um) + b (um per m of distance), the 6-DoF orientation MPE, and how many sigmas the
/// figures are (2: datasheet MPE with typical errors half of it; 1: the figures are 1-sigma values).
struct TrackerModelWire {
  std::array<double, 2> radial_um{10.0, 0.3};
  std::array<double, 2> transverse_um{15.0, 6.0};
  double orientation_deg = 0.01;
  double mpe_sigmas = 2.0;
};
template <>
struct WireFields<TrackerModelWire> {
  using S = TrackerModelWire;
  static constexpr auto fields = std::make_tuple(
      Field{"radial_um", &S::radial_um},
      Field{"transverse_um", &S::transverse_um},
      Field{"orientation_deg", &S::orientation_deg},
      Field{"mpe_sigmas", &S::mpe_sigmas});
};
ROBOCAL_WIRE_DECLARE(TrackerModelWire);
/// A request's tracker model: a member given fills the others from the defaults above; each pair's constant and
/// slope have their own ranges.
template <>
struct RequestReader<TrackerModelWire> {
  static bool Read(const nlohmann::json& value, const std::string& path, Problems* problems, TrackerModelWire* out);
};
TrackerUncertainty ToCore(const TrackerModelWire& tracker);
/// The core's noise: the tracker model when given, else the isotropic noise.
MeasurementNoise ToCore(const NoiseWire& noise, const std::optional<TrackerModelWire>& tracker);

}  // namespace robocal::api
