// robocal campaign create | list | get | forward, upload, measurements.
#include <algorithm>
#include <cstdint>
#include <iomanip>
#include <limits>
#include <sstream>

#include "cli.h"
#include "command.h"
#include "robocal/api/text.h"
#include "robocal/client/csv.h"
#include "support.h"

namespace robocal::cli {
namespace {

int Show(Invocation& in, const api::Campaign& campaign) {
  if (in.json) {
    PrintJson(in.out, campaign);
  } else {
    in.out << campaign.id << "  robot " << campaign.robot << "  " << api::WireName(campaign.type()) << "  calibration "
           << campaign.counts.calibration << "  validation " << campaign.counts.validation
           << (campaign.calibrated ? "  calibrated" : "  not calibrated") << "\n";
    if (const auto& t = campaign.tracker) {
      in.out << "tracker radial " << t->radial_um[0] << " um + " << t->radial_um[1] << " um/m, transverse "
             << t->transverse_um[0] << " um + " << t->transverse_um[1] << " um/m, orientation " << t->orientation_deg
             << " deg (MPE = " << t->mpe_sigmas << " sigma)\n";
    }
    if (campaign.repeatability_mm > 0.0) in.out << "robot repeatability " << campaign.repeatability_mm << " mm\n";
    if (const auto& p = campaign.payload) {
      in.out << "payload " << p->mass_kg << " kg at " << p->com_mm[0] << " " << p->com_mm[1] << " " << p->com_mm[2]
             << " mm (flange)\n";
    }
    for (const api::CampaignReflectorWire& r : campaign.reflectors) {
      in.out << "reflector " << r.id << " at " << r.position_mm[0] << " " << r.position_mm[1] << " " << r.position_mm[2]
             << " mm (flange)" << (r.fixed ? ", fixed" : ", offset identified") << "\n";
    }
  }
  return kExitOk;
}

}  // namespace

api::MeasurementBatchRequest ReadMeasurementFile(Invocation& in, const std::string& path,
                                                 const std::function<std::string()>& robot) {
  const std::string text = ReadFile(path);
  if (!EndsWith(path, ".csv")) return ReadJsonBatch(path, text);
  // A CSV's joint columns are the robot's.
  const api::Robot r = in.Client().GetRobot(robot());
  std::istringstream csv(text);
  api::MeasurementBatchRequest batch;
  try {
    batch.measurements = client::ReadMeasurementsCsv(csv, static_cast<int>(r.joints.size()));
  } catch (const std::runtime_error& e) {
    throw UsageError(path + ": " + e.what());
  }
  return batch;
}

api::MeasurementBatchRequest ReadJsonBatch(const std::string& path, const std::string& text) {
  api::MeasurementBatchRequest batch;
  try {
    const nlohmann::json j = nlohmann::json::parse(text);
    if (j.is_array()) {
      api::ReadWire(j, "", &batch.measurements);
    } else {
      const api::WireReader r(j);
      r.Required("measurements", &batch.measurements);
      r.Optional("request_id", &batch.request_id);
      r.Optional("role", &batch.role);
    }
  } catch (const std::exception& e) {  // not JSON (parse_error), or not a batch (api::WireError)
    throw UsageError(path + ": not a measurement batch: " + e.what());
  }
  return batch;
}

int CampaignCreate(Invocation& in) {
  api::CreateCampaignRequest request;
  request.robot = in.args[0];
  request.measurement_type = Invocation::ParseEnum<MeasurementType>("TYPE", in.args[1]);
  if (!in.Option("--plan").empty()) request.plan = in.Option("--plan");
  request.id = in.Option("--id");
  request.description = in.Option("--description");
  if (in.Has("--tracker")) request.tracker = ParseTrackerFlag(in.Option("--tracker"));
  request.repeatability_mm = in.Number("--repeatability-mm", 0.0, std::numeric_limits<double>::lowest());
  if (in.Has("--reflectors")) request.reflectors = ParseReflectorsFlag(in.Option("--reflectors"));
  if (in.Has("--payload")) request.payload = ParsePayloadFlag(in.Option("--payload"));
  const api::Campaign campaign = in.Client().CreateCampaign(request);
  if (in.json) return Show(in, campaign);
  in.out << campaign.id << "\n";
  return kExitOk;
}

int CampaignList(Invocation& in) {
  api::CampaignList list;
  list.campaigns = in.Client().ListCampaigns();
  if (in.json) {
    PrintJson(in.out, list);
    return kExitOk;
  }
  std::size_t id_width = 8, robot_width = 5;
  for (const api::Campaign& c : list.campaigns) {
    id_width = std::max(id_width, c.id.size());
    robot_width = std::max(robot_width, c.robot.size());
  }
  auto row = [&](const std::string& id, const std::string& robot, const std::string& type,
                 const std::string& calibration, const std::string& validation, const std::string& calibrated) {
    in.out << std::left << std::setw(static_cast<int>(id_width)) << id << "  "
           << std::setw(static_cast<int>(robot_width)) << robot << "  " << std::setw(13) << type << std::right << "  "
           << std::setw(11) << calibration << "  " << std::setw(10) << validation << "  " << calibrated << "\n";
  };
  row("campaign", "robot", "type", "calibration", "validation", "calibrated");
  for (const api::Campaign& c : list.campaigns) {
    row(c.id, c.robot, api::WireName(c.type()), std::to_string(c.counts.calibration),
        std::to_string(c.counts.validation), c.calibrated ? "yes" : "no");
  }
  return kExitOk;
}

int CampaignGet(Invocation& in) { return Show(in, in.Client().GetCampaign(in.args[0])); }

int CampaignForward(Invocation& in) {
  const api::Campaign campaign = in.Client().GetCampaign(in.args[0]);
  const api::Robot robot = in.Client().GetRobot(campaign.robot);
  const auto joints = ReadJointsFile(in.args[1], robot);
  std::optional<api::PayloadWire> payload;
  if (in.Has("--payload")) payload = ParsePayloadFlag(in.Option("--payload"));
  return WriteForward(in, robot, joints, in.Client().CampaignForward(campaign.id, joints, payload));
}

// upload --format sa|csv: the tracker's own export, read and matched by the service.
int ImportTrackerFile(Invocation& in, const std::string& format) {
  api::ImportMeasurementsRequest request = TrackerFileRequest(in, format, in.args[1]);
  // --calibration-rows N: N data rows drawn at random (--seed) are calibration measurements, the rest
  // validation: two imports of the whole text, each storing its role's rows (`rows`, by line), so that the server
  // reads the file in the order the tracker took it (a stale reading repeats the row before it).
  std::vector<api::ImportMeasurementsRequest> imports;
  if (in.Has("--calibration-rows")) {
    if (in.Has("--role")) throw UsageError("--calibration-rows sets the roles itself: leave out --role");
    const long long wanted = in.Integer("--calibration-rows", 0, 1, 1000000);
    const auto seed = static_cast<std::uint64_t>(in.Integer("--seed", 1, 0, std::numeric_limits<long long>::max()));
    const std::vector<int> data = api::DataRowLines(request.text);
    if (static_cast<std::size_t>(wanted) >= data.size()) {
      throw UsageError("--calibration-rows " + std::to_string(wanted) + ": " + in.args[1] + " has " +
                       std::to_string(data.size()) + " data rows; leave some for validation");
    }
    const api::DataRowSplit split = api::SplitDataRows(data, static_cast<std::size_t>(wanted), seed);
    for (const api::MeasurementRole role : {api::MeasurementRole::kCalibration, api::MeasurementRole::kValidation}) {
      api::ImportMeasurementsRequest part = request;
      part.role = role;
      part.rows = role == api::MeasurementRole::kCalibration ? split.calibration : split.validation;
      if (!request.request_id.empty()) part.request_id += "-" + std::string(api::WireName(role));
      imports.push_back(std::move(part));
    }
  } else {
    imports.push_back(request);
  }
  for (const api::ImportMeasurementsRequest& part : imports) {
    api::BatchResult r;
    try {
      r = in.Client().ImportMeasurements(in.args[0], part);
    } catch (const std::invalid_argument& e) {
      throw UsageError(in.args[1] + ": " + e.what());
    }
    if (in.json) {
      PrintJson(in.out, r);
    } else {
      in.out << (r.replayed ? "already stored (replayed): " : "stored ") << r.count << " " << api::WireName(part.role)
             << " measurements from " << in.args[1] << ", batch " << r.batch_id << ", request id " << r.request_id
             << "; campaign total " << r.campaign_total << "\n";
    }
  }
  return kExitOk;
}

int Upload(Invocation& in) {
  const std::string& campaign_id = in.args[0];
  const std::string& path = in.args[1];
  if (in.Has("--format")) return ImportTrackerFile(in, in.Option("--format"));
  for (const char* option :
       {"--plan", "--unit", "--columns", "--match", "--shots", "--joints", "--joint-unit", "--orientation-columns",
        "--quaternion-order", "--euler", "--euler-convention", "--angle-unit", "--delimiter", "--decimal", "--encoding",
        "--calibration-rows", "--seed"}) {
    if (in.Has(option)) throw UsageError(std::string(option) + " is for --format sa|csv (a tracker export)");
  }
  api::MeasurementBatchRequest batch =
      ReadMeasurementFile(in, path, [&] { return in.Client().GetCampaign(campaign_id).robot; });
  batch.role = in.Enum("--role", batch.role);
  batch.request_id = in.Option("--request-id", batch.request_id);
  if (in.Has("--payload")) {
    const api::PayloadWire payload = ParsePayloadFlag(in.Option("--payload"));
    for (api::MeasurementWire& m : batch.measurements) m.payload = payload;
  }
  const api::BatchResult r = in.Client().UploadMeasurements(campaign_id, batch);
  if (in.json) {
    PrintJson(in.out, r);
  } else {
    in.out << (r.replayed ? "already stored (replayed): " : "stored ") << r.count << " " << api::WireName(batch.role)
           << " measurements, batch " << r.batch_id << ", request id " << r.request_id << "; campaign total "
           << r.campaign_total << "\n";
  }
  return kExitOk;
}

int Measurements(Invocation& in) {
  std::optional<api::MeasurementRole> role;
  if (in.Has("--role")) role = Invocation::ParseEnum<api::MeasurementRole>("--role", in.Option("--role"));
  std::int64_t after = in.Integer("--after", 0, 0, std::numeric_limits<std::int64_t>::max());
  const long long limit =
      in.Integer("--limit", std::numeric_limits<long long>::max(), 1, std::numeric_limits<long long>::max());
  const std::string out_file = in.Option("--out");
  if (!out_file.empty() && !EndsWith(out_file, ".csv")) throw UsageError("--out takes FILE.csv");
  const api::Campaign campaign = in.Client().GetCampaign(in.args[0]);
  // Every page up to the limit, as one list; next_after is the last page's (set when there may be more).
  api::MeasurementList all;
  all.campaign = campaign.id;
  for (;;) {
    const long long left = limit - static_cast<long long>(all.measurements.size());
    api::MeasurementList page =
        in.Client().ListMeasurements(campaign.id, role, after, static_cast<int>(std::min<long long>(1000, left)));
    for (auto& m : page.measurements) all.measurements.push_back(std::move(m));
    all.next_after = page.next_after;
    if (!page.next_after || static_cast<long long>(all.measurements.size()) >= limit || page.measurements.empty()) {
      break;
    }
    after = *page.next_after;
  }
  Output target(out_file, in.out);
  if (in.json) {
    PrintJson(target.stream(), all);
  } else {
    std::vector<api::MeasurementWire> measurements;
    for (const api::StoredMeasurementWire& m : all.measurements) measurements.push_back(m);
    client::WriteMeasurementsCsv(target.stream(), in.Client().GetRobot(campaign.robot).joints, measurements);
  }
  in.err << all.measurements.size() << " measurements of campaign " << campaign.id << "\n";
  return kExitOk;
}

}  // namespace robocal::cli
