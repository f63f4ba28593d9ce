// Flag parsing of the simulated experiment (see experiment_flags.h).
#include "experiment_flags.h"

#include <numbers>
#include <stdexcept>

#include "robocal/core/cell.h"
#include "robocal/core/model_choice.h"
#include "robocal/core/units.h"

#include "flags.h"

namespace robocal::tools {
namespace {

void Apply(const std::string& flag, const std::string& value, ExperimentOptions* options) {
  if (flag == "--robot") {
    options->robot = value;
  } else if (flag == "--type") {
    if (!ParseMeasurementType(value, &options->measurement_type)) {
      throw BadFlag("--type: '" + value + "' is not position, position_axis or pose");
    }
  } else if (flag == "--configurations") {
    options->num_configurations = static_cast<int>(ParseIntegerFlag(flag, value, 1, 1000));
  } else if (flag == "--trials") {
    options->trials = static_cast<int>(ParseIntegerFlag(flag, value, 1, 10000));
  } else if (flag == "--validation") {
    options->num_validation = static_cast<int>(ParseIntegerFlag(flag, value, 1, 100000));
  } else if (flag == "--h-mm") {
    options->h_mm = ParseDoubleFlag(flag, value, 1e-9);
  } else if (flag == "--seed") {
    options->seed = ParseSeedFlag(flag, value);
  } else if (flag == "--noise-mm") {
    options->cell.noise.position_mm = ParseDoubleFlag(flag, value, 0.0);
  } else if (flag == "--noise-deg") {
    options->cell.noise.orientation_rad = ParseDoubleFlag(flag, value, 0.0) * kRadPerDeg;
  } else if (flag == "--cell") {
    // Resolved after every flag is read, when the robot is known.
    if (value != "preset" && value != "realistic" && value != "none") {
      throw BadFlag("--cell: '" + value + "' is not preset, realistic or none");
    }
    options->cell.measurement_cell.reset();
    if (value != "none") options->cell.measurement_cell = CellSpec{};
    const std::optional<CellSpec> cell = options->cell.measurement_cell;
    if (value == "realistic") {
      options->cell = Realistic(options->cell);
    } else {
      options->cell.noise.tracker.reset();
      options->cell.noise.repeatability_mm = 0.0;
      options->cell.outlier_rate = 0.0;
    }
    options->cell.measurement_cell = cell;
  } else if (flag == "--model") {
    // A comma list of models would clash with compliance,harmonics=N: models are separated by '/'.
    options->models.clear();
    std::size_t start = 0;
    while (start <= value.size()) {
      const std::size_t slash = std::min(value.find('/', start), value.size());
      const std::string model = value.substr(start, slash - start);
      JointErrorTerms terms;
      bool automatic = false;
      std::string error;
      if (!ParseModelName(model, &terms, &automatic, &error)) throw BadFlag("--model: " + error);
      options->models.push_back(model);
      start = slash + 1;
    }
  } else if (flag == "--compliance-mm") {
    options->cell.compliance_deflection_mm = ParseDoubleFlag(flag, value, 0.0);
  } else if (flag == "--harmonics-rad") {
    options->cell.joint_harmonic_sigma_rad = ParseDoubleFlag(flag, value, 0.0);
  } else if (flag == "--harmonic-orders") {
    const std::size_t dash = value.find('-');
    if (dash == std::string::npos) throw BadFlag("--harmonic-orders takes MIN-MAX (1 to 4), got '" + value + "'");
    options->cell.joint_harmonic_min_order = static_cast<int>(ParseIntegerFlag(flag, value.substr(0, dash), 1, 4));
    options->cell.joint_harmonic_max_order = static_cast<int>(ParseIntegerFlag(flag, value.substr(dash + 1), 1, 4));
  } else if (flag == "--shots") {
    options->cell.shots_per_pose = static_cast<int>(ParseIntegerFlag(flag, value, 1, 1000));
  } else if (flag == "--outliers" || flag == "--outlier-size") {
    // Applied after every flag (ApplyExperimentFlags), so that --cell realistic does not reset them.
  } else {
    throw BadFlag("unknown option '" + flag + "'");
  }
}

}  // namespace

const char* const kExperimentFlagsHelp = R"(  --robot NAME           grinder5 (default), puma560 or ur5e
  --type TYPE            measurements: position, position_axis or pose (default pose)
  --configurations M     configurations per plan (default 10, the paper's)
  --trials N             independent trials, results pooled (default 10)
  --validation N         validation poses per trial (default 36, the paper's)
  --h-mm H               lever of E_tot = E_xyz + H * E_cos, mm (default 30)
  --seed S               seed of every random draw (default 1)
  --noise-mm SIGMA       tracker position noise per axis, 1-sigma, mm (default 0.015)
  --noise-deg SIGMA      tracker orientation noise per axis, 1-sigma, degrees (default 0.0057)
  --shots N              tracker shots per pose (default 10, the paper's)
  --model M[/M...]       the models every plan is fitted with, side by side: geometric (default),
                         compliance, harmonics=N, compliance,harmonics=N, auto (docs/identification.md,
                         "Beyond geometry"); e.g. geometric/compliance,harmonics=2/auto
  --compliance-mm D      the simulated robot's joint compliance: each joint moves the tool by about D mm at
                         the largest gravity torque it bears (default 0: none)
  --harmonics-rad S      the simulated robot's joint harmonics, 1-sigma per coefficient, rad (default 0)
  --harmonic-orders A-B  their orders, 1 <= A <= B <= 4 (default 2-4)
  --cell preset|realistic|none
                         preset: measure in the robot's preset cell (docs/cells.md): plans in the cell, random
                         poses that ignore it (and the poses the tracker loses), every planner with every
                         objective; realistic: the preset cell with the datasheet tracker model (radial
                         10 um + 0.3 um/m, transverse 15 um + 6 um/m MPE, 2 sigma; --noise-* unused), 0.03 mm
                         robot repeatability and 2 % outliers of 1-5 mm, fitted robustly (docs/experiment.md)
                         (default none: the paper's three methods, everything measurable)
  --outliers RATE        share of shots made gross errors, 0..1 (default 0; 0.02 with --cell realistic);
                         every fit is robust (docs/identification.md, "Outliers")
  --outlier-size MIN,MAX size of a gross error, mm, drawn uniformly in [MIN, MAX] in a random direction
                         (default 1,5)
)";

std::string ParseExperimentFlags(const std::vector<std::string>& args, ExperimentOptions* options) {
  try {
    return ApplyExperimentFlags(SplitFlags(args), options);
  } catch (const BadFlag& e) {
    return e.what();
  }
}

std::string ApplyExperimentFlags(const std::vector<std::pair<std::string, std::string>>& flags,
                                 ExperimentOptions* options) {
  try {
    for (const auto& [flag, value] : flags) Apply(flag, value, options);
    // The realistic cell shoots its three held nests when the tracker measures positions only.
    const bool realistic = options->cell.noise.tracker.has_value();
    options->cell.reflectors.clear();
    if (realistic && options->measurement_type == MeasurementType::kPosition) {
      options->cell.reflectors = RealisticReflectors();
    }
    // Gross errors on top of whatever cell was chosen (the virtual cell checks the ranges).
    for (const auto& [flag, value] : flags) {
      if (flag == "--outliers") {
        options->cell.outlier_rate = ParseDoubleFlag(flag, value, 0.0);
      } else if (flag == "--outlier-size") {
        const std::vector<std::string> range = SplitList(flag, value);
        if (range.size() != 2) throw BadFlag("--outlier-size takes MIN,MAX (mm)");
        options->cell.outlier_min_mm = ParseDoubleFlag(flag, range[0], 0.0);
        options->cell.outlier_max_mm = ParseDoubleFlag(flag, range[1], 0.0);
      }
    }
    if (options->cell.measurement_cell) {
      // --cell preset|realistic: the robot's preset cell (docs/cells.md), named by --robot wherever it stands.
      try {
        options->cell.measurement_cell = PresetCellSpec(options->robot);
      } catch (const std::invalid_argument&) {
        throw BadFlag("--cell: robot '" + options->robot + "' has no preset cell");
      }
    }
  } catch (const BadFlag& e) {
    return e.what();
  }
  std::string error;
  if (!options->IsValid(&error)) return error;
  return "";
}

}  // namespace robocal::tools
