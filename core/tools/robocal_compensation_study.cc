// robocal-compensation-study: the compensation study of docs/compensation.md as a command
// (RunCompensationStudy). Exit codes: 0 done, 1 the run failed, 2 bad command line.
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "flags.h"
#include "robocal/core/compensation_study.h"

namespace {

constexpr const char* kUsage = R"(usage: robocal-compensation-study [options]

Per robot, on a calibration with random errors of the given size on every site (tracker 3 m from the base):
- N random nominal joint commands within the limits (--joint-targets): the share that converges, the others by
  termination, and for those the smallest singular value of the joint Jacobian (columns scaled to unit length)
  and the distance in joint space to the nearest singularity found by descending it;
- for a 6R arm with named branches, N random poses the calibrated robot reaches (--cartesian-targets), asked
  without joints on the branch of the joints that reach them: the share solved there (another branch is never
  taken), and the same poses without any hint (the default branch);
- a program of N poses along a smooth path that stays on one branch (--path-targets), as a sequence: branch
  changes (there should be none), the largest joint step and the deviation from the path's own joints.
Same flags, same figures.

options:
  --robots LIST             presets and ur10_mdh (a UR10-like arm in modified DH, +-170 deg), comma-separated
                            (default grinder5,puma560,ur5e,ur10_mdh)
  --joint-targets N         random joint commands per robot (default 10000)
  --cartesian-targets N     random Cartesian targets per 6R robot (default 2000)
  --path-targets N          targets of the smooth path (default 1000)
  --seed S                  seed of the errors and targets (default 1)
  --error-mm SIZE           1-sigma length errors, mm (default 0.3)
  --error-deg SIZE          1-sigma angle errors, degrees (default 0.02)
  --threads N               worker threads, 0 = the machine's cores (default 0); results do not depend on it
  --help, -h                this text
)";

}  // namespace

int main(int argc, char** argv) {
  using namespace robocal::tools;
  const std::vector<std::string> args(argv + 1, argv + argc);
  for (const std::string& a : args) {
    if (a == "--help" || a == "-h") {
      std::cout << kUsage;
      return 0;
    }
  }
  robocal::CompensationStudyOptions o;
  std::string error;
  try {
    for (const auto& [flag, value] : SplitFlags(args, {})) {
      if (flag == "--robots") {
        o.robots = SplitList(flag, value);
      } else if (flag == "--joint-targets") {
        o.joint_targets = static_cast<int>(ParseIntegerFlag(flag, value, 0, 10000000));
      } else if (flag == "--cartesian-targets") {
        o.cartesian_targets = static_cast<int>(ParseIntegerFlag(flag, value, 0, 10000000));
      } else if (flag == "--path-targets") {
        o.path_targets = static_cast<int>(ParseIntegerFlag(flag, value, 0, 10000000));
      } else if (flag == "--seed") {
        o.seed = ParseSeedFlag(flag, value);
      } else if (flag == "--error-mm") {
        o.error_mm = ParseDoubleFlag(flag, value, 0.0);
      } else if (flag == "--error-deg") {
        o.error_rad = ParseDoubleFlag(flag, value, 0.0) * 3.14159265358979323846 / 180.0;
      } else if (flag == "--threads") {
        o.threads = static_cast<int>(ParseIntegerFlag(flag, value, 0, 256));
      } else {
        throw BadFlag("unknown option '" + flag + "'");
      }
    }
    o.IsValid(&error);
  } catch (const BadFlag& e) {
    error = e.what();
  }
  if (!error.empty()) {
    std::cerr << "robocal-compensation-study: " << error << "\n(see robocal-compensation-study --help)\n";
    return 2;
  }
  try {
    const robocal::CompensationStudyResult result = robocal::RunCompensationStudy(o);
    std::cout << robocal::FormatCompensationStudy(result);
    std::fprintf(stderr, "%.1f s\n", result.seconds);
  } catch (const std::invalid_argument& e) {
    std::cerr << "robocal-compensation-study: " << e.what() << "\n(see robocal-compensation-study --help)\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "robocal-compensation-study: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
