// The OpenAPI spec (api/openapi.json) against the field tables, field by field: every schema that has a shape
// lists exactly the table's keys, each with the member's JSON type, the table's range, size and length, and the
// required list the table gives. The table is the one owner of a field; the spec adds only its description, and
// this test fails until the two agree (docs/architecture.md, "How to add a field").
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <set>
#include <string>
#include <type_traits>
#include <vector>

#include "robocal/api/calibration.h"
#include "robocal/api/campaigns.h"
#include "robocal/api/cells.h"
#include "robocal/api/health.h"
#include "robocal/api/json_reader.h"
#include "robocal/api/operations.h"
#include "robocal/api/plans.h"
#include "robocal/api/programs.h"
#include "robocal/api/robots.h"
#include "robocal/api/tracker_files.h"

namespace robocal::api {
namespace {

using nlohmann::json;

// Whether a schema describes what a client sends (its required list is the request's: Mandatory rows) or what
// the server writes (every row always written: kRequired, kOptionalOnRead, kAbsentIsEmpty, kSetByServer).
enum class Role { kRequest, kReply };

class SpecChecker {
 public:
  explicit SpecChecker(json spec) : spec_(std::move(spec)) {}

  // Checks the schema at `pointer` (a component or an inline object) against T's table.
  template <typename T>
  void Check(const std::string& pointer, Role role) {
    const json* schema = Resolve(pointer);
    if (schema == nullptr) {
      Fail(pointer, "no such schema");
      return;
    }
    // A component a request uses is the request's form, also where a reply carries it (a plan's request).
    if (role == Role::kReply && requests_.count(pointer)) return;
    if (role == Role::kRequest) requests_.insert(pointer);
    if (!checked_.insert(pointer + (role == Role::kRequest ? "#request" : "#reply")).second) return;
    const json properties = schema->value("properties", json::object());
    std::set<std::string> keys;
    std::set<std::string> required;
    std::apply([&](const auto&... row) { (Row<T>(pointer, *schema, role, row, &keys, &required), ...); },
               WireFields<T>::fields);
    for (const auto& [key, value] : properties.items()) {
      if (!keys.count(key)) Fail(pointer, "property \"" + key + "\" is in no row of the shape's table");
    }
    std::set<std::string> listed;
    for (const json& k : schema->value("required", json::array())) listed.insert(k.get<std::string>());
    for (const std::string& k : required) {
      if (!listed.count(k)) Fail(pointer + "/properties/" + k, "the table requires it: add it to \"required\"");
    }
    for (const std::string& k : listed) {
      if (!required.count(k)) Fail(pointer + "/properties/" + k, "\"required\" lists it, the table does not");
    }
    if (schema->value("additionalProperties", true) != false) Fail(pointer, "additionalProperties must be false");
  }

  const std::vector<std::string>& failures() const { return failures_; }

 private:
  const json* Resolve(const std::string& pointer) const {
    const json::json_pointer p(pointer);
    if (!spec_.contains(p)) return nullptr;
    const json* node = &spec_.at(p);
    while (node->is_object() && node->contains("$ref")) {
      const json::json_pointer ref((*node)["$ref"].get<std::string>().substr(1));
      if (!spec_.contains(ref)) return nullptr;
      node = &spec_.at(ref);
    }
    return node;
  }
  // The pointer of a property's schema, following a $ref (an items' schema for lists).
  std::string Target(const std::string& pointer) const {
    const json& node = spec_.at(json::json_pointer(pointer));
    if (node.is_object() && node.contains("$ref")) return node["$ref"].get<std::string>().substr(1);
    return pointer;
  }

  void Fail(const std::string& where, const std::string& reason) { failures_.push_back(where + ": " + reason); }

