// What several `robocal` commands share (see support.h).
#include "support.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>

#include "cli.h"
#include "robocal/client/csv.h"

namespace robocal::cli {

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw UsageError("cannot read " + path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

bool EndsWith(const std::string& text, const std::string& suffix) {
  return text.size() >= suffix.size() && text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

api::TrackerModelWire ParseTrackerFlag(const std::string& text) {
  api::TrackerModelWire tracker;
  if (text == "datasheet") return tracker;
  const std::vector<std::string> parts = tools::SplitList("--tracker", text);
  if (parts.size() < 4 || parts.size() > 6) {
    throw UsageError(
        "--tracker takes datasheet or RADIAL_UM,RADIAL_UM_PER_M,TRANSVERSE_UM,TRANSVERSE_UM_PER_M"
        "[,ORIENTATION_DEG[,MPE_SIGMAS]]");
  }
  std::vector<double> v;
  for (const std::string& p : parts) {
    v.push_back(tools::ParseDoubleFlag("--tracker", p, std::numeric_limits<double>::lowest()));
  }
  tracker.radial_um = {v[0], v[1]};
  tracker.transverse_um = {v[2], v[3]};
  if (v.size() > 4) tracker.orientation_deg = v[4];
  if (v.size() > 5) tracker.mpe_sigmas = v[5];
  return tracker;
}

std::vector<api::CampaignReflectorWire> ParseReflectorsFlag(const std::string& text) {
  const std::string usage = "--reflectors takes ID:X,Y,Z[:fixed]/ID:X,Y,Z[:fixed]/... (mm, flange frame)";
  std::vector<api::CampaignReflectorWire> out;
  std::size_t begin = 0;
  while (begin <= text.size()) {
    const std::size_t end = std::min(text.find('/', begin), text.size());
    const std::string item = text.substr(begin, end - begin);
    begin = end + 1;
    const std::size_t colon = item.find(':');
    if (colon == std::string::npos) throw UsageError(usage + "; \"" + item + "\" has no position");
    api::CampaignReflectorWire r;
    r.id = item.substr(0, colon);
    std::string position = item.substr(colon + 1);
    const std::size_t second = position.find(':');
    if (second != std::string::npos) {
      if (position.substr(second + 1) != "fixed") {
        throw UsageError(usage + "; \"" + item + "\" ends in neither a position nor :fixed");
      }
      r.fixed = true;
      position.resize(second);
    }
    if (position.empty()) throw UsageError(usage + "; \"" + item + "\" has no position");
    const std::vector<std::string> xyz = tools::SplitList("--reflectors", position);
    if (xyz.size() != 3) throw UsageError(usage + "; \"" + item + "\" needs three coordinates");
    for (int k = 0; k < 3; ++k) {
      r.position_mm[k] = tools::ParseDoubleFlag("--reflectors", xyz[k], std::numeric_limits<double>::lowest());
    }
    out.push_back(std::move(r));
  }
  return out;
}

api::PayloadWire ParsePayloadFlag(const std::string& text) {
  api::PayloadWire payload;
  const std::size_t at = text.find('@');
  payload.mass_kg =
      tools::ParseDoubleFlag("--payload", text.substr(0, at), std::numeric_limits<double>::lowest());
  if (at != std::string::npos) {
    const std::vector<std::string> xyz = tools::SplitList("--payload", text.substr(at + 1));
    if (xyz.size() != 3) throw UsageError("--payload takes KG or KG@X,Y,Z (mm, flange frame), got \"" + text + "\"");
    for (int k = 0; k < 3; ++k) {
      payload.com_mm[k] = tools::ParseDoubleFlag("--payload", xyz[k], std::numeric_limits<double>::lowest());
    }
  }
  return payload;
}

std::string Fixed(double v, int digits) {
  if (!std::isfinite(v)) return "-";
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

Output::Output(const std::string& out_file, std::ostream& out) : out_(out) {
  if (out_file.empty()) return;
  file_.open(out_file);
  if (!file_) throw UsageError("cannot write " + out_file);
}

std::vector<std::vector<double>> ReadJointsFile(const std::string& path, const api::Robot& robot) {
  std::istringstream in(ReadFile(path));
  std::vector<std::vector<double>> rows;
  try {
    rows = client::ReadJointsCsv(in, static_cast<int>(robot.joints.size()));
  } catch (const std::runtime_error& e) {
    throw UsageError(path + ": " + e.what());
  }
  if (rows.empty()) throw UsageError(path + ": no rows");
  return rows;
}

int WriteForward(Invocation& in, const api::Robot& robot, const std::vector<std::vector<double>>& joints,
                 const api::ForwardResult& result) {
  Output target(in.Option("--out"), in.out);
  if (in.json) {
    PrintJson(target.stream(), result);
    return kExitOk;
  }
  std::vector<api::MeasurementWire> rows;
  for (std::size_t i = 0; i < joints.size() && i < result.poses.size(); ++i) {
    rows.push_back({.joints = joints[i], .pose = result.poses[i]});
  }
  client::WriteMeasurementsCsv(target.stream(), robot.joints, rows);
  return kExitOk;
}

namespace {

void ProgressBar(std::ostream& err, const api::Operation& op) {
  const int width = 30;
  const double progress = std::isfinite(op.progress) ? std::clamp(op.progress, 0.0, 1.0) : 0.0;
  const int filled = static_cast<int>(std::lround(progress * width));
  err << "\r" << op.id << " [" << std::string(filled, '#') << std::string(width - filled, ' ') << "] " << std::setw(3)
      << std::lround(progress * 100) << "% " << api::WireName(op.state) << std::flush;
}

}  // namespace

api::Operation WaitWithProgress(Invocation& in, const std::string& id) {
  std::ostream& err = in.err;
  const api::Operation done = in.Client().WaitOperation(id, [&err](const api::Operation& op) {
    ProgressBar(err, op);
    return true;
  });
  err << "\n";
  return done;
}

int ReportUnfinished(const api::Operation& done, std::ostream& err) {
  const std::string state = api::WireName(done.state);
  const std::string message =
      done.error ? std::string(api::WireName(done.error->status)) + ": " + done.error->message : state;
  err << "robocal: operation " << done.id << " " << state << ": " << message << "\n";
  return kExitServiceError;
}

}  // namespace robocal::cli
