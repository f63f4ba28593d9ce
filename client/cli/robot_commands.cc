// robocal robots, robot register | get | delete | forward.
#include <algorithm>
#include <array>
#include <iomanip>
#include <limits>

#include "cli.h"
#include "command.h"
#include "support.h"

namespace robocal::cli {
namespace {

void PrintRobot(const api::Robot& robot, std::ostream& out) {
  out << robot.id << ": " << robot.joints.size() << " joints (" << api::WireName(robot.convention) << "), "
      << robot.error_parameters.size() << " error parameters";
  if (robot.urdf) out << ", from URDF " << robot.urdf->base_link << " -> " << robot.urdf->tip_link;
  if (robot.calibrated_from) {
    out << ", calibrated from campaign " << robot.calibrated_from->campaign << " (robot " << robot.calibrated_from->robot
        << ")";
  }
  out << "\n";
  std::size_t width = 8;
  for (const api::RobotJoint& j : robot.joints) width = std::max(width, j.name.size() + 1);
  for (const api::RobotJoint& j : robot.joints) {
    out << "  " << std::left << std::setw(static_cast<int>(width)) << j.name << std::setw(10) << api::WireName(j.type)
        << std::right << Fixed(j.min, 3) << " .. " << Fixed(j.max, 3) << " " << j.unit;
    // Joint terms the robot holds (a compliant calibration registered as a robot).
    if (j.compliance_deg_per_nm != 0.0) out << ", compliance " << j.compliance_deg_per_nm << " deg/(N*m)";
    if (j.harmonics_deg != std::array<double, 4>{}) {
      const std::array<double, 4>& h = j.harmonics_deg;
      out << ", harmonics sin1 " << h[0] << " cos1 " << h[1] << " sin2 " << h[2] << " cos2 " << h[3] << " deg";
    }
    out << "\n";
  }
  if (robot.calibrated_from && robot.calibrated_from->joint_ranges.size() == robot.joints.size()) {
    out << "  calibrated over:";
    for (std::size_t i = 0; i < robot.joints.size(); ++i) {
      const api::JointRangeWire& r = robot.calibrated_from->joint_ranges[i];
      out << (i == 0 ? " " : ", ") << robot.joints[i].name << " " << Fixed(r.min, 1) << " .. " << Fixed(r.max, 1) << " "
          << robot.joints[i].unit;
    }
    out << "\n";
  }
}

int Show(Invocation& in, const api::Robot& robot) {
  if (in.json) {
    PrintJson(in.out, robot);
  } else {
    PrintRobot(robot, in.out);
  }
  return kExitOk;
}

}  // namespace

int Robots(Invocation& in) {
  api::RobotList list;
  list.robots = in.Client().ListRobots();
  if (in.json) {
    PrintJson(in.out, list);
    return kExitOk;
  }
  for (const api::Robot& r : list.robots) {
    in.out << std::left << std::setw(16) << r.id << std::setw(8) << (r.preset ? "preset" : "") << r.joints.size()
           << " joints  " << r.description << std::right << "\n";
  }
  return kExitOk;
}

int RobotRegister(Invocation& in) {
  nlohmann::json body;
  try {
    body = nlohmann::json::parse(ReadFile(in.args[0]));
  } catch (const nlohmann::json::parse_error& e) {
    throw UsageError(in.args[0] + " is not JSON: " + e.what());
  }
  return Show(in, in.Client().RegisterRobot(body));
}

int RobotFromCalibration(Invocation& in) {
  if (!in.Has("--from-calibration") || !in.Has("--id")) {
    throw UsageError("robot register without FILE.json needs --from-calibration CAMPAIGN and --id ID");
  }
  return Show(in, in.Client().RegisterRobotFromCalibration(
                     {in.Option("--id"), in.Option("--description"), in.Option("--from-calibration")}));
}

int RobotImport(Invocation& in) {
  if (!in.Has("--base") || !in.Has("--tip")) throw UsageError("robot import needs --base LINK and --tip LINK");
  api::ImportUrdfRequest request;
  request.urdf = ReadFile(in.args[0]);
  request.base_link = in.Option("--base");
  request.tip_link = in.Option("--tip");
  request.id = in.Option("--id");
  request.description = in.Option("--description");
  if (in.Has("--tool-mm")) {
    const std::vector<std::string> xyz = tools::SplitList("--tool-mm", in.Option("--tool-mm"));
    if (xyz.size() != 3) throw UsageError("--tool-mm takes X,Y,Z (mm)");
    api::PoseWire tool;
    for (int k = 0; k < 3; ++k) {
      tool.position_mm[k] = tools::ParseDoubleFlag("--tool-mm", xyz[k], std::numeric_limits<double>::lowest());
    }
    request.tool = tool;
  }
  return Show(in, in.Client().ImportRobot(request));
}

int RobotGet(Invocation& in) { return Show(in, in.Client().GetRobot(in.args[0])); }

int RobotDelete(Invocation& in) {
  in.Client().DeleteRobot(in.args[0]);
  if (in.json) {
    PrintJson(in.out, nlohmann::json::object());  // the service's reply: DELETE has no resource to return
  } else {
    in.out << "deleted " << in.args[0] << "\n";
  }
  return kExitOk;
}

int RobotForward(Invocation& in) {
  const api::Robot robot = in.Client().GetRobot(in.args[0]);
  const auto joints = ReadJointsFile(in.args[1], robot);
  std::optional<api::PayloadWire> payload;
  if (in.Has("--payload")) payload = ParsePayloadFlag(in.Option("--payload"));
  return WriteForward(in, robot, joints, in.Client().RobotForward(robot.id, joints, payload));
}

}  // namespace robocal::cli