  template <typename T, typename S, typename M>
  void Row(const std::string& pointer, const json& schema, Role role, const Field<S, M>& row,
           std::set<std::string>* keys, std::set<std::string>* required) {
    keys->insert(row.name);
    if (role == Role::kRequest && row.presence == Presence::kServerOnly) return;
    const bool always = row.when == nullptr;
    if (role == Role::kRequest ? row.request.required && always
                               : always && row.presence != Presence::kOmitEmpty &&
                                     row.presence != Presence::kServerOnly) {
      required->insert(row.name);
    }
    const std::string at = pointer + "/properties/" + row.name;
    if (!schema.contains("properties") || !schema["properties"].contains(row.name)) {
      Fail(at, "missing: the table has this key");
      return;
    }
    // A member its parser reads apart is checked as any other (its type and the table's rule), unless the spec
    // gives a choice of forms for it (a list, or an object): that reading is the parser's to state.
    if (role == Role::kRequest && row.request.apart && Resolve(Target(at))->contains("oneOf")) return;
    Member<M>(Target(at), role, row.request);
  }
  template <typename T, typename Row_>
  requires(!FieldRow<Row_>) void Row(const std::string& pointer, const json& schema, Role role, const Row_& row,
                                     std::set<std::string>* keys, std::set<std::string>* required) {
    // Computed and Nested rows: a key whose form the shape's own functions give; it must be there, and a reply
    // always has a Nested key and a Computed one its write always writes.
    keys->insert(row.name);
    if constexpr (requires { row.always_written; }) {
      if (role == Role::kReply && row.always_written) required->insert(row.name);
      if (role == Role::kRequest && row.required_in_request) required->insert(row.name);
    } else {
      if (role == Role::kReply) required->insert(row.name);
    }
    if (!schema.contains("properties") || !schema["properties"].contains(row.name)) {
      Fail(pointer + "/properties/" + row.name, "missing: the table has this key");
    }
  }

  // The schema at `at` has M's JSON type and the rule's bounds.
  template <typename M>
  void Member(const std::string& at, Role role, const RequestRule& rule, bool element = false) {
    const json& p = *Resolve(at);
    if (p.contains("oneOf")) {
      // One of several shapes (an operation's request or result): the member's must be among them.
      std::vector<std::string> best;
      for (std::size_t k = 0; k < p["oneOf"].size(); ++k) {
        SpecChecker alternative(spec_);
        alternative.requests_ = requests_;
        alternative.template Member<M>(Target(at + "/oneOf/" + std::to_string(k)), role, rule);
        if (alternative.failures_.empty()) return;
        if (best.empty() || alternative.failures_.size() < best.size()) best = alternative.failures_;
      }
      failures_.insert(failures_.end(), best.begin(), best.end());
      return;
    }
    const std::string type = p.value("type", "");
    if constexpr (detail::IsOptional<M>::value) {
      Member<typename M::value_type>(at, role, rule, element);
    } else if constexpr (std::is_same_v<M, double>) {
      Expect(at, p, "number");
      Bounds(at, p, rule);
    } else if constexpr (std::is_same_v<M, bool>) {
      Expect(at, p, "boolean");
    } else if constexpr (kIsWireEnum<M>) {
      Expect(at, p, "string");
      if (!p.contains("enum")) Fail(at, "an enum: list its names under \"enum\"");
    } else if constexpr (std::is_integral_v<M>) {
      Expect(at, p, "integer");
      Bounds(at, p, rule);
    } else if constexpr (std::is_same_v<M, std::string>) {
      Expect(at, p, "string");
      // A list's strings: their length is the parser's (a row's size is the list's).
      if (!element) Length(at, p, rule);
    } else if constexpr (detail::IsArray<M>::value) {
      Expect(at, p, "array");
      if (p.value("minItems", -1) != static_cast<int>(std::tuple_size_v<M>) ||
          p.value("maxItems", -1) != static_cast<int>(std::tuple_size_v<M>)) {
        Fail(at, "minItems and maxItems must both be " + std::to_string(std::tuple_size_v<M>));
      }
      if constexpr (std::is_same_v<typename M::value_type, double>) {
        if (p.contains("items")) Member<double>(Target(at + "/items"), role, rule);
      }
    } else if constexpr (detail::IsVector<M>::value) {
      Expect(at, p, "array");
      Items(at, p, rule);
      if (!p.contains("items")) {
        Fail(at, "an array: give its \"items\"");
      } else {
        // A list's range is its elements' (its size is the list's own: Items above).
        Member<typename M::value_type>(Target(at + "/items"), role, RequestRule{rule.min, rule.max}, true);
      }
    } else if constexpr (kHasWireFields<M>) {
      Check<M>(at, role);
    }
    // Other types (maps of files, raw JSON): their form is the shape's own.
  }

