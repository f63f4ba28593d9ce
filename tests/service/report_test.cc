// The campaign report: the renderer on hand-made data (escaping, numbers equal to their inputs, statistics by
// hand, sections without data), and GET /v1/campaigns/{c}/report on the real server (its numbers against the
// calibration and :evaluate replies, the recomputed condition number against the fit's, the refusals).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "raw_http.h"
#include "robocal/api/calibration.h"
#include "robocal/core/presets.h"
#include "robocal/core/virtual_cell.h"
#include "server/src/report_html.h"
#include "test_server.h"

namespace robocal::server::testing {
namespace {

using nlohmann::json;

// The data-value of the first cell with data-key `key` after `anchor` in `page` (NaN when absent).
double ValueAfter(const std::string& page, const std::string& anchor, const std::string& key) {
  const std::size_t at = page.find(anchor);
  if (at == std::string::npos) return std::nan("");
  const std::string marker = "data-key=\"" + key + "\" data-value=\"";
  const std::size_t cell = page.find(marker, at);
  if (cell == std::string::npos) return std::nan("");
  const std::size_t start = cell + marker.size();
  return std::stod(page.substr(start, page.find('"', start) - start));
}

std::size_t Count(const std::string& page, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = page.find(what); at != std::string::npos; at = page.find(what, at + what.size())) ++n;
  return n;
}

report::ReportData HandMadeData() {
  report::ReportData d;
  d.campaign = "c1";
  d.description = "<script>alert('description')</script>";
  d.measurement_type = MeasurementType::kPose;
  d.robot = api::RobotFromModel("<script>robot</script>", Preset("grinder5"), false, "a & b");
  d.plan_missing = "The campaign was not made from a plan (it names none).";
  api::CalibrationResult& c = d.fit.calibration;
  c.parameters = {{"joint2.dz", "mm", 0.5, 0.01}, {"joint3.rx", "deg", -0.2, 0.01}, {"<b>bold</b>", "mm", 0.0, 0.003}};
  c.dropped = {{"joint1.dz", "not identifiable: <in the null space>"}};
  c.condition_number = 42.5;
  c.residuals_before.rms_position_mm = 1.25;
  c.residuals_after.rms_position_mm = 0.0125;
  c.robust.enabled = true;
  c.robust.threshold = 4.1;
  c.outliers = {{17, "", 9.5, true}};
  d.fit.singular_values = {3.0, 1.5, 0.25};
  d.fit.condition_number = 12.0;
  d.fit.correlations = {{"joint2.dz", "joint3.rx", -0.987654}};
  for (int k = 0; k < 5; ++k) {
    report::PoseResidual p;
    p.first_sequence = p.last_sequence = k + 1;
    p.shots = 1;
    p.before_position_mm = 1.0 + k;
    p.after_position_mm = 0.01 * (k + 1);
    p.outliers = k == 3 ? 1 : 0;
    d.fit.poses.push_back(p);
  }
  return d;
}

// A fit whose model was chosen by cross-validation: the model and every candidate's held-out error are shown, a
// compliance in its own unit with its significant digits.
TEST(ReportHtmlTest, EachJointMapIsACurveWithItsBand) {
  report::ReportData d = HandMadeData();
  EXPECT_EQ(report::RenderReport(d).find("joint-maps"), std::string::npos);
  d.fit.maps.push_back({"J2", {-10.0, 0.0, 10.0}, {0.001, -0.002, 0.003}, {0.0005, 0.0004, 0.0006}});
  const std::string page = report::RenderReport(d);
  EXPECT_NE(page.find("<section id=\"joint-maps\">"), std::string::npos);
  EXPECT_NE(page.find("class=\"map-curve\" data-joint=\"J2\" data-samples=\"3\""), std::string::npos);
  // The band: the three upper points, then the three lower ones.
  const std::size_t band = page.find("class=\"map-band\" points=\"");
  ASSERT_NE(band, std::string::npos);
  const std::string points = page.substr(band, page.find('"', band + 30) - band);
  EXPECT_EQ(std::count(points.begin(), points.end(), ','), 6) << points;
}

TEST(ReportHtmlTest, TheModelChoiceIsShown) {
  report::ReportData d = HandMadeData();
  api::CalibrationResult& c = d.fit.calibration;
  c.model = {.compliance = true, .joint_harmonics = 2};
  c.model_choice = api::ModelChoiceWire{
      5,
      {{{.compliance = false, .joint_harmonics = 0}, "geometric", 48, 0.41, 0.46, 0.017, 0, "", false},
       {{.compliance = true, .joint_harmonics = 0},
        "compliance",
        54,
        0,
        0,
        0,
        2,
        "fold 1: implausible joint4.compliance 31 deg/(N*m)",
        false},
       {{.compliance = true, .joint_harmonics = 2}, "compliance + harmonics 2", 78, 0.342, 0.38, 0.0165, 0, "", true}}};
  c.parameters.push_back({"joint2.compliance", "deg/(N*m)", 6.3147e-4, 3.38e-5});
  const std::string page = report::RenderReport(d);
  EXPECT_NE(page.find("<td>compliance + harmonics 2 (chosen by cross-validation, below)</td>"), std::string::npos);
  EXPECT_NE(page.find("5-fold cross-validation"), std::string::npos);
  EXPECT_EQ(ValueAfter(page, "data-model=\"geometric\"", "cv_mean_mm"), 0.41);
  EXPECT_EQ(ValueAfter(page, "data-model=\"compliance + harmonics 2\"", "cv_standard_error_mm"), 0.0165);
  EXPECT_NE(page.find("2 fold(s) not eligible: fold 1: implausible joint4.compliance"), std::string::npos);
  EXPECT_EQ(Count(page, "<td>chosen</td>"), 1u);
  EXPECT_EQ(ValueAfter(page, "data-parameter=\"joint2.compliance\"", "value"), 6.3147e-4);
  EXPECT_NE(page.find("\">0.00063147</td>"), std::string::npos);
}

TEST(ReportHtmlTest, EscapesEveryUserString) {
  EXPECT_EQ(report::EscapeHtml("<script>alert(\"x\")&'</script>"),
            "&lt;script&gt;alert(&quot;x&quot;)&amp;&#39;&lt;/script&gt;");
  EXPECT_EQ(report::EscapeHtml("tab\tnew\nline"), "tab\tnew\nline");
  EXPECT_EQ(report::EscapeHtml(std::string("bell\x07")), "bell\xEF\xBF\xBD");
  // Invalid UTF-8 becomes visible text, never a byte a browser would guess at.
  EXPECT_EQ(report::EscapeHtml(std::string("a\xFF<")), "a\\xff&lt;");
  EXPECT_EQ(report::EscapeHtml("Gr\xC3\xBC\xC3\x9F"), "Gr\xC3\xBC\xC3\x9F");

  const std::string page = report::RenderReport(HandMadeData());
  EXPECT_EQ(page.find("<script"), std::string::npos) << "a stored name came out as markup";
  EXPECT_EQ(page.find("<b>bold"), std::string::npos);
  EXPECT_NE(page.find("&lt;script&gt;robot&lt;/script&gt;"), std::string::npos);
  EXPECT_NE(page.find("&lt;script&gt;alert(&#39;description&#39;)&lt;/script&gt;"), std::string::npos);
  EXPECT_NE(page.find("not identifiable: &lt;in the null space&gt;"), std::string::npos);
  EXPECT_NE(page.find("a &amp; b"), std::string::npos);
}

TEST(ReportHtmlTest, TablesHoldTheInputNumbers) {
  const report::ReportData d = HandMadeData();
  const std::string page = report::RenderReport(d);
  EXPECT_EQ(page.rfind("<!DOCTYPE html>", 0), 0u);
  for (const api::ParameterEstimate& p : d.fit.calibration.parameters) {
    const std::string row = "<tr data-parameter=\"" + report::EscapeHtml(p.name) + "\">";
    EXPECT_EQ(ValueAfter(page, row, "value"), p.value) << p.name;
    EXPECT_EQ(ValueAfter(page, row, "std"), p.std) << p.name;
  }
  // std in percent of |value|, by hand: 0.01 / 0.5 = 2 %, 0.01 / 0.2 = 5 %, none for a zero value.
  EXPECT_DOUBLE_EQ(ValueAfter(page, "data-parameter=\"joint2.dz\"", "std_percent"), 2.0);
  EXPECT_DOUBLE_EQ(ValueAfter(page, "data-parameter=\"joint3.rx\"", "std_percent"), 5.0);
  EXPECT_NE(page.find("data-key=\"std_percent\" data-value=\"nan\">n/a</td>"), std::string::npos);
  // Rounded text beside the exact value: mm to 0.1 um, deg to 1e-5 deg.
  EXPECT_NE(page.find("data-value=\"0.5\">0.5000</td>"), std::string::npos);
  EXPECT_NE(page.find("data-value=\"-0.20000000000000001\">-0.20000</td>"), std::string::npos);
  EXPECT_EQ(ValueAfter(page, "id=\"fit-summary\"", "condition_number"), 42.5);
  EXPECT_EQ(ValueAfter(page, "id=\"fit-residuals\"", "residuals_before.rms_position_mm"), 1.25);
  EXPECT_EQ(ValueAfter(page, "id=\"fit-residuals\"", "residuals_after.rms_position_mm"), 0.0125);
  EXPECT_EQ(ValueAfter(page, "id=\"correlations\"", "rho"), -0.987654);
  EXPECT_EQ(ValueAfter(page, "id=\"outliers\"", "sequence"), 17.0);
  EXPECT_EQ(Count(page, "data-key=\"singular_value\""), 3u);
  EXPECT_NE(page.find("id=\"fit-condition-number\" data-value=\"12\""), std::string::npos);
  // One bar group per configuration in each chart (position and, for pose measurements, orientation), the
  // outlier marked once in each.
  EXPECT_EQ(Count(page, "<g class=\"pose"), 2 * 5u);
  EXPECT_EQ(Count(page, "class=\"outlier-mark\""), 2u);
  EXPECT_NE(page.find("data-first-sequence=\"4\" data-shots=\"1\" data-outliers=\"1\""), std::string::npos);
  // Units in the headers.
  const bool transform = d.robot.convention == GeometryConvention::kTransform;
  for (const char* header : {"RMS position (mm)", "RMS orientation (deg)", "std (% of |value|)",
                             transform ? "x (mm)" : "a (mm)", transform ? "roll (deg)" : "alpha (deg)"}) {
    EXPECT_NE(page.find(header), std::string::npos) << header;
  }
  // A print stylesheet with page breaks between sections, and nothing loaded from outside.
  EXPECT_NE(page.find("@media print"), std::string::npos);
  EXPECT_NE(page.find("break-before: page"), std::string::npos);
  EXPECT_EQ(page.find("src="), std::string::npos);
  EXPECT_EQ(page.find("<link"), std::string::npos);
}

TEST(ReportHtmlTest, SectionsWithoutDataSaySo) {
  report::ReportData d = HandMadeData();
  d.fit.calibration.outliers.clear();
  d.fit.correlations.clear();
  d.fit.singular_values.clear();
  d.fit.linearization_problem = "the fit estimated no parameters";
  d.fit.poses.clear();
  const std::string page = report::RenderReport(d);
  EXPECT_NE(page.find("The campaign was not made from a plan"), std::string::npos);
  EXPECT_NE(page.find("No validation measurements"), std::string::npos);
  EXPECT_NE(page.find("No outliers: no measurement was excluded."), std::string::npos);
  EXPECT_NE(page.find("Not available: the fit estimated no parameters"), std::string::npos);
  EXPECT_NE(page.find("No calibration measurements are stored."), std::string::npos);
  EXPECT_EQ(page.find("id=\"validation-table\""), std::string::npos);
  EXPECT_EQ(page.find("id=\"singular-values\""), std::string::npos);
}

TEST(ReportHtmlTest, ValidationTableInThePapersForm) {
  report::ReportData d = HandMadeData();
  report::ValidationSection v;
  // E_xyz of three poses 0.1, 0.2, 0.6 mm: mean 0.3, std (N - 1) sqrt(0.07) = 0.26458, RP = mean + 3 std.
  const std::vector<double> values = {0.1, 0.2, 0.6};
  const ErrorStatistics stats = ComputeErrorStatistics(values);
  EXPECT_NEAR(stats.mean, 0.3, 1e-15);
  EXPECT_NEAR(stats.std, std::sqrt(0.07), 1e-15);
  EXPECT_NEAR(stats.rp, 0.3 + 3.0 * std::sqrt(0.07), 1e-15);
  v.evaluation.num_validation = 3;
  v.evaluation.h_mm = 30.0;
  v.evaluation.nominal.e_xyz_mm = {3, stats.mean, stats.std, stats.max, stats.rp};
  v.evaluation.nominal.e_cos_deg = {3, 0.01, 0.002, 0.012, 0.016};
  v.evaluation.calibrated.e_xyz_mm = {3, 0.02, 0.005, 0.03, 0.035};
  v.evaluation.improvement_percent.e_xyz_mean = 100.0 * (0.3 - 0.02) / 0.3;
  v.e_xyz_before_mm = values;
  v.e_xyz_after_mm = {0.01, 0.02, 0.03};
  d.validation = v;
  const std::string page = report::RenderReport(d);
  // E_xyz and E_tot in um, E_cos in arcsec, as the column and row headers say.
  EXPECT_NEAR(ValueAfter(page, "id=\"validation-table\"", "nominal.e_xyz_um.mean"), 300.0, 1e-9);
  EXPECT_NEAR(ValueAfter(page, "id=\"validation-table\"", "nominal.e_xyz_um.std"), 1000.0 * std::sqrt(0.07), 1e-9);
  EXPECT_NEAR(ValueAfter(page, "id=\"validation-table\"", "nominal.e_xyz_um.rp"), 300.0 + 3000.0 * std::sqrt(0.07),
              1e-9);
  EXPECT_NEAR(ValueAfter(page, "id=\"validation-table\"", "calibrated.e_xyz_um.max"), 30.0, 1e-9);
  EXPECT_NEAR(ValueAfter(page, "id=\"validation-table\"", "nominal.e_cos_arcsec.mean"), 36.0, 1e-9);
  EXPECT_NEAR(ValueAfter(page, "id=\"improvement\"", "improvement.e_xyz_mean"), 93.333333333333329, 1e-9);
  EXPECT_NE(page.find("data-curve=\"before\" data-count=\"3\""), std::string::npos);
  EXPECT_NE(page.find("data-curve=\"after\" data-count=\"3\""), std::string::npos);
  EXPECT_NE(page.find("E_xyz (um)"), std::string::npos);
  EXPECT_NE(page.find("E_cos (arcsec)"), std::string::npos);
}

TEST(ReportHtmlTest, TopCorrelationsByHand) {
  Eigen::Matrix4d rho;
  rho << 1.0, 0.3, -0.9, 0.1,  //
      0.3, 1.0, 0.5, -0.95,    //
      -0.9, 0.5, 1.0, 0.2,     //
      0.1, -0.95, 0.2, 1.0;
  const std::vector<report::Correlation> top = report::TopCorrelations({"a", "b", "c", "d"}, rho, 3);
  ASSERT_EQ(top.size(), 3u);
  EXPECT_EQ(top[0].a + top[0].b, "bd");
  EXPECT_EQ(top[0].rho, -0.95);
  EXPECT_EQ(top[1].a + top[1].b, "ac");
  EXPECT_EQ(top[2].a + top[2].b, "bc");
  EXPECT_EQ(report::TopCorrelations({"a", "b", "c", "d"}, rho, 10).size(), 6u);
  EXPECT_TRUE(std::isnan(report::StdPercent(0.0, 1.0)));
  EXPECT_DOUBLE_EQ(report::StdPercent(-4.0, 1.0), 25.0);
}

TEST(ReportHtmlTest, ManyConfigurationsDrawAtMostTheCap) {
  report::ReportData d = HandMadeData();
  d.fit.poses.assign(report::kMaxResidualBars + 7, d.fit.poses[0]);
  const std::string page = report::RenderReport(d);
  EXPECT_EQ(Count(page, "<g class=\"pose"), 2 * report::kMaxResidualBars);  // position and orientation charts
  EXPECT_NE(page.find("The first " + std::to_string(report::kMaxResidualBars) + " configurations are drawn."),
            std::string::npos);
}

TEST(ReportHtmlTest, ManyOutliersListAtMostTheCap) {
  report::ReportData d = HandMadeData();
  // More outliers than the cap (the review had 30,156): only the largest normalised residuals are listed.
  d.fit.calibration.outliers.clear();
  const std::size_t n = report::kMaxOutlierRows + 30;
  for (std::size_t k = 0; k < n; ++k) {
    const double z = 5.0 + static_cast<double>((k * 7919) % n);  // all distinct, not in sequence order
    d.fit.calibration.outliers.push_back({static_cast<std::int64_t>(k + 1), "", z, true});
  }
  const std::string page = report::RenderReport(d);
  EXPECT_EQ(Count(page, "data-key=\"normalized_residual\""), report::kMaxOutlierRows);
  // Largest first: the first row is the largest, and no listed one is below one left out.
  EXPECT_EQ(ValueAfter(page, "id=\"outliers\"", "normalized_residual"), 5.0 + static_cast<double>(n - 1));
  EXPECT_EQ(page.find("data-value=\"34\">34.00</td>"), std::string::npos);
  EXPECT_NE(page.find("data-value=\"35\">35.00</td>"), std::string::npos);
  EXPECT_NE(page.find("The " + std::to_string(report::kMaxOutlierRows) + " largest of " + std::to_string(n) +
                      " excluded measurements are listed; 30 more are not"),
            std::string::npos);
  // Below the cap every outlier is listed and nothing is said about more.
  d.fit.calibration.outliers.resize(3);
  const std::string small = report::RenderReport(d);
  EXPECT_EQ(Count(small, "data-key=\"normalized_residual\""), 3u);
  EXPECT_EQ(small.find("more are not"), std::string::npos);
}

// ---- the endpoint ---------------------------------------------------------------------------------------

TEST(ReportEndpointTest, NumbersEqualTheCalibrationAndTheEvaluation) {
  TestServer s({}, {}, {}, OpenSqliteStorage(":memory:"));
  const RobotModel model = Preset("grinder5");
  const Reply plan = s.Post("/v1/plans", {{"robot", "grinder5"},
                                          {"num_configurations", 12},
                                          {"seed", 3},
                                          {"num_validation", 10},
                                          {"options", {{"k_max", 20}}}});
  ASSERT_EQ(plan.status, 200) << plan.text;
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "rep"},
                                     {"robot", "grinder5"},
                                     {"plan", plan.body["id"]},
                                     {"description", "<script>alert(1)</script> & co"}})
                .status,
            200);
  // Before the fit: refused as the other calibration routes refuse (FAILED_PRECONDITION naming the campaign).
  const Reply early = s.Get("/v1/campaigns/rep/report");
  EXPECT_EQ(early.status, 400);
  EXPECT_EQ(early.body["error"]["status"], "FAILED_PRECONDITION") << early.text;
  EXPECT_EQ(early.body["error"]["details"][0]["field"], "campaign");

  VirtualCellOptions o;
  o.seed = 11;
  o.shots_per_pose = 2;
  VirtualCell cell(model, o);
  std::vector<Eigen::VectorXd> configurations;
  for (const auto& q : plan.body["configurations"])
    configurations.push_back(api::JointsToCore(model, q.get<std::vector<double>>()));
  std::vector<Measurement> shots = cell.MeasureAll(configurations);
  shots[5].T_world_tool.translation() += Eigen::Vector3d(2.0, 0.0, 0.0);  // one gross error
  ASSERT_EQ(s.Post("/v1/campaigns/rep/measurements", Batch(model, shots, "cal", "calibration")).status, 200);
  Rng rng(5);
  const auto validation = cell.MeasureAll(RandomConfigurations(model, 15, &rng), 1);
  ASSERT_EQ(s.Post("/v1/campaigns/rep/measurements", Batch(model, validation, "val", "validation")).status, 200);
  const Reply fit = s.Post("/v1/campaigns/rep:fit", json::object());
  ASSERT_EQ(fit.status, 200) << fit.text;
  ASSERT_EQ(fit.body["outliers"].size(), 1u) << fit.text;
  const Reply evaluation = s.Post("/v1/campaigns/rep:evaluate", {{"h_mm", 50}});
  ASSERT_EQ(evaluation.status, 200);

  httplib::Client http = GuardedClient(s.port());
  const auto reply = http.Get("/v1/campaigns/rep/report?h_mm=50");
  ASSERT_TRUE(reply);
  ASSERT_EQ(reply->status, 200) << reply->body;
  EXPECT_EQ(reply->get_header_value("Content-Type"), "text/html; charset=utf-8");
  EXPECT_NE(reply->get_header_value("Content-Security-Policy").find("default-src 'none'"), std::string::npos);
  const std::string& page = reply->body;
  EXPECT_EQ(page.find("<script"), std::string::npos);
  EXPECT_NE(page.find("&lt;script&gt;alert(1)&lt;/script&gt; &amp; co"), std::string::npos);

  for (const json& p : fit.body["parameters"]) {
    const std::string row = "<tr data-parameter=\"" + p["name"].get<std::string>() + "\">";
    EXPECT_EQ(ValueAfter(page, row, "value"), p["value"].get<double>()) << row;
    EXPECT_EQ(ValueAfter(page, row, "std"), p["std"].get<double>()) << row;
  }
  // Recomputed from the stored calibration and measurements: the fit's own condition number.
  const std::string marker = "id=\"fit-condition-number\" data-value=\"";
  const std::size_t at = page.find(marker);
  ASSERT_NE(at, std::string::npos);
  const double recomputed = std::stod(page.substr(at + marker.size()));
  EXPECT_NEAR(recomputed / fit.body["condition_number"].get<double>(), 1.0, 1e-8);
  EXPECT_EQ(Count(page, "data-key=\"singular_value\""), fit.body["parameters"].size());
  EXPECT_EQ(Count(page, "data-key=\"rho\""), report::kTopCorrelations);
  // One bar group per configuration (two shots each) in each chart, the gross error's configuration marked.
  EXPECT_EQ(Count(page, "<g class=\"pose"), 2 * configurations.size());
  EXPECT_EQ(Count(page, "class=\"outlier-mark\""), 2u);
  EXPECT_EQ(ValueAfter(page, "id=\"outliers\"", "sequence"), fit.body["outliers"][0]["sequence"].get<double>());
  // The validation table is :evaluate's, in um.
  for (const char* side : {"nominal", "calibrated"}) {
    for (const char* stat : {"mean", "std", "max", "rp"}) {
      const double expected = 1000.0 * evaluation.body[side]["e_tot_mm"][stat].get<double>();
      EXPECT_NEAR(ValueAfter(page, "id=\"validation-table\"", std::string(side) + ".e_tot_um." + stat), expected,
                  1e-9 * expected)
          << side << " " << stat;
    }
  }
  EXPECT_NE(page.find("data-curve=\"after\" data-count=\"15\""), std::string::npos);
  EXPECT_NE(page.find("The plan was made without a cell"), std::string::npos);

  // Bad inputs name their field.
  const Reply bad_h = s.Get("/v1/campaigns/rep/report?h_mm=abc");
  EXPECT_EQ(bad_h.status, 400);
  EXPECT_EQ(bad_h.body["error"]["details"][0]["field"], "h_mm") << bad_h.text;
  const Reply negative_h = s.Get("/v1/campaigns/rep/report?h_mm=-1");
  EXPECT_EQ(negative_h.status, 400);
  EXPECT_EQ(negative_h.body["error"]["details"][0]["field"], "h_mm") << negative_h.text;
  EXPECT_EQ(s.Get("/v1/campaigns/nosuch/report").status, 404);
  const Reply bad_id = s.Get("/v1/campaigns/Bad%20Id/report");
  EXPECT_EQ(bad_id.status, 400);
}

