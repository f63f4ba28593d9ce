// The ISO 9283 test's wire shapes (iso9283.h): the cube read as an object or "auto", the figures in wire units,
// and the report as CSV.
#include "robocal/api/iso9283.h"

#include <cmath>
#include <iomanip>
#include <sstream>

#include "robocal/core/units.h"

namespace robocal::api {

const char* EnumTable<TestCommands>::Name(TestCommands v) {
  return v == TestCommands::kPlan ? "plan" : "robot_model";
}
const char* EnumTable<TestFrames>::Name(TestFrames v) {
  return v == TestFrames::kCalibration ? "calibration" : "registered_on_test";
}

Iso9283Cube ToCore(const Iso9283CubeWire& cube) {
  return {.center_mm = Eigen::Vector3d(cube.center_mm[0], cube.center_mm[1], cube.center_mm[2]),
          .size_mm = cube.size_mm};
}

Iso9283CubeWire ToWire(const Iso9283Cube& cube) {
  return {.center_mm = {cube.center_mm.x(), cube.center_mm.y(), cube.center_mm.z()}, .size_mm = cube.size_mm};
}

namespace detail {
bool WriteTestCube(const Iso9283TestWire& test, nlohmann::json* value) {
  *value = test.cube_auto || !test.cube ? nlohmann::json("auto") : nlohmann::json(*test.cube);
  return true;
}
void ReadTestCube(const nlohmann::json* value, const std::string& path, Iso9283TestWire* test) {
  if (value == nullptr) ThrowWire(path, "required");
  if (value->is_string() && value->get<std::string>() == "auto") {
    test->cube_auto = true;
  } else {
    Iso9283CubeWire cube;
    ReadWire(*value, path, &cube);
    test->cube = cube;
  }
}
}  // namespace detail

bool RequestReader<Iso9283TestWire>::Read(const nlohmann::json& value, const std::string& path, Problems* problems,
                                          Iso9283TestWire* out) {
  const std::size_t before = problems->size();
  ObjectReader r(value, path, problems);
  if (!r.ok()) return false;
  ReadRequest(r, out);
  const std::string cube_path = JoinPath(path, "cube");
  if (const nlohmann::json* cube = r.Get("cube"); cube == nullptr) {
    problems->Add(cube_path, "required: {\"center_mm\": [x, y, z], \"size_mm\": s} or \"auto\"");
  } else if (cube->is_string() && cube->get<std::string>() == "auto") {
    out->cube_auto = true;
  } else if (cube->is_object()) {
    Iso9283CubeWire read;
    if (ReadRequestObject(*cube, cube_path, problems, &read)) out->cube = read;
  } else {
    problems->Add(cube_path, "expected an object {\"center_mm\", \"size_mm\"} or \"auto\"");
  }
  r.RejectUnknown(WireFieldNames<Iso9283TestWire>());
  return problems->size() == before;
}

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
double Deg(double rad) { return std::isfinite(rad) ? rad * kDegPerRad : kNaN; }
}  // namespace

Iso9283FiguresWire ToWire(const Iso9283Result& result) {
  Iso9283FiguresWire out;
  for (const Iso9283PoseFigures& f : result.poses) {
    out.poses.push_back({.pose = Iso9283PoseName(f.pose),
                         .cycles = f.cycles,
                         .command_mm = {f.command_mm.x(), f.command_mm.y(), f.command_mm.z()},
                         .ap_mm = f.ap_mm,
                         .apx_mm = f.ap_xyz_mm.x(),
                         .apy_mm = f.ap_xyz_mm.y(),
                         .apz_mm = f.ap_xyz_mm.z(),
                         .apa_deg = Deg(f.ap_abc_rad.x()),
                         .apb_deg = Deg(f.ap_abc_rad.y()),
                         .apc_deg = Deg(f.ap_abc_rad.z()),
                         .rpl_mm = f.rp_l_mm,
                         .rpa_deg = Deg(f.rp_abc_rad.x()),
                         .rpb_deg = Deg(f.rp_abc_rad.y()),
                         .rpc_deg = Deg(f.rp_abc_rad.z())});
  }
  for (const Iso9283Distance& d : result.distances) {
    out.distances.push_back({.from = Iso9283PoseName(d.from),
                             .to = Iso9283PoseName(d.to),
                             .cycles = d.cycles,
                             .command_mm = d.command_mm,
                             .ad_mm = d.ad_mm,
                             .adx_mm = d.ad_xyz_mm.x(),
                             .ady_mm = d.ad_xyz_mm.y(),
                             .adz_mm = d.ad_xyz_mm.z(),
                             .rd_mm = d.rd_mm});
  }
  return out;
}

namespace {

// A CSV cell: empty for a figure the row has not or that is not measurable (NaN).
std::string Cell(double value) {
  if (!std::isfinite(value)) return "";
  std::ostringstream o;
  o << std::setprecision(9) << value;
  return o.str();
}

void CsvRows(const std::string& set, const Iso9283FiguresWire& figures, std::ostringstream* out) {
  for (const Iso9283PoseWire& p : figures.poses) {
    *out << set << ',' << p.pose << ',' << p.cycles;
    for (double v : {p.ap_mm, p.apx_mm, p.apy_mm, p.apz_mm, p.apa_deg, p.apb_deg, p.apc_deg, p.rpl_mm, p.rpa_deg,
                     p.rpb_deg, p.rpc_deg}) {
      *out << ',' << Cell(v);
    }
    *out << ",,,,,,\n";
  }
  for (const Iso9283DistanceWire& d : figures.distances) {
    *out << set << ',' << d.from << '-' << d.to << ',' << d.cycles << ",,,,,,,,,,,";
    for (double v : {d.command_mm, d.ad_mm, d.adx_mm, d.ady_mm, d.adz_mm, d.rd_mm}) *out << ',' << Cell(v);
    *out << '\n';
  }
}

}  // namespace

std::string Iso9283Csv(const Iso9283ReportWire& report) {
  std::ostringstream out;
  out << "set,pose,cycles,AP_mm,APx_mm,APy_mm,APz_mm,APa_deg,APb_deg,APc_deg,RPl_mm,RPa_deg,RPb_deg,RPc_deg,"
         "Dc_mm,AD_mm,ADx_mm,ADy_mm,ADz_mm,RD_mm\n";
  CsvRows("measured", report.measured, &out);
  if (report.calibrated) CsvRows("calibrated", *report.calibrated, &out);
  return out.str();
}

ROBOCAL_WIRE_DEFINE(Iso9283CubeWire);
ROBOCAL_WIRE_DEFINE(Iso9283TestWire);
ROBOCAL_WIRE_DEFINE(PlanTestWire);
ROBOCAL_WIRE_DEFINE(Iso9283PlannedPoseWire);
ROBOCAL_WIRE_DEFINE(TestTagWire);
ROBOCAL_WIRE_DEFINE(Iso9283PlanWire);
ROBOCAL_WIRE_DEFINE(Iso9283PoseWire);
ROBOCAL_WIRE_DEFINE(Iso9283DistanceWire);
ROBOCAL_WIRE_DEFINE(Iso9283FiguresWire);
ROBOCAL_WIRE_DEFINE(Iso9283ReportWire);

}  // namespace robocal::api
