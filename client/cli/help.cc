// The help texts of `robocal` (see help.h). Usage lines come from the command table (commands.cc).
#include "help.h"

namespace robocal::cli::help {

const char* const kIntro = R"(Usage: robocal [global options] COMMAND [arguments] [options]

Command line client of the robocal calibration service. Wire units: mm and degrees (revolute joints in
degrees, prismatic joints in mm).

Commands:
)";

const char* const kGlobal = R"(
Global options (anywhere on the line, valid for every command):
  --server URL    service URL (default $ROBOCAL_SERVER, else http://127.0.0.1:8080)
  --token TOKEN   bearer token (default $ROBOCAL_TOKEN)
  --ca-cert FILE  https: trust the certificate authorities in FILE (PEM; default $ROBOCAL_CA_CERT, else the
                  system's), e.g. a lab server's self-signed certificate itself
  --insecure      https: do NOT verify the server's certificate. Anyone on the network path can then pose as
                  the server and read the token. Only for a first test against a self-signed lab server;
                  use --ca-cert instead.
  --json          print the resource as the service's JSON instead of tables (for scripts)
  --help          help for robocal, for a command family (robocal campaign --help) or for one command
                  (-h for short; -o FILE is short for --out FILE)

An option that a command does not take is a usage error naming it (robocal robots --count 3).

Exit codes: 0 ok, 1 service error (HTTP 4xx/5xx; the error's status, message and fields go to stderr),
2 usage error, 3 connection failure.
)";

const HelpText kRobots = {"list preset and registered robots", R"(
Lists the preset and registered robots: id, preset or not, number of joints, description.
--json: the robot list ({"robots": [...]}, every page).
)"};

const HelpText kRobotRegister = {"register a robot model (DH / MDH / transform table; see the API docs)", R"(
FILE.json is the body of POST /v1/robots, e.g.
  {"id": "cell7", "from_preset": "ur5e", "tool": {"position_mm": [0, 0, 120], "rpy_deg": [0, 0, 0]}}
or a full table: {"id": ..., "convention": "dh"|"mdh"|"transform", "joints": [...], "base": ..., "tool": ...}.
Prints the robot as `robot get` does.
)"};

const HelpText kRobotFromCalibration = {"register a campaign's calibrated robot as a robot of its own", R"(
robot register --from-calibration CAMPAIGN --id ID: the robot as CAMPAIGN calibrated it (POST /v1/robots with
"from_calibration"), for a new cell or session: its calibrated kinematics, joint names and limits, the nominal
base and the calibrated tool, and the joint terms of a fit with compliance or harmonics (each joint then holds
its compliance in deg/(N*m) and its harmonics in degrees, and the robot deflects under a payload as the
calibration does). The tracker -> base registration stays with the campaign: after the tracker moved
or the probe was re-seated, create a campaign of ID, upload a few poses and `fit --scope frames` (the base and
the tool only). --description says what it is (default: where it came from). Prints the robot; `robot get`
shows its source as "calibrated from".
)"};

const HelpText kRobotImport = {"register a robot from its URDF file (the chain from --base down to --tip)", R"(
Sends FILE.urdf to POST /v1/robots: the joints from link --base down to link --tip become the robot, with the
URDF's joint names; fixed joints are folded into the next moving joint, an axis other than +z into a fixed
rotation, and the tip link is the flange (docs/formats.md). --id names the robot (default: the URDF's robot
name, in lower case); --description says what it is. --tool-mm X,Y,Z puts the tool point at that offset from
the tip link (mm, tip frame; orientation that of the tip). Prints the robot as `robot get` does; errors name
the URDF element.
)"};

const HelpText kExport = {"the calibrated robot in a format robot software loads (--format urdf|dh|mdh|json)", R"(
--format urdf (the default): a URDF document whose kinematics are the calibrated robot's (docs/formats.md): a
robot imported from a URDF comes back as its own document with the identified errors folded into the chain's
joint origins, any other robot as a generated one; both end in a link robocal_tool, the calibrated tool.
--format dh | mdh: the calibrated robot as a standard / modified DH table, rebuilt from the calibrated joint
axes: a robot definition (JSON) that `robocal robot register` takes as it is; base = tracker -> frame 0, tool =
last frame -> calibrated tool. Axes parallel in the model that the calibration tilts apart have no usable DH
table: the service says which row and which identified parameters, and urdf or json is the way out.
--format json: the stored calibration (GET /v1/campaigns/{c}/calibration). Written to stdout, or to --out FILE.
)"};

const HelpText kRobotGet = {"one robot: its joints, limits and units", R"(
Prints the robot's joints (type, limits in the joint's unit). --json: the robot resource.
)"};

const HelpText kRobotDelete = {"delete a registered robot (presets cannot be deleted)", R"(
Campaigns keep their copy of the robot's definition. --json: the service's reply ({}).
)"};

const HelpText kRobotForward = {"nominal tool poses for joint vectors (CSV in, CSV out)", R"(
IN.csv is a joints CSV (header, one row per configuration, degrees / mm); writes the nominal model's tool poses
(world frame: the nominal base) as the joint columns, x_mm,y_mm,z_mm,qw,qx,qy,qz to OUT.csv or stdout.
--payload KG[@X,Y,Z]: the payload on the flange (kg, centre of mass in mm, flange frame) under which a robot
holding joint compliances (registered from a compliant calibration) deflects. --json: the forward result
(frame and poses).
)"};

const HelpText kCellCreate = {"register a measurement cell (tracker, reflectors, obstacles; docs/cells.md)", R"(
FILE.json is the body of POST /v1/cells, e.g.
  {"id": "cell-a", "robot": "ur5e",
   "tracker": {"position_mm": [2500, -800, 300], "min_distance_mm": 1500, "max_distance_mm": 15000},
   "reflectors": [{"id": "smr1", "position_mm": [0, 0, 120], "normal": [0, 0, 1],
                   "acceptance_half_angle_deg": 30}],
   "obstacles": [{"id": "floor", "box": {"min_mm": [-3000, -3000, -500], "max_mm": [3000, 3000, -10]}}],
   "clearance_mm": 20}
Everything in the robot's base frame; reflectors in the flange frame. Prints the cell with every default
filled in (--json: the cell resource).
)"};

const HelpText kCellList = {"list the cells", R"(
One row per cell: id, robot, reflectors, obstacles, description. --json: GET /v1/cells, every page.
)"};

const HelpText kCellGet = {"one cell, with every default filled in", R"(
--json: the cell resource.
)"};

const HelpText kCellDelete = {"delete a cell (plans made in it keep their configurations and checks)", R"(
--json: the service's reply ({}).
)"};

const HelpText kCellCheck = {"which configurations a cell can measure (CSV in, CSV out)", R"(
IN.csv is a joints CSV (header, one row per configuration, degrees / mm, within the robot's limits). Writes
one row per configuration: row, feasible (1/0), min_clearance_mm and the pair that sets it, the measurable
reflectors, and the reasons when infeasible, to OUT.csv or stdout; the count of feasible ones on stderr.
--json: the check result (per configuration: feasible, per reflector incidence_deg, distance_mm and what
blocks it, min_clearance_mm, failed_rules, reasons).
)"};

const HelpText kPlan = {"optimal measurement configurations", R"(
Asks the service for M measurement configurations that make the calibration well conditioned, and prints
them (one row per configuration, in the joints' units) with their observability indices and predicted
accuracy against a random set of the same size.

  --count M|auto       configurations (default 10); auto: the smallest N in --min-count..--max-count (default
                       6..60) whose predicted error on the task reaches --goal-mm MM (prints the curve)
  --candidates SOURCE  choose the configurations among the cell's own: a joints CSV (as --out writes), a JSON
                       file (a list of joint vectors), a tracker export with joint columns (with --format csv
                       --joints H1,... --joint-unit deg|rad and upload's --unit, --delimiter, --decimal,
                       --encoding), or a campaign id (the joints of its measurements); prints the candidates'
                       account and a warning naming joints too narrow to determine the model's parameters
  --malformed refuse|reject  a candidate with the wrong joint count or beyond the limits: refuse the request
                       (default) or count it as rejected
  --purpose check      8 to 15 well-spread poses (log_det) for a drift check of a calibrated robot
                       (robocal check; docs/drift.md)
  --task FILE.csv      the poses the robot will work in (joints CSV): predicted_error's sample (and then the
                       default objective) and the predicted accuracy's
  --task-box X0,Y0,Z0:X1,Y1,Z1  or a box of the base frame (mm), with --task-rpy R,P,Y/... tool orientations
                       (deg) and --task-count N configurations (default 50)
  --cell CELL          plan only configurations the cell can measure (robocal cell create); each planned
                       configuration comes with its feasibility report (--json: configuration_checks)
  --type TYPE          pose, position_axis or position (default pose)
  --objective NAME     condition_number, o1, o2, o3, o4, o5, log_det, predicted_error (default
                       condition_number; from candidates or with auto log_det, with a task predicted_error)
  --optimiser NAME     solis_wets, random or exchange (default solis_wets)
  --seed N             seed of the search (default 1); the same seed gives the same plan
  --tracker MODEL      weigh the rows by the tracker's uncertainty model, as campaign create takes it
                       (datasheet, or R,r,T,t[,O[,K]]); in a cell from its tracker's place
  --reflectors NESTS   plan for shots of these nests (--type position; at most 4), as campaign create
                       takes them (ID:X,Y,Z[:fixed]/...): the set they identify, not the tool point's
  --async              run as a long-running operation and wait for it with a progress bar on stderr
  --out FILE           also write the configurations: FILE.csv (joints CSV) or FILE.json (the plan)
)"};

const HelpText kPlanGet = {"a stored plan (configurations and indices)", R"(
Prints a stored plan as `robocal plan` does (GET /v1/plans/{plan}); --out FILE.csv|FILE.json writes it like a
new one. --json: the plan resource.
)"};

const HelpText kCampaignCreate = {"create a calibration campaign (TYPE: pose, position_axis, position)", R"(
TYPE is what the tracker measures. --plan links a plan (same robot and type); --id names the campaign
(generated otherwise); --description says what it is for. --tracker sets the tracker's uncertainty model the
fit whitens residuals with (docs/identification.md): "datasheet" for radial 10 um + 0.3 um/m and transverse
15 um + 6 um/m MPE, orientation 0.01 deg, MPE = 2 sigma; or R,r,T,t[,O[,K]] for radial R um + r um/m,
transverse T um + t um/m, orientation O deg, MPE = K sigma (K = 1: the figures are 1-sigma values). Without
it every axis weighs alike (0.015 mm). --repeatability-mm: the robot's ISO 9283 repeatability RP, which the
shots of one configuration share (the fit then does not count them as independent). --reflectors lists the
reflector nests on the tool (position campaigns; TYPE position), each ID:X,Y,Z in mm in the flange frame,
separated by "/", ":fixed" for a nest whose position is known (held; the others' offsets are identified), e.g.
smr1:60,0,20/smr2:-30,52,20/smr3:-30,-52,20; every measurement then names its reflector. Free nests locate
themselves, not the tool point; fixed ones calibrate it. --payload KG[@X,Y,Z]: the payload the robot carries while
it is measured (kg; centre of mass in mm, flange frame, default its origin), which a compliance model deflects
under (fit --model); compensation takes it too unless told otherwise. Prints the campaign id; --json: the
campaign.
)"};

const HelpText kCampaignList = {"every campaign, with its measurement counts and whether it is calibrated", R"(
One row per campaign: id, robot, measurement type, calibration and validation measurements stored, and
whether the campaign is calibrated (has a stored fit). --json: the campaign list ({"campaigns": [...]},
every page), each campaign as `campaign get --json` prints it.
)"};

const HelpText kCampaignGet = {"one campaign", R"(
Prints the campaign's robot, measurement type, measurement counts and whether it is calibrated, its tracker
model, repeatability and reflectors where it has them.
--json: the campaign resource.
)"};

const HelpText kCampaignForward = {"tool poses of the calibrated robot (tracker frame), CSV in, CSV out", R"(
IN.csv is a joints CSV; writes the calibrated robot's tool poses in the tracker frame (the joint columns, then
x_mm,y_mm,z_mm,qw,qx,qy,qz) to OUT.csv or stdout. Needs a fit. --payload KG[@X,Y,Z]: the payload on the
flange under which a calibration with compliance deflects (default: the campaign's, or none). --json: the
forward result.
)"};

const HelpText kUpload = {"upload tracker measurements (CSV or JSON, or the tracker's own export)", R"(
FILE is CSV (*.csv) or JSON. CSV: a header, then one row per tracker shot: the joint columns (degrees for
revolute, mm for prismatic joints, in joint order), x_mm,y_mm,z_mm (tool position, tracker frame) and
qw,qx,qy,qz (tool orientation; may be left out for position campaigns), and for a campaign with reflectors a
last column reflector naming each shot's nest. JSON: a batch
{"request_id": ..., "role": ..., "measurements": [{"joints": [...], "pose": {...}}]}, or just the array.
The upload is atomic and idempotent: the same request id with the same content is stored once, so a repeated
upload is safe. Without --request-id (and none in the JSON) it is derived from the content.
--role (calibration or validation) defaults to calibration (or the JSON's role). --json: the batch result.

--format sa|csv: FILE is the tracker's own point export, sent to POST .../measurements:import (docs/formats.md)
and matched to the configurations of --plan (default: the campaign's plan). The campaign must measure
position. sa: `//` header lines (`// Units: mm` declares the unit) and `collection group target x y z` rows,
comma or white space between fields. csv: a header row; --columns names the columns read (default
target=target,x=x,y=y,z=z; reflector=... for a campaign with nests). --unit mm|m|in: the coordinates' unit
(required for csv; for sa when the file declares none). --match name (default): a point's configuration is its
target name's trailing number, 1-based (P007 is configuration 7); --match order: the points in file order,
--shots N per configuration (default: points / configurations). A bad line is named by its number, and then
nothing is stored.

A csv export that carries the robot's joints needs no plan (docs/formats.md, "Files with joints"):
  --joints C1,C2,...   the joint columns, one per joint in the robot's order
  --joint-unit deg|rad their unit
  --orientation-columns C1,C2,C3[,C4]
                       the measured orientation (pose and position_axis campaigns), as a quaternion:
  --quaternion-order wxyz|xyzw   what the four columns hold, or as Euler angles:
  --euler SEQUENCE     the axes of the first, second and third rotation (XYZ, ZYX, ZXZ, ...)
  --euler-convention intrinsic|extrinsic   about the turning axes or about the tracker's fixed axes
  --angle-unit deg|rad the angles' unit
  --delimiter ,|;|tab  the field delimiter (default: the header's most frequent of them)
  --decimal .|,        the decimal separator (default .; European exports write 0,25)
  --encoding auto|utf-8|latin-1   the file's encoding (default auto: UTF-8 if it is, else Latin-1)
  --calibration-rows N N data rows drawn at random are calibration measurements, the rest validation (two
                       imports; --seed S, default 1, makes the draw; not with --role)
  --payload KG[@X,Y,Z] the payload the robot carried for every measurement of the file (kg; centre of mass in
                       mm, flange frame); default: the campaign's (any file format)
Rows with equal joints are shots of one pose. Example (the IPA UR10 files, tests/data/ipa):
  robocal upload C series_b.csv --format csv --unit mm --decimal , --columns x=measurement_x,y=measurement_y,
    z=measurement_z --joints shoulder_pan_joint,...,wrist_3_joint --joint-unit rad --orientation-columns
    measurement_rx,measurement_ry,measurement_rz --euler XYZ --euler-convention intrinsic --angle-unit deg
)"};

const HelpText kMeasurements = {"the stored measurements as CSV (the upload format) or JSON", R"(
The campaign's stored measurements in upload order, as the measurement CSV that `robocal upload` reads (the
joint columns, x_mm,y_mm,z_mm, and qw,qx,qy,qz unless the campaign measures position only), to FILE.csv or
stdout. --role: only one role, calibration or validation (default both); --after: continue after that
sequence number; --limit: at most N measurements (default all). --json: the measurement list (every page
up to --limit, with sequence, batch and role of each; next_after set when --limit stopped it).
)"};

const HelpText kFit = {"identify the parameters; prints the parameter table", R"(
Identifies the error parameters from the calibration measurements and prints them (value and standard
deviation, mm or degrees), the parameters left out as unidentifiable and why, the residuals before and after,
and the robot error the geometric model does not explain (estimated beside the tracker's noise; RMS).
The fit is stored as the campaign's calibration, unless it stopped at the service's request deadline or was
cancelled: then it is printed with "NOT stored". --json: the calibration (fit) resource.

  --parameters a,b,... the parameters to estimate (default: the identifiable set)
  --no-register-base   do not register the base (tracker -> base) before identifying
  --max-iterations N   Levenberg-Marquardt iterations at most (default 100)
  --keep-outliers      plain least squares: no robust fit (by default measurements whose studentised
                       residual exceeds the chi-square threshold are excluded and listed by sequence number)
  --outlier-probability P
                       chance that a clean measurement is flagged (default 0.001; 1e-12 to 0.1; unused
                       with --keep-outliers)
  --scope all|frames   all (default): the identifiable parameters; frames: the base and the tool only, the
                       robot's kinematics held (a calibrated robot in a new cell: robot register
                       --from-calibration)
  --no-model-error     take the campaign's noise model as the whole error (by default the robot error the
                       geometric model does not explain is estimated beside it and weights the fit)
  --model M            the model: geometric (default); a list of compliance (one per revolute joint,
                       rotation = c x gravity torque; the robot needs link masses) and harmonics=N (N = 1 or
                       2: sin and cos of each joint's own angle up to order N), e.g. compliance,harmonics=2,
                       and joint_maps=Sdeg[:JOINTS] (each joint's angle error as a cubic B-spline of its
                       angle, knots every S degrees over the poses' range; JOINTS e.g. 1-5 or 2+3, every
                       revolute joint by default) with smoothness=L (its penalty's weight, default 0.01),
                       e.g. compliance,joint_maps=4deg:1-5;
                       or auto: every candidate cross-validated on the calibration measurements, the
                       simplest within one standard error of the best chosen, and the comparison printed
  --priors P           parameter priors (a MAP fit: each parameter held near zero by its expected size):
                       defaults (1 mm lengths, 0.1 deg angles and joint offsets; none on the base and tool),
                       KEY=V,... (lengths_mm, angles_deg, joint_offsets_deg, joint_offsets_mm, base_length_mm,
                       base_angle_deg, tool_length_mm, tool_angle_deg, scale, or a parameter's name, e.g.
                       joint2.dz=0.5), or auto: the defaults at the scale cross-validation finds best (prints
                       every scale's held-out error); lists the parameters the prior rather than the data held
  --folds N            auto: cross-validation folds (default 5; 2 to 20)
  --cv-seed S          auto: the seed that deals the poses to the folds (default 1)
  --cv-maps            auto: the candidates include joint error maps on every revolute joint, knots every 8,
                       4 and 2 degrees (with compliance if the robot has masses); their fits take longer
  --async              run as a long-running operation and wait for it with a progress bar on stderr
                       (robocal operation cancel ID stops it; a cancelled fit is not stored)
)"};

const HelpText kCompensate = {"compensated joints for nominal joint commands or tool poses (CSV in, CSV out)", R"(
IN.csv: nominal joint commands (a joints CSV: header, one row per configuration, degrees / mm), or tool pose
targets: header x_mm,y_mm,z_mm,qw,qx,qy,qz, optionally followed by shoulder, elbow and wrist columns naming the
branch (front/back, up/down, noflip/flip; an empty cell leaves the flag free). Poses are in the tracker
frame, or the calibrated robot base frame with --frame base. Writes the compensated joints that take the
calibrated robot to each target, with position_error_mm, orientation_error_deg, predicted_error_mm (a 95 %
bound on the position error the robot will have there: the fit's uncertainty and its model error; empty without
joints) and converged (0/1) columns, and for a 6R arm with named branches the shoulder, elbow and wrist of each
result, to OUT.csv or stdout. A pose without flags takes the branch shoulder front, elbow up, wrist noflip, or
the previous row's with --sequence. --json: the compensation result (per target: joints, errors, free rotation,
converged, iterations, message, configuration, predicted_error_mm).
--sequence: the rows are one program, in order: joint_jump_deg (the largest revolute joint move from the
previous row's result, deg; empty on the first row), joint_jump (1 when it exceeds --max-jump DEG, default
30) and branch_change (1 when the branch differs from the previous row's), so that you see where the
compensated program would swing the robot.
--payload KG[@X,Y,Z]: the payload at every target (kg; centre of mass in mm, flange frame); a calibration with a
compliance model brings the robot loaded so to the targets. Default: the campaign's payload, or none.
)"};

const HelpText kCompensateProgram = {"a robot program compensated: KRL, RAPID, URScript, FANUC LS or VAL3 in and out", R"(
FILE...: one program in its controller's language: a KUKA KRL .src with its .dat, ABB RAPID modules (.mod,
.prg), a URScript .script, a FANUC TP source .ls or a Staubli VAL3 data file .dtx; the extensions name the
dialect, or --dialect does. Every joint and Cartesian target is compensated on the campaign's calibration and
written back into the same bytes, in the same number format (at least 3 decimals in mm, 4 in degrees); every
other byte (comments, spacing, line ends, speeds, zones) comes back as it was. A Cartesian target is solved on
the branch its configuration names and written as the nominal pose of the compensated joints, so that the
controller's own inverse kinematics lands the real robot (docs/programs.md).
--out DIR: write the compensated files there (created if missing) and print a line per target (correction,
joint change, predicted error, or why it was kept as written). Without it, one file is written to stdout and
the report to stderr. --json: the whole reply.
--tools TOOLS.json, --bases BASES.json: the program's tools (T_flange_tool) and bases / work objects (in the
robot base) by the number or name the program uses, as the dialect writes a Cartesian target, e.g.
{"1": [0, 0, 180, 0, 0, 0]} for KRL (X, Y, Z, A, B, C). A tool without an entry is the calibrated robot's own;
a base without one is refused, except the identity (BASE 0, wobj0, UF 0, world).
--max-path-deviation MM: straight moves whose path leaves the programmed line by more than MM get
intermediate targets (KRL, RAPID, URScript). --on-failure keep (default) keeps a target that cannot be
compensated as written and reports it; refuse refuses the whole program. --payload KG[@X,Y,Z]: the payload.
)"};

const HelpText kEvaluate = {"the accuracy table (E_xyz, E_cos, E_tot) on the validation measurements", R"(
The paper's accuracy table on the campaign's validation measurements, nominal model against calibrated
model: E_xyz (position, um), E_cos (tool axis angle, urad shown as um at 1 m), E_tot = E_xyz + H E_cos;
mean, std, max and RP = mean + 3 std. --h-mm H defaults to 30 mm. --json: the evaluation.
)"};

const HelpText kReport = {"the campaign report: one HTML page to look at and print (--out FILE.html)", R"(
Fetches GET /v1/campaigns/{c}/report: one self-contained HTML page (inline SVG and CSS, no script, no external
asset; prints one section per page) of the campaign's robot, the plan it was made from (configurations,
observability indices, predicted accuracy, and stick figures around the tracker when the plan has a cell),
the fit (parameters with std and std in percent, dropped parameters, the most correlated pairs, singular
values, residuals before and after, outliers), the residual of each configuration as bars, and the
validation table (E_xyz, E_cos, E_tot before and after) with the distribution of E_xyz (docs/report.md).
Written to --out FILE (-o FILE), or to stdout. --h-mm H: E_tot = E_xyz + H E_cos[rad] (default 30 mm).
The campaign must be calibrated (robocal fit) first.
)"};

const HelpText kIso9283Plan = {"lay out the ISO 9283 pose test: P1-P5 in a cube, the joint commands, the tags", R"(
Makes a plan (POST /v1/plans with "test") of the ISO 9283 pose test (docs/iso9283.md): P1 at the centre of the
cube given by --center X,Y,Z (robot base frame, mm) and --size MM, P2-P5 on its diagonal plane at 10 % of the
diagonal from the corners, the tool in --rpy R,P,Y (fixed-axis roll, pitch, yaw, deg; default 180,0,0: pointing
down), visited P1 -> P5 --cycles N times (default 30). --size auto (with --cell) takes the largest cube the robot
reaches in the cell. --compensated-by CAMPAIGN: the joint commands of that calibration, so that the same test
runs after calibration. Prints the poses and their joint commands; --out PLAN.json writes the plan, which
robocal-mock-tracker --dump-measurements F --configurations PLAN.json measures as tagged test shots. Create the
campaign with --plan PLAN so that the report compares with the planned poses.
)"};

const HelpText kCheck = {"does the robot still hold its calibration? a drift check on a few shots", R"(
POST /v1/robots/{r}:check (docs/drift.md): the shots (CSV as upload reads it, or JSON) of a robot registered
from a calibration, compared with what its calibration predicts: the residual level and the one parameter that
best explains them, each against its threshold from the calibration's own shots. Prints the verdict (holds or
drifted), the statistics and, when drifted, the suspects (a joint offset first) with their change. --frames
register (default: the tracker or the probe moved; a joint 1 or 6 offset then looks like a moved base or tool)
or keep (the tracker stayed); --rate P the stated false alarm rate (default 0.05); --type the shots' type
(default the calibration's). Each check is an entry of the robot's history. A check plan
(robocal plan ROBOT --purpose check) gives 8-15 well-spread poses.
)"};

const HelpText kRobotHistory = {"the calibrations a robot has carried, its checks and rollbacks", R"(
GET /v1/robots/{r}/calibrations: every entry in order (registered, calibrated, check, rollback), when, from which
campaign, by which token (its name from the server's tokens file), a check's verdict and suspects.
)"};

const HelpText kRobotCalibrate = {"put a campaign's calibration on a robot (a new history entry)", R"(
POST /v1/robots/{r}:calibrate: the robot's definition becomes CAMPAIGN's calibrated robot (a campaign of this
robot, or of the robot it was calibrated from). --note TEXT for the history. Prints the history.
)"};

const HelpText kRobotRollback = {"put a robot back on an earlier entry's calibration (a new history entry)", R"(
POST /v1/robots/{r}:rollback: the robot's definition becomes exactly the one entry ENTRY put on it; nothing is
removed from the history. --note TEXT for the history. Prints the history.
)"};

const HelpText kIso9283Report = {"the ISO 9283 pose characteristics (AP, RP, AD, RD) of a campaign's test shots", R"(
GET /v1/campaigns/{c}/iso9283: per pose AP (with APx, APy, APz, APa, APb, APc) and RP (RPl, RPa, RPb, RPc), and
the distance accuracy AD and repeatability RD of P1-P2 and P2-P4, from the campaign's shots of role test
(each tagged with test_pose and cycle). "measured" is the test as run; a calibrated campaign also gets
"calibrated": the accuracy with commands compensated by its calibration. Repeatability needs 2 cycles: with
one it is n/a (not measurable). --csv prints the CSV table, --json the report; --out FILE writes to a file.
)"};

const HelpText kOperationWait = {"wait for an async plan or fit, drawing progress on stderr", R"(
Polls until the operation is done; exit 1 if it failed. --json: the operation as it ended.
)"};

const HelpText kOperationGet = {"a long-running operation's state", R"(
--json: the operation resource.
)"};

const HelpText kOperationCancel = {"cancel a long-running operation (a cancelled fit is not stored)", R"(
Cancelling a finished operation changes nothing. --json: the operation resource.
)"};

const HelpText kExperiment = {"the paper's simulated experiment, run locally (no server)", R"(
The paper's simulated experiment, run locally by the calibration core (no server involved): per trial, a
robot with new hidden geometric errors; M configurations planned by Solis & Wets, by random selection and by
exchange; each plan measured by a simulated laser tracker and identified; then random validation poses
compensated on each calibration. Prints E_xyz, E_cos and E_tot (mean, std, max, RP = mean + 3 std) before and
after calibration per method, and the improvement over random selection. Progress goes to stderr. --json
prints the pooled results as JSON (the accuracies in the service's form). The same flags as
robocal-experiment:

)"};

}  // namespace robocal::cli::help
