// The service's robot programs: a program in its controller's language compensated on a campaign's calibration
// (POST /v1/campaigns/{c}:compensate-program, docs/programs.md).
#include <stdexcept>
#include <string>
#include <vector>

#include "robocal/api/programs.h"
#include "robocal/programs/compensate_program.h"
#include "robocal/server/service.h"
#include "service_support.h"

namespace robocal::server {

api::CompensateProgramResult Service::CompensateProgram(const std::string& campaign_id, const nlohmann::json& body) {
  const Calibrated loaded = LoadCalibrated(campaign_id);
  const api::CompensateProgramRequest req = api::ParseCompensateProgramRequest(body, options_.limits);
  std::vector<programs::ProgramFile> files;
  std::size_t bytes = 0;
  for (const auto& [name, text] : req.files) {
    files.push_back({name, text});
    bytes += text.size();
  }
  const TrimWhenDone trim(&trimmer_, bytes >= 100 * kLargeRequest);
  programs::ProgramCompensationOptions options;
  options.tools = req.tools;
  options.bases = req.bases;
  options.max_path_deviation_mm = req.max_path_deviation_mm;
  options.on_failure = req.on_failure;
  options.threads = options_.compensation_threads;
  // Each target's predicted error: the fit's covariance and model error, and the campaign's repeatability.
  options.prediction = {.probability = 0.95, .repeatability_mm = loaded.campaign.repeatability_mm};
  // Under the request's payload, else the campaign's (a compliance model deflects under it).
  if (req.payload) {
    options.payload = api::ToCore(*req.payload);
  } else if (loaded.campaign.payload) {
    options.payload = api::ToCore(*loaded.campaign.payload);
  }
  programs::ProgramCompensationResult result;
  try {
    result = programs::CompensateProgram(loaded.calibration, loaded.model, *req.dialect, files, options);
  } catch (const programs::ProgramError& e) {
    // A program robocal cannot read, or a target in a frame the request does not give: the file, line and column.
    throw ApiError(Status::kInvalidArgument, e.what(),
                   {{"files." + e.file(), "line " + std::to_string(e.line()) + ", column " +
                                              std::to_string(e.column()) + ": " + e.reason()}});
  } catch (const std::invalid_argument& e) {
    // An option the program cannot take (a tool entry of the wrong kind, a path check for a dialect that cannot
    // insert targets): its name leads the message.
    const std::string what = e.what();
    const std::size_t colon = what.find(':');
    throw ApiError(Status::kInvalidArgument, "invalid compensate-program request: " + what,
                   {{colon == std::string::npos ? "" : what.substr(0, colon), what}});
  }
  if (result.summary.termination == Termination::kFailure) {
    // on_failure refuse: nothing is written; each target that failed is named.
    std::vector<api::FieldViolation> details;
    for (const programs::CompensatedTarget& t : result.targets) {
      if (t.inserted || (t.termination == Termination::kConvergence && t.configuration_kept)) continue;
      details.push_back({"files." + files[static_cast<std::size_t>(t.file)].name,
                         "line " + std::to_string(t.line) + (t.name ? " (" + *t.name + ")" : std::string()) + ": " +
                             ToString(t.termination) + (t.message.empty() ? "" : ", " + t.message)});
    }
    throw ApiError(Status::kFailedPrecondition, result.summary.message, std::move(details));
  }
  return api::ToWire(loaded.model, campaign_id, files, result);
}

}  // namespace robocal::server
