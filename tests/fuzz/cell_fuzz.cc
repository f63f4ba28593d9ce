// Fuzz target: the body of POST /v1/cells (api::ParseCellRequest), against every preset, then what the
// service does with an accepted cell: build the core cell, write the resource with every default filled in
// (which a client may send back as a new cell), and check configurations in it.
#include "fuzz_util.h"

#include "robocal/api/cells.h"
#include "robocal/core/cell.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace robocal;
  const std::optional<nlohmann::json> body = fuzz::Body(data, size);
  if (!body) return 0;
  const api::Limits limits;
  for (const RobotModel& model : fuzz::Presets()) {
    const auto parse = [&](const nlohmann::json& b) { return api::ParseCellRequest(b, model, limits); };
    const auto request = fuzz::Parsed([&] { return parse(*body); });
    if (!request) continue;
    fuzz::Check(api::IsValidId(request->id), "a cell's id is a valid id");
    // The parser has had the core check the geometry, so building can no longer fail: an exception here
    // escapes and is a finding.
    const Cell cell = api::ToCell(*request, model);
    // The request reads back through the parser; only the resource (below), with every default written out,
    // also through the strict structural reader (a request may leave tool_radius_mm to the server).
    const nlohmann::json written = nlohmann::json(*request);
    const auto again = fuzz::Parsed([&] { return parse(api::ParseBody(written.dump())); });
    fuzz::Check(again.has_value(), "a parsed cell's ToJson parses again");
    fuzz::Check(fuzz::SameJson(nlohmann::json(*again), written), "a parsed cell's ToJson reads back the same");
    const api::CellWire resource = api::CellResource(*request, cell, model);
    fuzz::Check(resource.link_radii_mm.size() == static_cast<std::size_t>(model.num_joints()),
                "the resource has one radius per link");
    fuzz::Check(resource.joint_ranges.size() == static_cast<std::size_t>(model.num_joints()),
                "the resource has one range per joint");
    fuzz::Check(!resource.reflectors.empty(), "the resource names at least one reflector");
    fuzz::CheckRoundTrip(resource, parse);
    // Checks at the middle and the ends of the planning ranges: a report per reflector, the fast decision
    // equal to the full report's.
    const RobotModel planning = cell.PlanningModel(model);
    for (const Eigen::VectorXd& q :
         {planning.lower_limits(), planning.upper_limits(),
          Eigen::VectorXd(0.5 * (planning.lower_limits() + planning.upper_limits()))}) {
      const ConfigurationCheck check = CheckConfiguration(model, cell, q);
      fuzz::Check(check.reflectors.size() == resource.reflectors.size(), "a check reports every reflector");
      fuzz::Check(check.feasible == IsFeasible(model, cell, q), "IsFeasible agrees with CheckConfiguration");
      fuzz::Check(check.feasible == check.failed_rules.empty(), "infeasible exactly when a rule failed");
    }
  }
  return 0;
}