TEST(ReportEndpointTest, ACampaignWithoutPlanOrValidationSaysSo) {
  TestServer s({}, {}, {}, OpenSqliteStorage(":memory:"));
  const RobotModel model = Preset("grinder5");
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", "bare"}, {"robot", "grinder5"}}).status, 200);
  VirtualCellOptions o;
  o.seed = 2;
  VirtualCell cell(model, o);
  Rng rng(3);
  ASSERT_EQ(s.Post("/v1/campaigns/bare/measurements",
                   Batch(model, cell.MeasureAll(RandomConfigurations(model, 15, &rng), 1), "cal", "calibration"))
                .status,
            200);
  ASSERT_EQ(s.Post("/v1/campaigns/bare:fit", json::object()).status, 200);
  const Reply page = s.Get("/v1/campaigns/bare/report");
  ASSERT_EQ(page.status, 200) << page.text;
  EXPECT_NE(page.text.find("The campaign was not made from a plan"), std::string::npos);
  EXPECT_NE(page.text.find("No validation measurements"), std::string::npos);
  EXPECT_EQ(Count(page.text, "<g class=\"pose"), 2u * 15u);
}

// A campaign without a plan, `configurations` poses x 3 shots of calibration measurements and 10 validation
// poses, fitted.
void CalibratedCampaign(TestServer& s, const std::string& id, int configurations, json* fit) {
  const RobotModel model = Preset("grinder5");
  ASSERT_EQ(s.Post("/v1/campaigns", {{"id", id}, {"robot", "grinder5"}}).status, 200);
  VirtualCellOptions o;
  o.seed = 4;
  o.shots_per_pose = 3;
  VirtualCell cell(model, o);
  Rng rng(6);
  ASSERT_EQ(
      s.Post("/v1/campaigns/" + id + "/measurements",
             Batch(model, cell.MeasureAll(RandomConfigurations(model, configurations, &rng)), "cal", "calibration"))
          .status,
      200);
  ASSERT_EQ(s.Post("/v1/campaigns/" + id + "/measurements",
                   Batch(model, cell.MeasureAll(RandomConfigurations(model, 10, &rng), 1), "val", "validation"))
                .status,
            200);
  const Reply reply = s.Post("/v1/campaigns/" + id + ":fit", json::object());
  ASSERT_EQ(reply.status, 200) << reply.text;
  *fit = reply.body;
}

