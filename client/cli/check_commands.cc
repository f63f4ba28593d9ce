// Drift checks and a robot's calibration history: `check`, `robot history`, `robot calibrate`, `robot rollback`
// (docs/drift.md).
#include <ctime>
#include <iomanip>
#include <limits>
#include <sstream>
#include <string>

#include "command.h"
#include "robocal/client/csv.h"
#include "support.h"

namespace robocal::cli {
namespace {

std::string Time(std::int64_t unix_ms) {
  const std::time_t t = static_cast<std::time_t>(unix_ms / 1000);
  std::tm tm{};
  gmtime_r(&t, &tm);
  std::ostringstream o;
  o << std::put_time(&tm, "%Y-%m-%d %H:%M:%S UTC");
  return o.str();
}

void PrintHistory(const api::RobotHistoryWire& h, std::ostream& out) {
  out << "robot " << h.robot << ": "
      << (h.current_entry ? "carries the calibration of campaign " + h.current_campaign + " (entry " +
                                std::to_string(*h.current_entry) + ")"
                          : std::string("carries no calibration"))
      << "\n";
  for (const api::HistoryEntryWire& e : h.entries) {
    out << std::setw(4) << e.entry << "  " << Time(e.at_unix_ms) << "  " << std::left << std::setw(11)
        << api::WireName(e.kind) << std::right << " " << e.campaign;
    if (e.verdict) {
      out << "  " << api::WireName(*e.verdict) << " (" << Fixed(e.statistic.value_or(0.0), 3) << " / "
          << Fixed(e.threshold.value_or(0.0), 3) << ")";
      for (const std::string& s : e.suspects) out << " " << s;
    }
    if (e.rolled_back_to) out << "  back to entry " << *e.rolled_back_to;
    out << "  by " << e.by.value_or("(no tokens)");
    if (!e.note.empty()) out << "  \"" << e.note << "\"";
    out << "\n";
  }
}

int ShowHistory(Invocation& in, const api::RobotHistoryWire& h) {
  if (in.json) {
    PrintJson(in.out, h);
  } else {
    PrintHistory(h, in.out);
  }
  return kExitOk;
}

}  // namespace

int Check(Invocation& in) {
  const std::string& robot_id = in.args[0];
  const std::string& path = in.args[1];
  api::DriftCheckRequest request;
  request.measurements = ReadMeasurementFile(in, path, [&] { return robot_id; }).measurements;
  if (in.Has("--type")) request.measurement_type = in.Enum("--type", MeasurementType::kPose);
  request.frames = in.Enum("--frames", request.frames);
  // Any number: the service says which it takes (its error names the field and the range).
  request.false_alarm_rate = in.Number("--rate", request.false_alarm_rate, std::numeric_limits<double>::lowest());
  request.seed = in.Seed("--seed", request.seed);
  const api::DriftCheckWire c = in.Client().CheckRobot(robot_id, request);
  if (in.json) {
    PrintJson(in.out, c);
    return kExitOk;
  }
  in.out << "robot " << c.robot << " against the calibration of campaign " << c.campaign << ": "
         << api::WireName(c.verdict) << "\n";
  in.out << "  residual level " << Fixed(c.statistic, 3) << " (threshold " << Fixed(c.threshold, 3) << ", p "
         << Fixed(c.p_value, 3) << "); largest one-parameter drop " << Fixed(c.largest_drop, 2) << " (threshold "
         << Fixed(c.drop_threshold, 2) << ", " << c.num_candidates << " parameters)\n";
  in.out << "  " << c.num_measurements << " shots, position RMS " << Fixed(c.rms_position_mm, 3) << " mm (expected "
         << Fixed(c.expected_rms_position_mm, 3) << " mm), frames " << api::WireName(c.frames)
         << ", false alarm rate " << Fixed(c.false_alarm_rate, 3) << "\n";
  for (const api::DriftSuspectWire& s : c.suspects) {
    in.out << "  suspect " << s.parameter << (s.joint_offset ? " (joint offset)" : "") << ": " << Fixed(s.change, 4)
           << " +- " << Fixed(s.std, 4) << " " << s.unit;
    if (!s.equivalent.empty()) {
      in.out << " (or";
      for (const std::string& e : s.equivalent) in.out << " " << e;
      in.out << ")";
    }
    in.out << "\n";
  }
  in.out << "  history entry " << c.history_entry << "\n";
  return kExitOk;
}

int RobotHistory(Invocation& in) {
  const api::RobotHistoryWire h = in.Client().RobotHistory(in.args[0]);
  return ShowHistory(in, h);
}

int RobotCalibrate(Invocation& in) {
  const api::RobotHistoryWire h = in.Client().CalibrateRobot(in.args[0], in.args[1], in.Option("--note"));
  return ShowHistory(in, h);
}

int RobotRollback(Invocation& in) {
  const std::int64_t entry = tools::ParseIntegerFlag("ENTRY", in.args[1], 1, std::numeric_limits<long long>::max());
  const api::RobotHistoryWire h = in.Client().RollbackRobot(in.args[0], entry, in.Option("--note"));
  return ShowHistory(in, h);
}

}  // namespace robocal::cli
