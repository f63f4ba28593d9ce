// The help texts of `robocal`: the main help's parts and, per command, a one-line summary (the main help's
// list) and the text under its usage line. The usage lines themselves are made from the command table, so
// that they always list what the parser accepts.
#pragma once

namespace robocal::cli {

struct HelpText {
  /// One line for the command list of `robocal --help`.
  const char* summary;
  /// What `robocal COMMAND --help` prints under the usage line.
  const char* text;
};

namespace help {

/// `robocal --help`: before the command list, and after it (global options, exit codes).
extern const char* const kIntro;
extern const char* const kGlobal;

extern const HelpText kRobots;
extern const HelpText kRobotRegister;
extern const HelpText kRobotFromCalibration;
extern const HelpText kRobotImport;
extern const HelpText kExport;
extern const HelpText kRobotGet;
extern const HelpText kRobotDelete;
extern const HelpText kRobotForward;
extern const HelpText kCellCreate;
extern const HelpText kCellList;
extern const HelpText kCellGet;
extern const HelpText kCellDelete;
extern const HelpText kCellCheck;
extern const HelpText kPlan;
extern const HelpText kPlanGet;
extern const HelpText kCampaignCreate;
extern const HelpText kCampaignList;
extern const HelpText kCampaignGet;
extern const HelpText kCampaignForward;
extern const HelpText kUpload;
extern const HelpText kMeasurements;
extern const HelpText kFit;
extern const HelpText kCompensate;
extern const HelpText kCompensateProgram;
extern const HelpText kEvaluate;
extern const HelpText kReport;
extern const HelpText kIso9283Plan;
extern const HelpText kCheck;
extern const HelpText kRobotHistory;
extern const HelpText kRobotCalibrate;
extern const HelpText kRobotRollback;
extern const HelpText kIso9283Report;
extern const HelpText kOperationWait;
extern const HelpText kOperationGet;
extern const HelpText kOperationCancel;
/// Followed by the experiment's flags (tools::kExperimentFlagsHelp).
extern const HelpText kExperiment;

}  // namespace help
}  // namespace robocal::cli