double FitConditionNumber(const std::string& page) {
  const std::string marker = "id=\"fit-condition-number\" data-value=\"";
  const std::size_t at = page.find(marker);
  return at == std::string::npos ? std::nan("") : std::stod(page.substr(at + marker.size()));
}

TEST(ReportEndpointTest, MeasurementsUploadedAfterTheFitAreNotInIt) {
  TestServer s({}, {}, {}, OpenSqliteStorage(":memory:"));
  json fit;
  CalibratedCampaign(s, "late", 20, &fit);
  ASSERT_EQ(fit["summary"]["num_measurements"], 60);
  ASSERT_TRUE(fit["outliers"].empty()) << fit.dump();
  const RobotModel model = Preset("grinder5");
  const auto check = [&](const std::string& when) {
    const Reply page = s.Get("/v1/campaigns/late/report");
    ASSERT_EQ(page.status, 200) << page.text;
    // The fit's sections are over the 60 measurements it used, as the fit itself computed them.
    EXPECT_NEAR(FitConditionNumber(page.text) / fit["condition_number"].get<double>(), 1.0, 1e-8) << when;
    EXPECT_EQ(Count(page.text, "<g class=\"pose"), 2u * 20u) << when;  // position and orientation charts
    EXPECT_EQ(ValueAfter(page.text, "id=\"campaign-summary\"", "counts.calibration"), 90.0) << when;
    EXPECT_EQ(ValueAfter(page.text, "id=\"campaign-summary\"", "counts.after_fit"), 30.0) << when;
    EXPECT_NE(page.text.find("30 calibration measurements uploaded after this fit are not in it; fit again."),
              std::string::npos)
        << when;
  };

  // Before anything is added the page says nothing about later measurements.
  const Reply before = s.Get("/v1/campaigns/late/report");
  ASSERT_EQ(before.status, 200);
  EXPECT_EQ(before.text.find("uploaded after this fit"), std::string::npos);
  EXPECT_EQ(ValueAfter(before.text, "id=\"campaign-summary\"", "counts.after_fit"), 0.0);

  // 30 more calibration measurements, 5 mm off: the campaign stays calibrated by the fit of the first 60.
  VirtualCellOptions o;
  o.seed = 9;
  o.shots_per_pose = 3;
  VirtualCell cell(model, o);
  Rng rng(8);
  std::vector<Measurement> late = cell.MeasureAll(RandomConfigurations(model, 10, &rng));
  for (Measurement& m : late) m.T_world_tool.translation() += Eigen::Vector3d(5.0, 0.0, 0.0);
  ASSERT_EQ(s.Post("/v1/campaigns/late/measurements", Batch(model, late, "late", "calibration")).status, 200);
  check("with the fit's last sequence stored");

  // A fit stored before the last sequence was recorded: the first (used + excluded) measurements are its own,
  // the storage being append-only in sequence order.
  std::optional<Document> doc = s.storage().Get("calibrations", "late");
  ASSERT_TRUE(doc);
  json stored = json::parse(doc->json);
  ASSERT_TRUE(stored["state"].contains("last_calibration_sequence")) << stored["state"].dump();
  stored["state"].erase("last_calibration_sequence");
  s.storage().Put("calibrations", "late", stored.dump());
  check("an older stored fit");

  // Fitted again, the page is about all 90 once more.
  ASSERT_EQ(s.Post("/v1/campaigns/late:fit", json::object()).status, 200);
  const Reply again = s.Get("/v1/campaigns/late/report");
  EXPECT_EQ(again.text.find("uploaded after this fit"), std::string::npos);
  EXPECT_EQ(Count(again.text, "<g class=\"pose"), 2u * 30u);
}

