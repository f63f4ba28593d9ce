// Fuzz target: the body of POST /v1/robots (api::ParseRegisterRobotRequest), then what the service does with
// an accepted robot: build the core model, store ToJson and parse that again whenever the robot is used.
#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace robocal;
  const std::optional<nlohmann::json> body = fuzz::Body(data, size);
  if (!body) return 0;
  const auto parse = [](const nlohmann::json& b) { return api::ParseRegisterRobotRequest(b, api::Limits{}); };
  const auto request = fuzz::Parsed([&] { return parse(*body); });
  if (!request) return 0;
  fuzz::Check(api::IsValidId(request->id), "a registered robot's id is a valid id");
  // The parser has already had the core check the geometry, so building can no longer fail: an exception
  // here escapes and is a finding.
  const RobotModel model = RobotModel::Build(api::ToSpec(*request));
  fuzz::Check(model.num_joints() >= 1 && model.num_joints() <= kMaxJoints, "joint count within 1..kMaxJoints");
  fuzz::CheckRoundTrip(*request, parse);
  return 0;
}
