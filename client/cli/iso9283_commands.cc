// The ISO 9283 pose test's commands: `iso9283 plan` lays the test out, `iso9283 report` shows a campaign's
// characteristics (docs/iso9283.md).
#include <fstream>
#include <iomanip>
#include <limits>
#include <string>

#include "command.h"
#include "support.h"

namespace robocal::cli {
namespace {

void PrintTestPlan(const api::PlanResult& plan, std::ostream& out) {
  const api::Iso9283PlanWire& t = *plan.test;
  out << "plan " << plan.id << "  robot " << plan.robot << "  ISO 9283 pose test, " << t.cycles << " cycles of P1-P5 ("
      << plan.configurations.size() << " configurations)\n";
  out << "cube: centre " << Fixed(t.cube.center_mm[0], 1) << ", " << Fixed(t.cube.center_mm[1], 1) << ", "
      << Fixed(t.cube.center_mm[2], 1) << " mm, edge " << Fixed(t.cube.size_mm, 1) << " mm; tool rpy "
      << Fixed(t.orientation_rpy_deg[0], 2) << ", " << Fixed(t.orientation_rpy_deg[1], 2) << ", "
      << Fixed(t.orientation_rpy_deg[2], 2) << " deg";
  if (!t.configuration.empty()) out << "; " << t.configuration;
  out << "\n";
  if (t.compensated_by) out << "joint commands compensated by the calibration of campaign " << *t.compensated_by << "\n";
  out << std::setw(4) << "pose" << std::setw(10) << "x[mm]" << std::setw(10) << "y[mm]" << std::setw(10) << "z[mm]";
  for (std::size_t j = 0; j < plan.joint_units.size(); ++j) {
    out << std::setw(12) << ("q" + std::to_string(j + 1) + "[" + plan.joint_units[j] + "]");
  }
  out << "\n";
  for (const api::Iso9283PlannedPoseWire& p : t.poses) {
    out << std::setw(4) << p.name;
    for (double v : p.position_mm) out << std::setw(10) << Fixed(v, 1);
    for (double v : p.joints) out << std::setw(12) << Fixed(v, 3);
    out << "\n";
  }
  out << t.message << "\n";
}

void PrintFigures(const char* set, const api::Iso9283FiguresWire& f, std::ostream& out) {
  out << set << ":\n" << std::setw(6) << "pose" << std::setw(7) << "cycles" << std::setw(10) << "AP[mm]" << std::setw(10)
      << "APx" << std::setw(10) << "APy" << std::setw(10) << "APz" << std::setw(10) << "RPl[mm]" << std::setw(11)
      << "APa[deg]" << std::setw(11) << "APb[deg]" << std::setw(11) << "APc[deg]" << std::setw(11) << "RPa[deg]"
      << std::setw(11) << "RPb[deg]" << std::setw(11) << "RPc[deg]" << "\n";
  for (const api::Iso9283PoseWire& p : f.poses) {
    out << std::setw(6) << p.pose << std::setw(7) << p.cycles << std::setw(10) << Fixed(p.ap_mm, 4) << std::setw(10)
        << Fixed(p.apx_mm, 4) << std::setw(10) << Fixed(p.apy_mm, 4) << std::setw(10) << Fixed(p.apz_mm, 4)
        << std::setw(10) << Fixed(p.rpl_mm, 4) << std::setw(11) << Fixed(p.apa_deg, 5) << std::setw(11)
        << Fixed(p.apb_deg, 5) << std::setw(11) << Fixed(p.apc_deg, 5) << std::setw(11) << Fixed(p.rpa_deg, 5)
        << std::setw(11) << Fixed(p.rpb_deg, 5) << std::setw(11) << Fixed(p.rpc_deg, 5) << "\n";
  }
  for (const api::Iso9283DistanceWire& d : f.distances) {
    out << "  " << d.from << "-" << d.to << ": commanded " << Fixed(d.command_mm, 3) << " mm, AD " << Fixed(d.ad_mm, 4)
        << " mm (" << Fixed(d.adx_mm, 4) << ", " << Fixed(d.ady_mm, 4) << ", " << Fixed(d.adz_mm, 4) << "), RD "
        << Fixed(d.rd_mm, 4) << " mm over " << d.cycles << " cycles\n";
  }
}

}  // namespace

int Iso9283Plan(Invocation& in) {
  api::PlanRequest request;
  request.robot = in.args[0];
  request.cell = in.Option("--cell");
  request.measurement_type = in.Enum("--type", MeasurementType::kPose);
  request.seed = in.Seed("--seed", 1);
  api::Iso9283TestWire& test = request.test.emplace().iso9283;
  if (in.Option("--size") == "auto") {
    if (in.Has("--center")) throw UsageError("--center goes with --size MM, not with --size auto");
    test.cube_auto = true;
  } else {
    if (!in.Has("--center") || !in.Has("--size")) {
      throw UsageError("give the cube: --center X,Y,Z (base frame, mm) and --size MM, or --size auto with --cell");
    }
    // Any number: the service says which it takes (its error names the field and the range).
    test.cube = api::Iso9283CubeWire{.center_mm = Triple("--center", in.Option("--center")),
                                     .size_mm = in.Number("--size", 0.0, std::numeric_limits<double>::lowest())};
  }
  test.cycles = static_cast<int>(in.Integer("--cycles", test.cycles, 0, 1000000));
  if (in.Has("--rpy")) test.orientation_rpy_deg = Triple("--rpy", in.Option("--rpy"));
  test.compensated_by = in.Option("--compensated-by");
  const api::PlanResult plan = in.Client().CreatePlan(request);
  const std::string out_file = in.Option("--out");
  if (!out_file.empty()) {
    std::ofstream file(out_file);
    PrintJson(file, plan);
    if (!file) throw UsageError("cannot write " + out_file);
  }
  if (in.json) {
    PrintJson(in.out, plan);
  } else {
    PrintTestPlan(plan, in.out);
  }
  return kExitOk;
}

int Iso9283Report(Invocation& in) {
  const std::string file = in.Option("--out");
  if (in.Has("--csv")) {
    // Fetched before the file is opened: a refused report leaves no empty file behind.
    const std::string csv = in.Client().Iso9283Csv(in.args[0]);
    Output(file, in.out).stream() << csv;
    return kExitOk;
  }
  const api::Iso9283ReportWire r = in.Client().Iso9283(in.args[0]);
  Output output(file, in.out);
  std::ostream& out = output.stream();
  if (in.json) {
    PrintJson(out, r);
    return kExitOk;
  }
  out << "ISO 9283 pose test of campaign " << r.campaign << ": " << r.num_shots << " shots, up to " << r.cycles
      << " cycles per pose; commands from " << api::WireName(r.commands) << ", frames from " << api::WireName(r.frames)
      << "\n";
  PrintFigures("measured", r.measured, out);
  if (r.calibrated) PrintFigures("calibrated (commands compensated by this campaign's calibration)", *r.calibrated, out);
  for (const std::string& note : r.notes) out << "note: " << note << "\n";
  return kExitOk;
}

}  // namespace robocal::cli
