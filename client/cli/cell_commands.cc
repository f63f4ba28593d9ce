// robocal cell create | list | get | delete | check.
#include <iomanip>

#include "cli.h"
#include "command.h"
#include "support.h"

namespace robocal::cli {
namespace {

void PrintCell(const api::CellWire& cell, std::ostream& out) {
  out << cell.id << ": robot " << cell.robot << ", tracker at [" << Fixed(cell.tracker.position_mm[0], 1) << ", "
      << Fixed(cell.tracker.position_mm[1], 1) << ", " << Fixed(cell.tracker.position_mm[2], 1) << "] mm, "
      << cell.reflectors.size() << " reflector(s), " << cell.obstacles.size() << " obstacle(s), clearance "
      << Fixed(cell.clearance_mm, 1) << " mm\n";
  for (const api::ReflectorWire& r : cell.reflectors) {
    out << "  reflector " << r.id << " at [" << Fixed(r.position_mm[0], 1) << ", " << Fixed(r.position_mm[1], 1)
        << ", " << Fixed(r.position_mm[2], 1) << "] mm (flange), half angle " << Fixed(r.acceptance_half_angle_deg, 1)
        << " deg\n";
  }
  for (const api::ObstacleWire& o : cell.obstacles) out << "  obstacle " << o.id << "\n";
}

int Show(Invocation& in, const api::CellWire& cell) {
  if (in.json) {
    PrintJson(in.out, cell);
  } else {
    PrintCell(cell, in.out);
  }
  return kExitOk;
}

}  // namespace

int CellCreate(Invocation& in) {
  nlohmann::json body;
  try {
    body = nlohmann::json::parse(ReadFile(in.args[0]));
  } catch (const nlohmann::json::parse_error& e) {
    throw UsageError(in.args[0] + " is not JSON: " + e.what());
  }
  return Show(in, in.Client().CreateCell(body));
}

int CellList(Invocation& in) {
  api::CellList list;
  list.cells = in.Client().ListCells();
  if (in.json) {
    PrintJson(in.out, list);
    return kExitOk;
  }
  for (const api::CellWire& c : list.cells) {
    in.out << std::left << std::setw(20) << c.id << std::setw(12) << c.robot << std::right << c.reflectors.size()
           << " reflector(s)  " << c.obstacles.size() << " obstacle(s)  " << c.description << "\n";
  }
  return kExitOk;
}

int CellGet(Invocation& in) { return Show(in, in.Client().GetCell(in.args[0])); }

int CellDelete(Invocation& in) {
  in.Client().DeleteCell(in.args[0]);
  if (in.json) {
    PrintJson(in.out, nlohmann::json::object());
  } else {
    in.out << "deleted " << in.args[0] << "\n";
  }
  return kExitOk;
}

int CellCheck(Invocation& in) {
  const api::CellWire cell = in.Client().GetCell(in.args[0]);
  const auto joints = ReadJointsFile(in.args[1], in.Client().GetRobot(cell.robot));
  const api::CellCheckResult result = in.Client().CheckCell(cell.id, joints);
  Output output(in.Option("--out"), in.out);
  std::ostream& out = output.stream();
  if (in.json) {
    PrintJson(out, result);
    return kExitOk;
  }
  // One row per configuration: feasible, clearance and what sets it, measurable reflectors, the reasons.
  out << "row,feasible,min_clearance_mm,clearance_pair,measurable,reasons\n";
  int feasible = 0;
  for (std::size_t i = 0; i < result.results.size(); ++i) {
    const api::ConfigurationCheckWire& c = result.results[i];
    feasible += c.feasible ? 1 : 0;
    std::string measurable, reasons;
    for (const api::ReflectorCheckWire& r : c.reflectors) {
      if (r.measurable) measurable += (measurable.empty() ? "" : " ") + r.id;
    }
    for (const std::string& reason : c.reasons) reasons += (reasons.empty() ? "" : "; ") + reason;
    out << i + 1 << "," << (c.feasible ? 1 : 0) << "," << Fixed(c.min_clearance_mm, 1) << "," << c.clearance_pair
        << "," << measurable << ",\"" << reasons << "\"\n";
  }
  in.err << feasible << " of " << result.results.size() << " configurations feasible in cell " << cell.id << "\n";
  return kExitOk;
}

}  // namespace robocal::cli
