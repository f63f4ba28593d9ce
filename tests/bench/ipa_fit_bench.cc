// The fit on real data, as the server runs it: the IPA UR10 (tests/data/ipa, Series B, 6-D laser-tracker poses)
// registered from its URDF, the calibration rows drawn as `robocal upload --calibration-rows N --seed 1` draws them
// (so these are the fits of tests/realdata/ipa.sh), and `Service::Fit` timed whole: the measurements read from the
// store, the robust rounds, the model error, the covariance, the reply and the stored calibration. Counter
// `fit_s`: the fit's own summary.seconds. Arg: calibration poses. BM_IpaFitAuto: `model: auto` (five-fold
// cross-validation over the model candidates).
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "robocal/api/campaigns.h"
#include "robocal/api/tracker_files.h"
#include "robocal/server/memory_trimmer.h"
#include "robocal/server/service.h"
#include "server/storage/storage.h"

namespace robocal::server {
namespace {

std::string ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// One service over a temporary SQLite database holding the UR10 and a campaign per calibration size.
class IpaCell {
 public:
  static IpaCell& Get() {
    static IpaCell cell;
    return cell;
  }
  Service& service() { return *service_; }

  // The campaign "bN": N rows of Series B for calibration, the rest for validation (created on first use).
  std::string Campaign(int calibration_rows) {
    const std::string id = "b" + std::to_string(calibration_rows);
    if (made_.count(id) != 0) return id;
    service_->CreateCampaign(
        {{"id", id}, {"robot", "ur10"}, {"measurement_type", "pose"}, {"tracker", api::TrackerModelWire{}}});
    const api::DataRowSplit split =
        api::SplitDataRows(api::DataRowLines(series_b_), static_cast<std::size_t>(calibration_rows), 1);
    for (const bool want_calibration : {true, false}) {
      nlohmann::json body = import_;
      body["role"] = want_calibration ? "calibration" : "validation";
      body["rows"] = want_calibration ? split.calibration : split.validation;
      body["request_id"] = id + (want_calibration ? "-calibration" : "-validation");
      service_->ImportMeasurements(id, body);
    }
    made_.insert(id);
    return id;
  }

 private:
  IpaCell() {
    ConfigureMemoryAllocator();  // the server's malloc settings
    char dir_template[] = "/tmp/robocal-ipa-bench-XXXXXX";
    if (mkdtemp(dir_template) == nullptr) throw std::runtime_error("mkdtemp failed");
    dir_ = dir_template;
    storage_ = OpenSqliteStorage(dir_ + "/robocal.db");
    service_ = std::make_unique<Service>(storage_.get(), ServiceOptions{});
    const std::string data = ROBOCAL_TEST_DATA;
    // The robot as tests/realdata/ipa.sh registers it: base_link -> tool0 with the probe 109 mm out of the flange,
    // turned -90 deg about it.
    service_->CreateRobot({{"id", "ur10"},
                           {"urdf", ReadText(data + "/urdf/ur10_robot.urdf")},
                           {"base_link", "base_link"},
                           {"tip_link", "tool0"},
                           {"tool", {{"position_mm", {0, 0, 109}}, {"rpy_deg", {0, 0, -90}}}}});
    series_b_ = ReadText(data + "/ipa/series_b_joint_configurations.csv");
    // The files as published: ';' and decimal commas, joints in rad, the probe's pose as mm and intrinsic X-Y-Z
    // Euler angles in degrees.
    import_ = {{"format", "csv"},
               {"text", series_b_},
               {"unit", "mm"},
               {"decimal", ","},
               {"columns", {{"x", "measurement_x"}, {"y", "measurement_y"}, {"z", "measurement_z"}}},
               {"joints",
                {{"columns",
                  {"shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
                   "wrist_3_joint"}},
                 {"unit", "rad"}}},
               {"orientation",
                {{"representation", "euler"},
                 {"columns", {"measurement_rx", "measurement_ry", "measurement_rz"}},
                 {"sequence", "XYZ"},
                 {"convention", "intrinsic"},
                 {"unit", "deg"}}}};
  }
  ~IpaCell() {
    service_.reset();
    storage_.reset();
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }

  std::string dir_;
  std::unique_ptr<Storage> storage_;
  std::unique_ptr<Service> service_;
  std::string series_b_;
  nlohmann::json import_;
  std::set<std::string> made_;
};

void RunFit(benchmark::State& state, const nlohmann::json& body) {
  IpaCell& cell = IpaCell::Get();
  const std::string campaign = cell.Campaign(static_cast<int>(state.range(0)));
  api::CalibrationResult last;
  double fit_seconds = 0.0;
  for (auto _ : state) {
    last = std::get<api::CalibrationResult>(cell.service().Fit(campaign, body));
    fit_seconds += last.summary.seconds;
  }
  if (last.summary.termination != Termination::kConvergence) state.SkipWithError(last.summary.message.c_str());
  state.counters["fit_s"] = benchmark::Counter(fit_seconds, benchmark::Counter::kAvgIterations);
  state.counters["model_error_mm"] = last.model_error.model_error_mm;
  state.SetLabel("IPA UR10 Series B, " + std::to_string(state.range(0)) + " calibration poses, " +
                 std::to_string(last.parameters.size()) + " parameters");
}

void BM_IpaFit(benchmark::State& state) { RunFit(state, nlohmann::json::object()); }
BENCHMARK(BM_IpaFit)->Arg(100)->Arg(400)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_IpaFitAuto(benchmark::State& state) { RunFit(state, {{"model", "auto"}}); }
BENCHMARK(BM_IpaFitAuto)->Arg(400)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

}  // namespace
}  // namespace robocal::server
