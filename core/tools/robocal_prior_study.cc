// robocal-prior-study: parameter priors on real data (docs/identification.md, "Parameter priors"). Reads the IPA
// UR10's Series B file itself (tests/data/ipa: ';' separated, decimal commas, joints in rad, the T-Mac's pose in mm
// and intrinsic X-Y-Z Euler degrees), draws N calibration poses at random per seed, and fits 6-D geometric
// calibrations without priors and with priors: auto, judged on every other pose (held-out mean position error).
// Exit codes: 0 done, 1 the run failed, 2 bad command line.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

#include "flags.h"
#include "robocal/core/identification.h"
#include "robocal/core/kinematics.h"
#include "robocal/core/model_choice.h"
#include "robocal/core/random.h"
#include "robocal/core/robot_model.h"
#include "robocal/core/transforms.h"

namespace {

constexpr const char* kUsage = R"(usage: robocal-prior-study --csv FILE [options]

The IPA UR10's Series B (tests/data/ipa/series_b_joint_configurations.csv): per N and seed, N calibration poses
drawn at random (the rest held out), a 6-D geometric fit without priors and one with priors: auto (5-fold
cross-validation of the prior scale), and their held-out mean position error. The robot is the UR10's DH table
(the kinematics of ur_description's URDF) with the T-Mac 109 mm out of the flange, turned -90 deg about it; the
tracker's datasheet uncertainty; stale readings (FlagStaleShots, in file order) left out of both sets.

options:
  --csv FILE        the Series B file
  --n LIST          calibration poses, comma-separated (default 20,30,100)
  --seeds K         seeds 1..K of the draw (default 5)
  --folds F         folds of priors: auto (default 5)
  --frame-priors    put the default lengths' and angles' priors on the base and tool sites too
  --free A,B        no prior on these parameters
  --scales LIST     the candidate scales of priors: auto (inf: none; default 0.25,0.5,1,2,4,inf)
  --help, -h        this text
)";

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

// A number with a decimal comma.
double Number(std::string text) {
  for (char& c : text)
    if (c == ',') c = '.';
  return std::stod(text);
}

// The UR10 as the DH table Universal Robots publish, which ur_description's URDF writes as joint origins: the
// joints and the flange (tool0) are the same frames; the URDF's base_link is the DH base turned half a turn about
// z, which the fit's registration of the tracker -> base frame absorbs.
robocal::RobotModel Ur10() {
  robocal::RobotModelSpec spec;
  spec.name = "ur10";
  spec.convention = robocal::GeometryConvention::kStandardDh;
  const double d[6] = {127.3, 0.0, 0.0, 163.941, 115.7, 92.2};
  const double a[6] = {0.0, -612.0, -572.3, 0.0, 0.0, 0.0};
  const double alpha[6] = {kPi / 2, 0.0, 0.0, kPi / 2, -kPi / 2, 0.0};
  const char* names[6] = {"joint1", "joint2", "joint3", "joint4", "joint5", "joint6"};
  for (int i = 0; i < 6; ++i) {
    robocal::JointSpec j;
    j.name = names[i];
    j.d_mm = d[i];
    j.a_mm = a[i];
    j.alpha_rad = alpha[i];
    j.min = -2 * kPi;
    j.max = 2 * kPi;
    spec.joints.push_back(j);
  }
  spec.T_flange_tool = robocal::TransformFromXyzRpy({0.0, 0.0, 109.0}, {0.0, 0.0, -90.0 * kDeg});
  return robocal::RobotModel::Build(spec);
}

std::vector<robocal::Measurement> ReadSeriesB(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::string line;
  std::getline(in, line);
  std::map<std::string, int> column;
  {
    std::stringstream header(line);
    std::string name;
    for (int k = 0; std::getline(header, name, ';'); ++k) column[name] = k;
  }
  const char* joints[6] = {"shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                           "wrist_1_joint",      "wrist_2_joint",       "wrist_3_joint"};
  std::vector<robocal::Measurement> out;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::vector<std::string> cells;
    std::stringstream row(line);
    std::string cell;
    while (std::getline(row, cell, ';')) cells.push_back(cell);
    const auto at = [&](const std::string& name) { return Number(cells.at(column.at(name))); };
    robocal::Measurement m;
    m.joints.resize(6);
    for (int i = 0; i < 6; ++i) m.joints[i] = at(joints[i]);
    // Intrinsic X-Y-Z: R = Rx(a) Ry(b) Rz(c).
    const Eigen::Matrix3d r = (Eigen::AngleAxisd(at("measurement_rx") * kDeg, Eigen::Vector3d::UnitX()) *
                               Eigen::AngleAxisd(at("measurement_ry") * kDeg, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(at("measurement_rz") * kDeg, Eigen::Vector3d::UnitZ()))
                                  .toRotationMatrix();
    m.T_world_tool = robocal::Transform::Identity();
    m.T_world_tool.linear() = r;
    m.T_world_tool.translation() << at("measurement_x"), at("measurement_y"), at("measurement_z");
    out.push_back(m);
  }
  return out;
}

// The held-out mean distance between measured and calibrated positions.
double HeldOutMean(const robocal::Calibration& c, const std::vector<robocal::Measurement>& held_out) {
  robocal::KinematicsWorkspace ws(c.model);
  double sum = 0.0;
  for (const robocal::Measurement& m : held_out) {
    sum += (m.T_world_tool.translation() - robocal::ForwardKinematics(c.model, m.joints, c.errors, &ws).translation())
               .norm();
  }
  return sum / static_cast<double>(held_out.size());
}

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
  std::string csv;
  std::vector<int> sizes = {20, 30, 100};
  int seeds = 5;
  robocal::PriorChoiceOptions choice;
  try {
    for (const auto& [flag, value] : SplitFlags(args, {"--frame-priors"})) {
      if (flag == "--csv") {
        csv = value;
      } else if (flag == "--n") {
        sizes.clear();
        for (const std::string& n : SplitList(flag, value))
          sizes.push_back(static_cast<int>(ParseIntegerFlag(flag, n, 10, 1000)));
      } else if (flag == "--seeds") {
        seeds = static_cast<int>(ParseIntegerFlag(flag, value, 1, 1000));
      } else if (flag == "--frame-priors") {
        // The lengths' and angles' priors on the base and tool sites too (by default they have none).
        choice.priors.base_length_mm = choice.priors.tool_length_mm = choice.priors.length_mm;
        choice.priors.base_angle_rad = choice.priors.tool_angle_rad = choice.priors.angle_rad;
      } else if (flag == "--free") {
        for (const std::string& name : SplitList(flag, value))
          choice.priors.parameters[name] = std::numeric_limits<double>::infinity();
      } else if (flag == "--scales") {
        choice.scales.clear();
        for (const std::string& x : SplitList(flag, value))
          choice.scales.push_back(x == "inf" ? std::numeric_limits<double>::infinity() : std::stod(x));
      } else if (flag == "--folds") {
        choice.folds = static_cast<int>(ParseIntegerFlag(flag, value, 2, 20));
      } else {
        throw BadFlag("unknown flag " + flag);
      }
    }
    if (csv.empty()) throw BadFlag("--csv is required");
  } catch (const BadFlag& e) {
    std::cerr << "robocal-prior-study: " << e.what() << "\n" << kUsage;
    return 2;
  }
  try {
    const robocal::RobotModel nominal = Ur10();
    const std::vector<robocal::Measurement> all = ReadSeriesB(csv);
    const std::vector<char> stale = robocal::FlagStaleShots(nominal, all, robocal::MeasurementType::kPose, 0.0);
    std::vector<robocal::Measurement> rows;
    for (size_t i = 0; i < all.size(); ++i)
      if (!stale[i]) rows.push_back(all[i]);
    std::printf("%zu rows, %zu stale left out\n", all.size(), all.size() - rows.size());
    robocal::IdentificationOptions o;
    o.measurement_type = robocal::MeasurementType::kPose;
    o.noise.tracker = robocal::TrackerUncertainty{};
    for (int n : sizes) {
      double sum_plain = 0.0, sum_auto = 0.0;
      for (int seed = 1; seed <= seeds; ++seed) {
        std::vector<size_t> order(rows.size());
        std::iota(order.begin(), order.end(), size_t{0});
        robocal::Rng rng(static_cast<std::uint64_t>(seed));
        for (size_t k = order.size(); k > 1; --k) std::swap(order[k - 1], order[rng.Index(k)]);
        std::vector<robocal::Measurement> calibration, held_out;
        for (size_t k = 0; k < order.size(); ++k)
          (static_cast<int>(k) < n ? calibration : held_out).push_back(rows[order[k]]);
        choice.seed = static_cast<std::uint64_t>(seed);
        const robocal::Calibration plain = robocal::Identify(nominal, calibration, o);
        const robocal::Calibration automatic = robocal::IdentifyWithPriorChoice(nominal, calibration, o, choice);
        const double e_plain = HeldOutMean(plain, held_out), e_auto = HeldOutMean(automatic, held_out);
        if (std::getenv("ROBOCAL_PRIOR_STUDY_REPORT") != nullptr) std::cout << plain.FullReport();
        sum_plain += e_plain;
        sum_auto += e_auto;
        const robocal::IdentificationSummary& s = automatic.summary;
        std::printf(
            "N %3d seed %2d: held-out mean without priors %.4f mm (%s), priors auto %.4f mm (%s), %+.1f %%;"
            " chosen scale %g, %zu prior-determined; CV",
            n, seed, e_plain, robocal::ToString(plain.summary.termination), e_auto, robocal::ToString(s.termination),
            100.0 * (e_auto / e_plain - 1.0), s.prior_chosen >= 0 ? s.prior_candidates[s.prior_chosen].scale : -1.0,
            s.prior_determined.size());
        for (const robocal::PriorScaleCandidate& c : s.prior_candidates)
          std::printf(" %g:%.4f+-%.4f", c.scale, c.cv_mean_mm, c.cv_standard_error_mm);
        std::printf("\n");
      }
      std::printf("N %3d: mean over %d seeds without priors %.4f mm, priors auto %.4f mm (%+.1f %%)\n", n, seeds,
                  sum_plain / seeds, sum_auto / seeds, 100.0 * (sum_auto / sum_plain - 1.0));
    }
  } catch (const std::exception& e) {
    std::cerr << "robocal-prior-study: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
