// The README's worked example of the core, built and run by ctest so that it stays true.
#include <iostream>

#include "robocal/core/compensation.h"
#include "robocal/core/error_model.h"
#include "robocal/core/identification.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/planning.h"
#include "robocal/core/presets.h"
#include "robocal/core/virtual_cell.h"

int main() {
  using namespace robocal;
  const RobotModel robot = Preset("grinder5");  // X, Y, Z slides (mm), C and A axes (rad)

  Eigen::VectorXd q(5);
  q << 400.0, 300.0, 200.0, 0.5, -0.3;
  const Transform T_world_tool = ForwardKinematics(robot, q);
  std::cout << "tool position [mm]: " << T_world_tool.translation().transpose() << "\n";

  // How the tool pose moves per unit geometric error: 6 rows (mm, rad) x 42 error parameters.
  KinematicsWorkspace ws(robot);
  Eigen::MatrixXd e(MeasurementRows(MeasurementType::kPose), robot.num_error_parameters());
  IdentificationJacobian(robot, q, Eigen::VectorXd(), MeasurementType::kPose, &ws, e);
  const int k = robot.ParameterIndex("A.ry");
  std::cout << "d(position)/d(A.ry) [mm/rad]: " << e.col(k).head<3>().transpose() << "\n";

  // Which error parameters can a 6-D tracker tell apart?
  const IdentifiabilitySummary s = FindIdentifiableParameters(robot, MeasurementType::kPose);
  std::cout << s.BriefReport() << "\n";
  for (const DroppedParameter& d : s.dropped) {
    if (d.name == "Z.dz") std::cout << d.name << ": " << d.reason << "\n";
  }

  // Plan 10 measurement configurations with the paper's Solis & Wets preset.
  ObservabilityOptions observability;
  observability.measurement_type = MeasurementType::kPose;
  observability.parameters = s.identifiable;
  SolisWetsOptions options = SolisWetsOptions::Paper();  // k_max 100, Scent 5, Fcent 3, sigma 1 in [0.1, 3]
  options.seed = 7;
  const Plan plan = PlanSolisWets(robot, 10, observability, options);
  std::cout << plan.summary.BriefReport() << "\n";
  const bool improved = plan.summary.final.condition_number < plan.summary.initial.condition_number;

  // Measure the plan in a simulated cell (hidden errors, tracker 3 m away, 0.015 mm noise, 10 shots per
  // pose), identify, and compensate a command.
  VirtualCell cell(robot);
  const Calibration cal = Identify(robot, cell.MeasureAll(plan.configurations));
  std::cout << cal.summary.BriefReport() << "\n";
  const CompensationResult r = CompensateJoints(cal, robot, q);
  std::cout << "compensated joints: " << r.joints.transpose() << (r.converged ? " (converged)" : "") << "\n";
  const bool calibrated = cal.summary.termination == Termination::kConvergence &&
                          cal.summary.after.rms_position_mm < 0.1 * cal.summary.before.rms_position_mm;
  return s.identifiable.size() == 20 && improved && calibrated && r.converged ? 0 : 1;
}
