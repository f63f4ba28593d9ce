// Reading and writing the CSV formats of the CLI and the mock tracker.
#include "robocal/client/csv.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

namespace robocal::client {
namespace {

std::vector<std::string> SplitFields(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ',')) {
    const auto first = field.find_first_not_of(" \t\r");
    const auto last = field.find_last_not_of(" \t\r");
    fields.push_back(first == std::string::npos ? std::string() : field.substr(first, last - first + 1));
  }
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

double ParseNumber(const std::string& text, int line, std::size_t column) {
  char* end = nullptr;
  // strtod's ERANGE is not consulted: it also flags results below the normal range (subnormal values, which
  // the writer writes, or text that rounds to zero). Overflow gives an infinity, refused below.
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v)) {
    throw std::runtime_error("line " + std::to_string(line) + ", column " + std::to_string(column + 1) +
                             ": not a finite number: \"" + text + "\"");
  }
  return v;
}

// Calls `row` for each data line (after the header) with its fields and line number; returns the header's
// fields.
template <typename RowFn>
std::vector<std::string> ReadLines(std::istream& in, RowFn row) {
  std::string line;
  std::vector<std::string> header;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    // A byte order mark before the first line (spreadsheets write one) is not part of the header.
    if (number == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    const std::vector<std::string> fields = SplitFields(line);
    if (header.empty()) {
      header = fields;
      continue;
    }
    if (fields.size() != header.size()) {
      throw std::runtime_error("line " + std::to_string(number) + ": expected " + std::to_string(header.size()) +
                               " values (as the header), got " + std::to_string(fields.size()));
    }
    row(fields, number);
  }
  if (header.empty()) throw std::runtime_error("no header line (see the CSV formats in docs/client.md)");
  return header;
}

// Calls `row` for each data line (after the header) with its numbers; returns the header's fields.
template <typename RowFn>
std::vector<std::string> ReadRows(std::istream& in, RowFn row) {
  return ReadLines(in, [&](const std::vector<std::string>& fields, int number) {
    std::vector<double> values;
    for (std::size_t i = 0; i < fields.size(); ++i) values.push_back(ParseNumber(fields[i], number, i));
    row(values);
  });
}

// Shortest text that reads back as the same double, so that a plan written as CSV is the plan.
void WriteValue(std::ostream& out, double v) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, v);
  out.write(buffer, result.ptr - buffer);
}

}  // namespace

std::string JointColumn(const api::RobotJoint& joint) { return joint.name + "_" + joint.unit; }

std::vector<std::vector<double>> ReadJointsCsv(std::istream& in, int num_joints) {
  std::vector<std::vector<double>> rows;
  const auto header = ReadRows(in, [&](const std::vector<double>& v) { rows.push_back(v); });
  if (static_cast<int>(header.size()) != num_joints) {
    throw std::runtime_error("the header has " + std::to_string(header.size()) + " columns; the robot has " +
                             std::to_string(num_joints) + " joints");
  }
  return rows;
}

void WriteJointsCsv(std::ostream& out, const std::vector<api::RobotJoint>& joints,
                    const std::vector<std::vector<double>>& rows) {
  for (std::size_t i = 0; i < joints.size(); ++i) out << (i ? "," : "") << JointColumn(joints[i]);
  out << "\n";
  for (const auto& row : rows) {
    for (std::size_t i = 0; i < row.size(); ++i) {
      if (i) out << ",";
      WriteValue(out, row[i]);
    }
    out << "\n";
  }
}

