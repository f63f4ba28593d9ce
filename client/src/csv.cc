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

// Calls `row` for each data line (after the header) with its numbers; returns the header's fields.
template <typename RowFn>
std::vector<std::string> ReadRows(std::istream& in, RowFn row) {
  std::string line;
  std::vector<std::string> header;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
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
    std::vector<double> values;
    for (std::size_t i = 0; i < fields.size(); ++i) values.push_back(ParseNumber(fields[i], number, i));
    row(values);
  }
  if (header.empty()) throw std::runtime_error("no header line (see the CSV formats in docs/client.md)");
  return header;
}

// Shortest text that reads back as the same double, so that a plan written as CSV is the plan.
void WriteValue(std::ostream& out, double v) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, v);
  out.write(buffer, result.ptr - buffer);
}

}  // namespace

std::string JointColumn(const api::RobotJoint& joint) { return joint.joint.name + "_" + joint.unit; }

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
  const auto header = ReadRows(in, [&](const std::vector<double>& v) {
    api::MeasurementWire m;
    m.joints.assign(v.begin(), v.begin() + std::min(n, v.size()));
    if (v.size() >= n + 3) m.pose.position_mm = {v[n], v[n + 1], v[n + 2]};
    if (v.size() == n + 7) {
      m.pose.quaternion = {v[n + 3], v[n + 4], v[n + 5], v[n + 6]};
    } else {
      m.pose.has_orientation = false;
    }
    measurements.push_back(std::move(m));
  });
  if (header.size() != n + 3 && header.size() != n + 7) {
    throw std::runtime_error("the header has " + std::to_string(header.size()) + " columns; expected " +
                             std::to_string(n) + " joints + x_mm,y_mm,z_mm (+ qw,qx,qy,qz)");
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
  for (const api::RobotJoint& j : joints) out << JointColumn(j) << ",";
  out << (orientation ? "x_mm,y_mm,z_mm,qw,qx,qy,qz\n" : "x_mm,y_mm,z_mm\n");
  for (const auto& m : measurements) {
    for (double v : m.joints) {
      WriteValue(out, v);
      out << ",";
    }
    for (int i = 0; i < 3; ++i) {
      WriteValue(out, m.pose.position_mm[i]);
      out << (i < 2 || orientation ? "," : "\n");
    }
    for (int i = 0; orientation && i < 4; ++i) {
      WriteValue(out, m.pose.quaternion[i]);
      out << (i < 3 ? "," : "\n");
    }
  }
}

void WriteCompensationCsv(std::ostream& out, const std::vector<api::RobotJoint>& joints,
                          const std::vector<api::Compensation>& results, bool sequence) {
  for (const api::RobotJoint& j : joints) out << JointColumn(j) << ",";
  out << "position_error_mm,orientation_error_deg,converged";
  if (sequence) out << ",joint_jump_deg,joint_jump";
  out << "\n";
  for (const api::Compensation& r : results) {
    for (std::size_t i = 0; i < joints.size(); ++i) {
      WriteValue(out, i < r.joints.size() ? r.joints[i] : std::nan(""));
      out << ",";
    }
    WriteValue(out, r.position_error_mm);
    out << ",";
    WriteValue(out, r.orientation_error_deg);
    out << "," << (r.converged ? 1 : 0);
    if (sequence) {
      out << ",";
      if (std::isfinite(r.joint_jump_deg)) WriteValue(out, r.joint_jump_deg);  // empty on the first row
      out << "," << (r.joint_jump ? 1 : 0);
    }
    out << "\n";
  }
}

}  // namespace robocal::client
