// Fuzz target: the body of POST /v1/campaigns/{c}/measurements (api::ParseMeasurementBatchRequest), against
// every preset and measurement type, then the form the service stores a measurement in.
#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace robocal;
  const std::optional<nlohmann::json> body = fuzz::Body(data, size);
  if (!body) return 0;
  const api::Limits limits;
  for (const RobotModel& model : fuzz::Presets()) {
    for (MeasurementType type : {MeasurementType::kPosition, MeasurementType::kPositionAxis, MeasurementType::kPose}) {
      const auto parse = [&](const nlohmann::json& b) {
        return api::ParseMeasurementBatchRequest(b, model, type, limits);
      };
      const auto request = fuzz::Parsed([&] { return parse(*body); });
      if (!request) continue;
      for (const api::MeasurementWire& m : request->measurements) {
        fuzz::Check(static_cast<int>(m.joints.size()) == model.num_joints(), "joints sized to the robot");
        fuzz::Check(m.pose.has_orientation || type == MeasurementType::kPosition,
                    "an orientation unless the campaign measures position only");
        // Stored as its JSON and read back by from_json: exactly the same shot, bit for bit.
        const auto stored = api::FromWire<api::MeasurementWire>(nlohmann::json::parse(nlohmann::json(m).dump()));
        fuzz::Check(stored.joints == m.joints && stored.pose.position_mm == m.pose.position_mm &&
                        stored.pose.has_orientation == m.pose.has_orientation &&
                        (!m.pose.has_orientation || stored.pose.quaternion == m.pose.quaternion),
                    "a stored measurement reads back unchanged");
      }
      fuzz::CheckRoundTrip(*request, parse);
    }
  }
  return 0;
}