  void Expect(const std::string& at, const json& p, const std::string& type) {
    const json t = p.value("type", json());
    const bool ok = t == type || (t.is_array() && std::find(t.begin(), t.end(), type) != t.end());
    if (!ok) Fail(at, "type must be \"" + type + "\", the spec says " + t.dump());
  }
  void Bounds(const std::string& at, const json& p, const RequestRule& rule) {
    const bool has_min = rule.min > -RequestRule::kNoBound, has_max = rule.max < RequestRule::kNoBound;
    if (has_min != p.contains("minimum") || (has_min && p["minimum"].get<double>() != rule.min)) {
      Fail(at, has_min ? "\"minimum\" must be " + json(rule.min).dump() : "the table has no minimum");
    }
    if (has_max != p.contains("maximum") || (has_max && p["maximum"].get<double>() != rule.max)) {
      Fail(at, has_max ? "\"maximum\" must be " + json(rule.max).dump() : "the table has no maximum");
    }
  }
  void Length(const std::string& at, const json& p, const RequestRule& rule) {
    if ((rule.max_size > 0) != p.contains("maxLength") ||
        (rule.max_size > 0 && p["maxLength"].get<std::size_t>() != rule.max_size)) {
      Fail(at, rule.max_size > 0 ? "\"maxLength\" must be " + std::to_string(rule.max_size)
                                 : "the table has no maxLength");
    }
  }
  void Items(const std::string& at, const json& p, const RequestRule& rule) {
    if ((rule.min_size > 0) != p.contains("minItems") ||
        (rule.min_size > 0 && p["minItems"].get<std::size_t>() != rule.min_size)) {
      Fail(at, rule.min_size > 0 ? "\"minItems\" must be " + std::to_string(rule.min_size)
                                 : "the table has no minItems");
    }
    if ((rule.max_size > 0) != p.contains("maxItems") ||
        (rule.max_size > 0 && p["maxItems"].get<std::size_t>() != rule.max_size)) {
      Fail(at, rule.max_size > 0 ? "\"maxItems\" must be " + std::to_string(rule.max_size)
                                 : "the table has no maxItems");
    }
  }

