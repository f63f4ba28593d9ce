// TEMPORARY: stand-ins for core functions whose implementation has not landed on this branch yet
// (identification, compensation, accuracy). Removed when they merge; every stub throws.
#include <stdexcept>

#include "robocal/core/accuracy.h"
#include "robocal/core/compensation.h"
#include "robocal/core/identification.h"

namespace robocal {
namespace {
[[noreturn]] void Missing(const char* what) { throw std::logic_error(std::string(what) + " not implemented yet"); }
}  // namespace
std::string IdentificationSummary::BriefReport() const { Missing("BriefReport"); }
Calibration Identify(const RobotModel&, const std::vector<Measurement>&, const IdentificationOptions&) {
  Missing("Identify");
}
bool ParseTargetFrame(const std::string&, TargetFrame*) { Missing("ParseTargetFrame"); }
CompensationResult CompensatePose(const Calibration&, const Transform&, TargetFrame, const Eigen::VectorXd&,
                                  const CompensationOptions&) {
  Missing("CompensatePose");
}
CompensationResult CompensateJoints(const Calibration&, const RobotModel&, const Eigen::VectorXd&,
                                    const CompensationOptions&) {
  Missing("CompensateJoints");
}
AccuracyReport ComputeAccuracy(const std::vector<Transform>&, const std::vector<Transform>&, double) {
  Missing("ComputeAccuracy");
}
}  // namespace robocal
