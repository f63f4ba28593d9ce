// What several `robocal` commands share: files in and out, number formatting, joints CSV input, forward
// kinematics output, waiting for an operation with a progress bar.
#pragma once

#include <array>
#include <fstream>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

#include "command.h"
#include "robocal/api/tracker_files.h"
#include "robocal/api/wire.h"

namespace robocal::cli {

/// The whole file; a usage error if it cannot be read (the user's file, not the service).
std::string ReadFile(const std::string& path);
/// Three numbers "X,Y,Z" of `option` (UsageError naming it otherwise).
std::array<double, 3> Triple(const std::string& option, const std::string& text);
/// A batch from a JSON file: the body of POST /v1/campaigns/{c}/measurements (request_id and role optional), or just
/// its array of measurements (UsageError naming the file when it is neither).
api::MeasurementBatchRequest ReadJsonBatch(const std::string& path, const std::string& text);
/// The measurements of a file as upload and check read it: a CSV (joints of the robot `robot` names, asked for only
/// then) or JSON (ReadJsonBatch). UsageError naming the file when it is neither.
api::MeasurementBatchRequest ReadMeasurementFile(Invocation& in, const std::string& path,
                                                 const std::function<std::string()>& robot);
bool EndsWith(const std::string& text, const std::string& suffix);
/// `v` with `digits` decimals; "-" if not finite.
std::string Fixed(double v, int digits);
/// The value of --tracker: "datasheet" (the defaults) or RADIAL_UM,RADIAL_UM_PER_M,TRANSVERSE_UM,
/// TRANSVERSE_UM_PER_M[,ORIENTATION_DEG[,MPE_SIGMAS]]; UsageError otherwise. The service checks the ranges.
api::TrackerModelWire ParseTrackerFlag(const std::string& text);
/// --reflectors ID:X,Y,Z[:fixed]/...: reflector nests on the flange (mm, flange frame); ids and ranges are
/// left to the service, which names the field.
std::vector<api::CampaignReflectorWire> ParseReflectorsFlag(const std::string& text);
/// --payload KG or KG@X,Y,Z: a payload's mass (kg) and centre of mass (mm, flange frame; default the flange
/// origin). The service checks the ranges and names the field.
api::PayloadWire ParsePayloadFlag(const std::string& text);

/// `out_file` opened for writing, or `out` when it is empty.
class Output {
 public:
  Output(const std::string& out_file, std::ostream& out);
  std::ostream& stream() { return file_.is_open() ? file_ : out_; }

 private:
  std::ostream& out_;
  std::ofstream file_;
};

/// The import request of a tracker export at `path` in `format` ("sa" or "csv") from the upload options (--unit,
/// --columns, --joints, --joint-unit, --orientation-columns, --delimiter, --decimal, --encoding, ...): upload
/// --format and plan --candidates FILE --format csv.
api::ImportMeasurementsRequest TrackerFileRequest(Invocation& in, const std::string& format, const std::string& path);

/// The joints CSV at `path` for `robot`, as a usage error when malformed or empty.
std::vector<std::vector<double>> ReadJointsFile(const std::string& path, const api::Robot& robot);

/// robot forward / campaign forward: the poses of `joints` as the measurement CSV (or, with --json, the
/// forward result) to --out or stdout.
int WriteForward(Invocation& in, const api::Robot& robot, const std::vector<std::vector<double>>& joints,
                 const api::ForwardResult& result);

/// Waits for operation `id`, drawing its progress bar on in.err, and ends the bar's line.
api::Operation WaitWithProgress(Invocation& in, const std::string& id);
/// An async plan or fit that ended without its result: says why on err; the command's exit code.
int ReportUnfinished(const api::Operation& done, std::ostream& err);

}  // namespace robocal::cli