  json spec_;
  std::set<std::string> requests_;
  std::set<std::string> checked_;
  std::vector<std::string> failures_;
};

json LoadSpec() {
  std::ifstream in(ROBOCAL_OPENAPI_JSON);
  return json::parse(in);
}

std::string Schema(const std::string& name) { return "/components/schemas/" + name; }

TEST(SpecTest, EverySchemaWithAShapeIsItsTable) {
  SpecChecker spec(LoadSpec());
  // Requests (and the shapes only requests and their stored copies carry).
  spec.Check<RegisterRobotRequest>(Schema("RegisterRobotRequest"), Role::kRequest);
  spec.Check<ImportUrdfRequest>(Schema("ImportUrdfRequest"), Role::kRequest);
  spec.Check<RobotFromCalibrationRequest>(Schema("RobotFromCalibrationRequest"), Role::kRequest);
  spec.Check<PlanRequest>(Schema("PlanRequest"), Role::kRequest);
  spec.Check<CreateCampaignRequest>(Schema("CreateCampaignRequest"), Role::kRequest);
  spec.Check<MeasurementBatchRequest>(Schema("MeasurementBatch"), Role::kRequest);
  spec.Check<FitRequest>(Schema("FitRequest"), Role::kRequest);
  spec.Check<CompensateRequest>(Schema("CompensateRequest"), Role::kRequest);
  spec.Check<EvaluateRequest>(Schema("EvaluateRequest"), Role::kRequest);
  spec.Check<CellWire>(Schema("CellRequest"), Role::kRequest);
  spec.Check<CompensateProgramRequest>(Schema("CompensateProgramRequest"), Role::kRequest);
  spec.Check<ImportMeasurementsRequest>(Schema("ImportMeasurementsRequest"), Role::kRequest);
  // A fit's model: a Computed row of the fit request ("auto" or the object), the object's form a request's.
  spec.Check<ModelWire>(Schema("Model"), Role::kRequest);
  spec.Check<JointMapsWire>(Schema("JointMaps"), Role::kRequest);
  // Replies.
  spec.Check<Health>(Schema("Health"), Role::kReply);
  spec.Check<Robot>(Schema("Robot"), Role::kReply);
  spec.Check<RobotList>(Schema("RobotList"), Role::kReply);
  spec.Check<Indices>(Schema("Indices"), Role::kReply);
  spec.Check<PlanResult>(Schema("Plan"), Role::kReply);
  spec.Check<Operation>(Schema("Operation"), Role::kReply);
  spec.Check<Campaign>(Schema("Campaign"), Role::kReply);
  spec.Check<CampaignList>(Schema("CampaignList"), Role::kReply);
  spec.Check<BatchResult>(Schema("BatchResult"), Role::kReply);
  spec.Check<MeasurementList>(Schema("MeasurementList"), Role::kReply);
  spec.Check<Residuals>(Schema("Residuals"), Role::kReply);
  spec.Check<CalibrationResult>(Schema("Calibration"), Role::kReply);
  spec.Check<CompensatedTargets>(Schema("CompensateResponse"), Role::kReply);
  spec.Check<Accuracy>(Schema("AccuracyReport"), Role::kReply);
  spec.Check<Evaluation>(Schema("EvaluateResponse"), Role::kReply);
  spec.Check<CellWire>(Schema("Cell"), Role::kReply);
  spec.Check<CellList>(Schema("CellList"), Role::kReply);
  spec.Check<ConfigurationCheckWire>(Schema("ConfigurationCheck"), Role::kReply);
  spec.Check<CellCheckResult>(Schema("CellCheckResult"), Role::kReply);
  spec.Check<CalibrationSource>(Schema("CalibrationSource"), Role::kReply);
  spec.Check<ModelCandidateWire>(Schema("ModelCandidate"), Role::kReply);
  spec.Check<CompensateProgramResult>(Schema("CompensateProgramResponse"), Role::kReply);
  spec.Check<MapGridWire>(Schema("MapGrid"), Role::kReply);
  spec.Check<JointMapWire>(Schema("JointMap"), Role::kReply);
  spec.Check<Iso9283ReportWire>(Schema("Iso9283Report"), Role::kReply);
  spec.Check<DriftCheckRequest>(Schema("DriftCheckRequest"), Role::kRequest);
  spec.Check<DriftCheckWire>(Schema("DriftCheck"), Role::kReply);
  spec.Check<RobotHistoryWire>(Schema("RobotHistory"), Role::kReply);
  spec.Check<CalibrateRobotRequest>(Schema("CalibrateRobotRequest"), Role::kRequest);
  spec.Check<RollbackRequest>(Schema("RollbackRequest"), Role::kRequest);
  std::string all;
  for (const std::string& f : spec.failures()) all += f + "\n";
  EXPECT_TRUE(spec.failures().empty()) << spec.failures().size() << " differences:\n" << all;
}

// The checker itself: a schema that differs from its table in a type, a bound, a key or the required list is
// found, so that the test above cannot pass by checking nothing.
TEST(SpecTest, TheCheckerFindsEachKindOfDifference) {
  const json good = {{"components",
                      {{"schemas",
                        {{"Noise",
                          {{"type", "object"},
                           {"properties",
                            {{"position_mm", {{"type", "number"}, {"minimum", 1e-9}, {"maximum", 1e3}}},
                             {"orientation_deg", {{"type", "number"}, {"minimum", 1e-9}, {"maximum", 90.0}}}}},
                           {"additionalProperties", false}}}}}}}};
  {
    SpecChecker spec(good);
    spec.Check<NoiseWire>(Schema("Noise"), Role::kRequest);
    EXPECT_TRUE(spec.failures().empty()) << spec.failures().front();
  }
  const auto failures = [&](const std::function<void(json*)>& change) {
    json bad = good;
    change(&bad["components"]["schemas"]["Noise"]);
    SpecChecker spec(bad);
    spec.Check<NoiseWire>(Schema("Noise"), Role::kRequest);
    return spec.failures().size();
  };
  EXPECT_EQ(failures([](json* s) { (*s)["properties"]["position_mm"]["type"] = "integer"; }), 1u);
  EXPECT_EQ(failures([](json* s) { (*s)["properties"]["position_mm"]["maximum"] = 100.0; }), 1u);
  EXPECT_EQ(failures([](json* s) { (*s)["properties"]["orientation_deg"].erase("minimum"); }), 1u);
  EXPECT_EQ(failures([](json* s) { (*s)["properties"].erase("orientation_deg"); }), 1u);
  EXPECT_EQ(failures([](json* s) { (*s)["properties"]["extra"] = {{"type", "number"}}; }), 1u);
  EXPECT_EQ(failures([](json* s) { (*s)["required"] = {"position_mm"}; }), 1u);
  EXPECT_EQ(failures([](json* s) { (*s)["additionalProperties"] = true; }), 1u);
}

}  // namespace
}  // namespace robocal::api
