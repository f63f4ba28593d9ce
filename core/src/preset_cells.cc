// Preset cells: one measurement cell per robot preset, laid out as a real cell would be (docs/cells.md,
// "Preset cells").
#include <cmath>
#include <stdexcept>

#include "robocal/core/cell.h"

namespace robocal {
namespace {

using V = Eigen::Vector3d;

// A laser tracker's usual window for a 1.5-inch SMR: from 1.5 m (closer, the head cannot follow a moving
// reflector and the angular resolution is wasted) to 15 m.
TrackerSpec Tracker(const V& position_mm) {
  TrackerSpec tracker;
  tracker.position_mm = position_mm;
  tracker.min_distance_mm = 1500.0;
  tracker.max_distance_mm = 15000.0;
  return tracker;
}

// A floor slab whose top is at z = top_mm, wide enough to hold the robot and the tracker.
BoxObstacle Floor(double top_mm) { return {"floor", V(-4000, -4000, top_mm - 500), V(4000, 4000, top_mm)}; }

CellSpec Ur5eCell() {
  // The arm on the floor (its base flange at z = 0), a fixture table in front of it, the tracker 2.7 m away on
  // a tripod, its head 1.0 m above the floor.
  CellSpec spec;
  spec.tracker = Tracker(V(2300, -1400, 1400));
  spec.obstacles = {Floor(-10.0), {"table", V(350, 350, -10), V(950, 950, 250)}};
  spec.clearance_mm = 20.0;
  spec.joint_min = Eigen::VectorXd::Constant(6, -2 * M_PI);
  spec.joint_max = Eigen::VectorXd::Constant(6, 2 * M_PI);
  spec.joint_min[1] = -M_PI;
  spec.joint_max[1] = 0.0;
  return spec;
}

CellSpec Puma560Cell() {
  // The PUMA's base frame is at the shoulder, about 670 mm above the floor on its pedestal; a table to its
  // side, and the tracker 2.8 m away, its head 1.2 m above the floor.
  CellSpec spec;
  spec.tracker = Tracker(V(2300, -1500, 530));
  spec.obstacles = {Floor(-680.0), {"table", V(400, 400, -680), V(1000, 1000, -250)}};
  spec.clearance_mm = 20.0;
  return spec;
}

CellSpec Grinder5Cell() {
  // The gantry's frame is at its X slide, above the work: the spindle tip hangs at z = -370 mm with the Z ram
  // up. The workpiece table under the head, the floor 1.6 m below the slide, and the tracker beside the
  // gantry at the head's height, 2 m off its side.
  CellSpec spec;
  spec.tracker = Tracker(V(400, -1900, -500));
  spec.obstacles = {Floor(-1600.0), {"table", V(-300, -150, -1600), V(1100, 1050, -700)}};
  spec.clearance_mm = 20.0;
  return spec;
}

}  // namespace

CellSpec PresetCellSpec(const std::string& robot) {
  if (robot == "grinder5") return Grinder5Cell();
  if (robot == "puma560") return Puma560Cell();
  if (robot == "ur5e") return Ur5eCell();
  throw std::invalid_argument("no preset cell for robot '" + robot + "' (presets: grinder5, puma560, ur5e)");
}

}  // namespace robocal
