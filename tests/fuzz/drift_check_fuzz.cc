// Fuzz target: the body of POST /v1/robots/{r}:check (api::ParseDriftCheckRequest), against every preset and the
// measurement type its calibration may have measured.
#include "fuzz_util.h"

#include "robocal/api/drift.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace robocal;
  const std::optional<nlohmann::json> body = fuzz::Body(data, size);
  if (!body) return 0;
  const api::Limits limits;
  for (const RobotModel& model : fuzz::Presets()) {
    for (MeasurementType type : {MeasurementType::kPosition, MeasurementType::kPositionAxis, MeasurementType::kPose}) {
      const auto parse = [&](const nlohmann::json& b) { return api::ParseDriftCheckRequest(b, model, type, limits); };
      const auto request = fuzz::Parsed([&] { return parse(*body); });
      if (!request) continue;
      fuzz::Check(!request->measurements.empty() && request->measurements.size() <= api::kMaxCheckShots,
                  "1..kMaxCheckShots measurements");
      const MeasurementType checked = request->measurement_type.value_or(type);
      fuzz::Check(MeasurementRows(checked) <= MeasurementRows(type), "no more than the calibration measured");
      for (const api::MeasurementWire& m : request->measurements) {
        fuzz::Check(static_cast<int>(m.joints.size()) == model.num_joints(), "joints sized to the robot");
        fuzz::Check(m.test_pose.empty() && m.cycle == 0, "a check's shots carry no test tags");
      }
      fuzz::Check(request->false_alarm_rate >= 1e-4 && request->false_alarm_rate <= 0.25, "a rate in range");
    }
  }
  return 0;
}