std::vector<api::MeasurementWire> ReadMeasurementsCsv(std::istream& in, int num_joints) {
  std::vector<api::MeasurementWire> measurements;
  const std::size_t n = static_cast<std::size_t>(num_joints);
  std::vector<std::vector<std::string>> rows;
  std::vector<int> lines;
  const std::vector<std::string> header = ReadLines(in, [&](const std::vector<std::string>& fields, int number) {
    rows.push_back(fields);
    lines.push_back(number);
  });
  // A last column "reflector" names the reflector of each shot (a campaign with several reflectors).
  const bool reflector = !header.empty() && header.back() == "reflector";
  const std::size_t numbers = header.size() - (reflector ? 1 : 0);
  if (numbers != n + 3 && numbers != n + 7) {
    throw std::runtime_error("the header has " + std::to_string(header.size()) + " columns; expected " +
                             std::to_string(n) + " joints + x_mm,y_mm,z_mm (+ qw,qx,qy,qz) (+ reflector)");
  }
  for (std::size_t r = 0; r < rows.size(); ++r) {
    std::vector<double> v;
    for (std::size_t i = 0; i < numbers; ++i) v.push_back(ParseNumber(rows[r][i], lines[r], i));
    api::MeasurementWire m;
    m.joints.assign(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(n));
    m.pose.position_mm = {v[n], v[n + 1], v[n + 2]};
    if (numbers == n + 7) {
      m.pose.quaternion = {v[n + 3], v[n + 4], v[n + 5], v[n + 6]};
    } else {
      m.pose.has_orientation = false;
    }
    if (reflector) {
      m.reflector = rows[r][numbers];
      if (!m.reflector.empty() && !api::IsValidId(m.reflector)) {
        throw std::runtime_error("line " + std::to_string(lines[r]) + ", column " + std::to_string(numbers + 1) +
                                 ": reflector \"" + m.reflector + "\" " + api::kIdRule);
      }
    }
    measurements.push_back(std::move(m));
  }
  if (header[n] != "x_mm") {
    throw std::runtime_error("column " + std::to_string(n + 1) + " must be x_mm (after the " + std::to_string(n) +
                             " joint columns), got \"" + header[n] + "\"");
  }
  return measurements;
}

void WriteMeasurementsCsv(std::ostream& out, const std::vector<api::RobotJoint>& joints,
                          const std::vector<api::MeasurementWire>& measurements) {
  // Position-only measurements have no quaternion to write (a made-up identity would read back as measured).
  const bool orientation = std::all_of(measurements.begin(), measurements.end(),
                                       [](const api::MeasurementWire& m) { return m.pose.has_orientation; });
  const bool reflector = std::any_of(measurements.begin(), measurements.end(),
                                     [](const api::MeasurementWire& m) { return !m.reflector.empty(); });
  for (const api::RobotJoint& j : joints) out << JointColumn(j) << ",";
  out << (orientation ? "x_mm,y_mm,z_mm,qw,qx,qy,qz" : "x_mm,y_mm,z_mm") << (reflector ? ",reflector\n" : "\n");
  for (const auto& m : measurements) {
    for (double v : m.joints) {
      WriteValue(out, v);
      out << ",";
    }
    for (int i = 0; i < 3; ++i) {
      WriteValue(out, m.pose.position_mm[i]);
      if (i < 2 || orientation) out << ",";
    }
    for (int i = 0; orientation && i < 4; ++i) {
      WriteValue(out, m.pose.quaternion[i]);
      if (i < 3) out << ",";
    }
    // Reflector ids follow the id rule: no comma or quote to escape.
    if (reflector) out << "," << m.reflector;
    out << "\n";
  }
}

