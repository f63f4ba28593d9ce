// Fuzz target: the body of POST /v1/campaigns/{c}:compensate (api::ParseCompensateRequest), against every
// preset.
#include "fuzz_util.h"
#include "robocal/core/arm_kinematics.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace robocal;
  const std::optional<nlohmann::json> body = fuzz::Body(data, size);
  if (!body) return 0;
  const api::Limits limits;
  for (const RobotModel& model : fuzz::Presets()) {
    const auto parse = [&](const nlohmann::json& b) { return api::ParseCompensateRequest(b, model, limits); };
    const auto request = fuzz::Parsed([&] { return parse(*body); });
    if (!request) continue;
    const std::size_t n = static_cast<std::size_t>(model.num_joints());
    for (const api::CompensationTargetWire& t : request->targets) {
      // The service dispatches on these: exactly one kind of target, vectors sized to the robot.
      fuzz::Check(t.pose.has_value() != (t.joints.size() == n), "a target is either joints or a pose");
      fuzz::Check(t.start_joints.empty() || (t.pose && t.start_joints.size() == n),
                  "start_joints only on a pose target, sized to the robot");
      fuzz::Check(t.frame == TargetFrame::kTracker || t.frame == TargetFrame::kBase, "frame is tracker or base");
      // A configuration only on a pose target of a robot with named branches, each flag -1, 0 or +1.
      const ArmConfiguration& c = t.configuration;
      fuzz::Check(c == ArmConfiguration{} || (t.pose && ArmSolver::For(model).has_value()),
                  "configuration only on a pose target of a robot with named branches");
      for (int flag : {c.shoulder, c.elbow, c.wrist}) fuzz::Check(flag >= -1 && flag <= 1, "a flag is -1, 0 or 1");
    }
    fuzz::CheckRoundTrip(*request, parse);
  }
  return 0;
}
