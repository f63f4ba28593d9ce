// Fuzz target: the CSV files of the CLI and the mock tracker (client::ReadJointsCsv, ReadMeasurementsCsv,
// ReadCompensationTargetsCsv), read for every joint count a robot can have, and written back. The bytes are
// also taken as doubles for the writers: whatever finite value a plan or a measurement holds must survive a
// CSV file.
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <typeinfo>

#include "fuzz_util.h"
#include "robocal/client/csv.h"

namespace {

using robocal::api::MeasurementWire;
using robocal::fuzz::Check;
namespace client = robocal::client;

std::vector<robocal::api::RobotJoint> Joints(int n) {
  std::vector<robocal::api::RobotJoint> joints(n);
  for (int i = 0; i < n; ++i) {
    joints[i].name = "q" + std::to_string(i + 1);
    joints[i].min = -180.0;
    joints[i].max = 180.0;
    joints[i].unit = "deg";
  }
  return joints;
}

// Reads with `read`; a refusal is expected only as the documented std::runtime_error itself (the CLI reports
// it as a usage error; a derived type would come from somewhere the reader does not mean).
template <typename ReadFn>
auto ReadCsv(const std::string& text, ReadFn read) -> std::optional<decltype(read(std::declval<std::istream&>()))> {
  std::istringstream in(text);
  try {
    return read(in);
  } catch (const std::runtime_error& e) {
    Check(typeid(e) == typeid(std::runtime_error), "the CSV readers refuse input with std::runtime_error");
    return std::nullopt;
  }
}

bool SameMeasurements(const std::vector<MeasurementWire>& a, const std::vector<MeasurementWire>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].joints != b[i].joints || a[i].pose.position_mm != b[i].pose.position_mm ||
        a[i].pose.has_orientation != b[i].pose.has_orientation ||
        (a[i].pose.has_orientation && a[i].pose.quaternion != b[i].pose.quaternion)) {
      return false;
    }
  }
  return true;
}

void CheckJointsRoundTrip(int n, const std::vector<std::vector<double>>& rows) {
  std::ostringstream out;
  client::WriteJointsCsv(out, Joints(n), rows);
  const auto again = ReadCsv(out.str(), [&](std::istream& in) { return client::ReadJointsCsv(in, n); });
  Check(again.has_value() && *again == rows, "written joint rows read back unchanged");
}

void CheckMeasurementsRoundTrip(int n, const std::vector<MeasurementWire>& measurements) {
  std::ostringstream out;
  client::WriteMeasurementsCsv(out, Joints(n), measurements);
  const auto again = ReadCsv(out.str(), [&](std::istream& in) { return client::ReadMeasurementsCsv(in, n); });
  Check(again.has_value() && SameMeasurements(*again, measurements), "written measurements read back unchanged");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text = robocal::fuzz::Text(data, size);
  for (int n = 1; n <= robocal::kMaxJoints; ++n) {
    if (const auto rows = ReadCsv(text, [&](std::istream& in) { return client::ReadJointsCsv(in, n); })) {
      for (const auto& row : *rows) Check(static_cast<int>(row.size()) == n, "a joint row has n values");
      CheckJointsRoundTrip(n, *rows);
    }
    if (const auto shots = ReadCsv(text, [&](std::istream& in) { return client::ReadMeasurementsCsv(in, n); })) {
      for (const auto& m : *shots) Check(static_cast<int>(m.joints.size()) == n, "a measurement has n joints");
      CheckMeasurementsRoundTrip(n, *shots);
    }
    // Compensation targets: each row a joint command of n values or a pose with flags in {-1, 0, 1}.
    if (const auto targets =
            ReadCsv(text, [&](std::istream& in) { return client::ReadCompensationTargetsCsv(in, n); })) {
      for (const auto& t : *targets) {
        Check(t.pose.has_value() != (static_cast<int>(t.joints.size()) == n), "a target is joints or a pose");
        for (int flag : {t.configuration.shoulder, t.configuration.elbow, t.configuration.wrist}) {
          Check(flag >= -1 && flag <= 1, "a flag is -1, 0 or 1");
        }
        if (!t.pose) Check(t.configuration == robocal::ArmConfiguration{}, "no flags on a joint target");
      }
    }
  }

  // The writing side: the bytes as finite doubles, 7 per row (6 joints and a value to spare for positions).
  std::vector<double> values;
  for (std::size_t i = 0; i + sizeof(double) <= size; i += sizeof(double)) {
    double v;
    std::memcpy(&v, data + i, sizeof v);
    if (std::isfinite(v)) values.push_back(v);
  }
  const int n = 6;
  std::vector<std::vector<double>> rows;
  std::vector<MeasurementWire> shots;
  for (std::size_t i = 0; i + n + 1 <= values.size(); i += n + 1) {
    rows.emplace_back(values.begin() + i, values.begin() + i + n);
    MeasurementWire m;
    m.joints = rows.back();
    m.pose.position_mm = {values[i + n], values[i], values[i + 1]};
    m.pose.quaternion = {values[i + 2], values[i + 3], values[i + 4], values[i + 5]};
    shots.push_back(m);
  }
  CheckJointsRoundTrip(n, rows);
  CheckMeasurementsRoundTrip(n, shots);
  return 0;
}
