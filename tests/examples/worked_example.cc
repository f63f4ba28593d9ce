// The README's worked example of the core, built and run by ctest so that it stays true.
#include <iostream>

#include "robocal/core/error_model.h"
#include "robocal/core/identifiability.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/presets.h"

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
  return s.identifiable.size() == 20 ? 0 : 1;
}
