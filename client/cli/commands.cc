// The `robocal` command table: one entry per command, declaring its words, positional arguments, options and
// help. The parser (cli.cc) refuses any option an entry does not list; the usage lines are made from it.
#include "command.h"
#include "experiment_flags.h"

namespace robocal::cli {

const std::vector<Command>& Commands() {
  static const std::vector<Command> commands = {
      {"robots", {}, {}, &help::kRobots, Robots},
      {"robot register", {"FILE.json"}, {}, &help::kRobotRegister, RobotRegister},
      {"robot register",
       {},
       {{"--from-calibration", "CAMPAIGN"}, {"--id", "ID"}, {"--description", "TEXT"}},
       &help::kRobotFromCalibration,
       RobotFromCalibration},
      {"robot import",
       {"FILE.urdf"},
       {{"--base", "LINK"}, {"--tip", "LINK"}, {"--id", "ID"}, {"--description", "TEXT"}, {"--tool-mm", "X,Y,Z"}},
       &help::kRobotImport,
       RobotImport},
      {"robot get", {"ROBOT"}, {}, &help::kRobotGet, RobotGet},
      {"robot delete", {"ROBOT"}, {}, &help::kRobotDelete, RobotDelete},
      {"robot history", {"ROBOT"}, {}, &help::kRobotHistory, RobotHistory},
      {"robot calibrate", {"ROBOT", "CAMPAIGN"}, {{"--note", "TEXT"}}, &help::kRobotCalibrate, RobotCalibrate},
      {"robot rollback", {"ROBOT", "ENTRY"}, {{"--note", "TEXT"}}, &help::kRobotRollback, RobotRollback},
      {"check",
       {"ROBOT", "SHOTS.csv|SHOTS.json"},
       {{"--type", "pose|position|position_axis"}, {"--frames", "register|keep"}, {"--rate", "P"}, {"--seed", "S"}},
       &help::kCheck,
       Check},
      {"robot forward",
       {"ROBOT", "IN.csv"},
       {{"--out", "OUT.csv"}, {"--payload", "KG[@X,Y,Z]"}},
       &help::kRobotForward,
       RobotForward},
      {"cell create", {"FILE.json"}, {}, &help::kCellCreate, CellCreate},
      {"cell list", {}, {}, &help::kCellList, CellList},
      {"cell get", {"CELL"}, {}, &help::kCellGet, CellGet},
      {"cell delete", {"CELL"}, {}, &help::kCellDelete, CellDelete},
      {"cell check", {"CELL", "IN.csv"}, {{"--out", "OUT.csv"}}, &help::kCellCheck, CellCheck},
      {"plan",
       {"ROBOT"},
       {{"--count", "M|auto"},
        {"--goal-mm", "MM"},
        {"--min-count", "N"},
        {"--max-count", "N"},
        {"--candidates", "FILE|CAMPAIGN"},
        {"--malformed", "refuse|reject"},
        {"--format", "csv"},
        {"--unit", "UNIT"},
        {"--joints", "H1,H2,..."},
        {"--joint-unit", "deg|rad"},
        {"--delimiter", "C"},
        {"--decimal", ".|,"},
        {"--encoding", "auto|utf-8|latin-1"},
        {"--task", "FILE.csv"},
        {"--task-box", "X0,Y0,Z0:X1,Y1,Z1"},
        {"--task-rpy", "R,P,Y/..."},
        {"--task-count", "N"},
        {"--cell", "CELL"},
        {"--type", "TYPE"},
        {"--objective", "NAME"},
        {"--purpose", "calibration|check"},
        {"--optimiser", "NAME"},
        {"--seed", "N"},
        {"--tracker", "datasheet|R,r,T,t[,O[,K]]"},
        {"--reflectors", "ID:X,Y,Z[:fixed]/..."},
        {"--async"},
        {"--out", "FILE.csv|FILE.json"}},
       &help::kPlan,
       Plan},
      {"plan get", {"PLAN"}, {{"--out", "FILE.csv|FILE.json"}}, &help::kPlanGet, PlanGet},
      {"campaign create",
       {"ROBOT", "TYPE"},
       {{"--plan", "PLAN"},
        {"--id", "ID"},
        {"--description", "TEXT"},
        {"--tracker", "datasheet|R,r,T,t[,O[,K]]"},
        {"--repeatability-mm", "RP"},
        {"--reflectors", "ID:X,Y,Z[:fixed]/..."},
        {"--payload", "KG[@X,Y,Z]"}},
       &help::kCampaignCreate,
       CampaignCreate},
      {"campaign list", {}, {}, &help::kCampaignList, CampaignList},
      {"campaign get", {"CAMPAIGN"}, {}, &help::kCampaignGet, CampaignGet},
      {"campaign forward",
       {"CAMPAIGN", "IN.csv"},
       {{"--out", "OUT.csv"}, {"--payload", "KG[@X,Y,Z]"}},
       &help::kCampaignForward,
       CampaignForward},
      {"upload",
       {"CAMPAIGN", "FILE"},
       {{"--role", "calibration|validation"},
        {"--request-id", "ID"},
        {"--format", "sa|csv"},
        {"--plan", "PLAN"},
        {"--unit", "mm|m|in"},
        {"--columns", "target=NAME,x=X,y=Y,z=Z[,reflector=R]"},
        {"--match", "name|order"},
        {"--shots", "N"},
        {"--joints", "C1,C2,..."},
        {"--joint-unit", "deg|rad"},
        {"--orientation-columns", "C1,C2,C3[,C4]"},
        {"--quaternion-order", "wxyz|xyzw"},
        {"--euler", "SEQUENCE"},
        {"--euler-convention", "intrinsic|extrinsic"},
        {"--angle-unit", "deg|rad"},
        {"--delimiter", ",|;|tab"},
        {"--decimal", ".|,"},
        {"--encoding", "auto|utf-8|latin-1"},
        {"--calibration-rows", "N"},
        {"--seed", "S"},
        {"--payload", "KG[@X,Y,Z]"}},
       &help::kUpload,
       Upload},
      {"measurements",
       {"CAMPAIGN"},
       {{"--role", "calibration|validation"}, {"--after", "SEQ"}, {"--limit", "N"}, {"--out", "FILE.csv"}},
       &help::kMeasurements,
       Measurements},
      {"fit",
       {"CAMPAIGN"},
       {{"--parameters", "a,b,..."},
        {"--no-register-base"},
        {"--max-iterations", "N"},
        {"--keep-outliers"},
        {"--outlier-probability", "P"},
        {"--scope", "all|frames"},
        {"--no-model-error"},
        {"--model", "auto|geometric|compliance,harmonics=N,joint_maps=Sdeg[:JOINTS],smoothness=L"},
        {"--priors", "auto|defaults|KEY=V,..."},
        {"--folds", "N"},
        {"--cv-seed", "S"},
        {"--cv-maps"},
        {"--async"}},
       &help::kFit,
       Fit},
      {"compensate",
       {"CAMPAIGN", "IN.csv"},
       {{"--out", "OUT.csv"},
        {"--sequence"},
        {"--max-jump", "DEG"},
        {"--frame", "tracker|base"},
        {"--payload", "KG[@X,Y,Z]"}},
       &help::kCompensate,
       Compensate},
      {"compensate-program",
       {"CAMPAIGN", "FILE..."},
       {{"--out", "DIR"},
        {"--dialect", "krl|rapid|urscript|fanuc-ls|val3"},
        {"--tools", "TOOLS.json"},
        {"--bases", "BASES.json"},
        {"--max-path-deviation", "MM"},
        {"--on-failure", "keep|refuse"},
        {"--payload", "KG[@X,Y,Z]"}},
       &help::kCompensateProgram,
       CompensateProgram},
      {"evaluate", {"CAMPAIGN"}, {{"--h-mm", "H"}}, &help::kEvaluate, Evaluate},
      {"report", {"CAMPAIGN"}, {{"--out", "FILE.html"}, {"--h-mm", "H"}}, &help::kReport, Report},
      {"iso9283 plan",
       {"ROBOT"},
       {{"--center", "X,Y,Z"},
        {"--size", "MM|auto"},
        {"--cycles", "N"},
        {"--rpy", "R,P,Y"},
        {"--cell", "CELL"},
        {"--compensated-by", "CAMPAIGN"},
        {"--type", "pose|position|position_axis"},
        {"--seed", "S"},
        {"--out", "PLAN.json"}},
       &help::kIso9283Plan,
       Iso9283Plan},
      {"iso9283 report", {"CAMPAIGN"}, {{"--csv"}, {"--out", "FILE"}}, &help::kIso9283Report, Iso9283Report},
      {"export", {"CAMPAIGN"}, {{"--format", "urdf|dh|mdh|json"}, {"--out", "FILE"}}, &help::kExport, Export},
      {"operation wait", {"ID"}, {}, &help::kOperationWait, OperationWait},
      {"operation get", {"ID"}, {}, &help::kOperationGet, OperationGet},
      {"operation cancel", {"ID"}, {}, &help::kOperationCancel, OperationCancel},
      {"experiment", {}, {}, &help::kExperiment, Experiment, /*local=*/true, &tools::kExperimentFlagsHelp},
  };
  return commands;
}

std::string CommandHelp(const Command& command) {
  std::string usage = "Usage: robocal " + command.name;
  for (const std::string& argument : command.arguments) usage += " " + argument;
  if (command.local) usage += " [options]";
  for (const OptionSpec& option : command.options) {
    usage += std::string(" [") + option.name + (option.value ? std::string(" ") + option.value : "") + "]";
  }
  return usage + "\n" + command.help->text + (command.flags_help ? *command.flags_help : "");
}

std::string Invocation::Option(const std::string& option, const std::string& fallback) const {
  const auto it = options.find(option);
  return it == options.end() ? fallback : it->second;
}

long long Invocation::Integer(const std::string& option, long long fallback, long long min, long long max) const {
  return Has(option) ? tools::ParseIntegerFlag(option, Option(option), min, max) : fallback;
}

double Invocation::Number(const std::string& option, double fallback, double min) const {
  return Has(option) ? tools::ParseDoubleFlag(option, Option(option), min) : fallback;
}

std::uint64_t Invocation::Seed(const std::string& option, std::uint64_t fallback) const {
  return Has(option) ? tools::ParseSeedFlag(option, Option(option)) : fallback;
}

client::Client& Invocation::Client() const {
  if (!client) throw std::logic_error("robocal " + command.name + " runs without a server");
  return *client;
}

}  // namespace robocal::cli