std::vector<api::CompensationTargetWire> ReadCompensationTargetsCsv(std::istream& in, int num_joints,
                                                                    TargetFrame frame) {
  std::vector<std::vector<std::string>> rows;
  std::vector<int> lines;
  const std::vector<std::string> header = ReadLines(in, [&](const std::vector<std::string>& fields, int number) {
    rows.push_back(fields);
    lines.push_back(number);
  });
  std::vector<api::CompensationTargetWire> targets;
  static const std::vector<std::string> kPose = {"x_mm", "y_mm", "z_mm", "qw", "qx", "qy", "qz"};
  if (header.size() < kPose.size() || !std::equal(kPose.begin(), kPose.end(), header.begin())) {
    if (static_cast<int>(header.size()) != num_joints) {
      throw std::runtime_error("the header has " + std::to_string(header.size()) + " columns; expected the robot's " +
                               std::to_string(num_joints) + " joint columns, or x_mm,y_mm,z_mm,qw,qx,qy,qz " +
                               "(+ shoulder,elbow,wrist) for pose targets");
    }
    for (std::size_t r = 0; r < rows.size(); ++r) {
      api::CompensationTargetWire t;
      for (std::size_t i = 0; i < rows[r].size(); ++i) t.joints.push_back(ParseNumber(rows[r][i], lines[r], i));
      targets.push_back(std::move(t));
    }
    return targets;
  }
  // Pose targets: the flag columns by name, in any order; an empty cell leaves the flag free.
  std::vector<int*> flags;
  for (std::size_t i = kPose.size(); i < header.size(); ++i) {
    if (header[i] != "shoulder" && header[i] != "elbow" && header[i] != "wrist") {
      throw std::runtime_error("column " + std::to_string(i + 1) + ": \"" + header[i] +
                               "\" is not a pose target column (shoulder, elbow, wrist may follow qz)");
    }
  }
  for (std::size_t r = 0; r < rows.size(); ++r) {
    api::CompensationTargetWire t;
    api::PoseWire pose;
    for (std::size_t i = 0; i < 3; ++i) pose.position_mm[i] = ParseNumber(rows[r][i], lines[r], i);
    for (std::size_t i = 0; i < 4; ++i) pose.quaternion[i] = ParseNumber(rows[r][3 + i], lines[r], 3 + i);
    t.pose = pose;
    t.frame = frame;
    for (std::size_t i = kPose.size(); i < header.size(); ++i) {
      const std::string& text = rows[r][i];
      if (text.empty()) continue;
      int* flag = header[i] == "shoulder" ? &t.configuration.shoulder
                  : header[i] == "elbow"  ? &t.configuration.elbow
                                          : &t.configuration.wrist;
      if (!ParseConfigurationFlag(header[i], text, flag)) {
        throw std::runtime_error("line " + std::to_string(lines[r]) + ", column " + std::to_string(i + 1) + ": not a " +
                                 header[i] + " flag: \"" + text + "\"");
      }
    }
    targets.push_back(std::move(t));
  }
  return targets;
}

void WriteCompensationCsv(std::ostream& out, const std::vector<api::RobotJoint>& joints,
                          const std::vector<api::Compensation>& results, bool sequence) {
  // The branch columns for a robot with named branches (every result with joints says its branch).
  const bool branches = std::any_of(results.begin(), results.end(),
                                    [](const api::Compensation& r) { return r.configuration.has_value(); });
  for (const api::RobotJoint& j : joints) out << JointColumn(j) << ",";
  out << "position_error_mm,orientation_error_deg,predicted_error_mm,converged";
  if (branches) out << ",shoulder,elbow,wrist";
  if (sequence) out << ",joint_jump_deg,joint_jump";
  if (sequence && branches) out << ",branch_change";
  out << "\n";
  for (const api::Compensation& r : results) {
    for (std::size_t i = 0; i < joints.size(); ++i) {
      WriteValue(out, i < r.joints.size() ? r.joints[i] : std::nan(""));
      out << ",";
    }
    WriteValue(out, r.position_error_mm);
    out << ",";
    WriteValue(out, r.orientation_error_deg);
    out << ",";
    if (std::isfinite(r.predicted_error_mm)) WriteValue(out, r.predicted_error_mm);  // empty: none (no joints)
    out << "," << (r.converged ? 1 : 0);
    if (branches) {
      if (r.configuration) {
        out << "," << ShoulderName(r.configuration->shoulder) << "," << ElbowName(r.configuration->elbow) << ","
            << WristName(r.configuration->wrist);
      } else {
        out << ",,,";  // no joints, no branch
      }
    }
    if (sequence) {
      out << ",";
      if (std::isfinite(r.joint_jump_deg)) WriteValue(out, r.joint_jump_deg);  // empty on the first row
      out << "," << (r.joint_jump ? 1 : 0);
    }
    if (sequence && branches) out << "," << (r.branch_change ? 1 : 0);
    out << "\n";
  }
}

}  // namespace robocal::client