TEST(ReportEndpointTest, QueryIsStrict) {
  TestServer s({}, {}, {}, OpenSqliteStorage(":memory:"));
  json fit;
  CalibratedCampaign(s, "q", 12, &fit);
  // Decimal numbers, as the client writes them (%.17g).
  EXPECT_NE(s.Get("/v1/campaigns/q/report").text.find("id=\"h-mm\" data-value=\"30\""), std::string::npos);
  for (const auto& [query, h] :
       std::vector<std::pair<std::string, std::string>>{{"h_mm=50", "50"},
                                                        {"h_mm=12.5", "12.5"},
                                                        {"h_mm=1e3", "1000"},
                                                        {"h_mm=1.0000000000000001e-05", "1.0000000000000001e-05"}}) {
    const Reply r = s.Get("/v1/campaigns/q/report?" + query);
    EXPECT_EQ(r.status, 200) << query;
    EXPECT_NE(r.text.find("id=\"h-mm\" data-value=\"" + h + "\""), std::string::npos) << query;
  }
  // Anything else is 400 naming the parameter; raw bytes, so that no client library tidies the query first.
  const auto refused = [&](const std::string& query, const std::string& field, const std::string& message) {
    const RawReply r = RawConnection::Exchange(
        s.port(), "GET /v1/campaigns/q/report?" + query + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
    EXPECT_EQ(r.status, 400) << query << ": " << r.body.substr(0, 300);
    ASSERT_TRUE(r.json.is_object()) << query << ": " << r.body.substr(0, 300);
    EXPECT_EQ(r.json["error"]["details"][0]["field"], field) << query << ": " << r.body;
    EXPECT_NE(r.json["error"]["message"].get<std::string>().find(message), std::string::npos)
        << query << ": " << r.body;
  };
  for (const char* query :
       {"h_mm=0x10", "h_mm=0x1p3", "h_mm=", "h_mm", "h_mm=inf", "h_mm=nan", "h_mm=INF", "h_mm=%2030", "h_mm=30%20",
        "h_mm=+30", "h_mm=30.", "h_mm=.5", "h_mm=1e400", "h_mm=30mm", "h_mm=3,5"}) {
    refused(query, "h_mm", "invalid report request: h_mm");
  }
  refused("h_mm=-1", "h_mm", "invalid report request: h_mm");
  refused("h_mm=1e7", "h_mm", "invalid report request: h_mm");
  refused("h_mm=30&h_mm=40", "h_mm", "given 2 times");
  refused("h_mm=30&h_mm=30", "h_mm", "given 2 times");
  refused("hmm=30", "hmm", "unknown query parameter");
  refused("h_mm=30&format=json", "format", "unknown query parameter");
  refused("=30", "query", "unknown query parameter");
}

}  // namespace
}  // namespace robocal::server::testing
