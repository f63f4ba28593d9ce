// The campaign report's HTML: an escaper, a small SVG writer, number cells that carry their exact value
// (data-value) beside the rounded text, and one function per section. report_html.h says why by hand.
#include "report_html.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <limits>
#include <sstream>

#include "robocal/api/text.h"

namespace robocal::server::report {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kUmPerMm = 1000.0;
constexpr double kArcsecPerDeg = 3600.0;

// ---- numbers --------------------------------------------------------------------------------------------

// `value` with `digits` decimals; "n/a" when it is not finite.
std::string Fixed(double value, int digits) {
  if (!std::isfinite(value)) return "n/a";
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", digits, value);
  // "-0.000" says nothing a reader should see.
  if (std::string(buffer).find_first_of("123456789") == std::string::npos && buffer[0] == '-') {
    return std::string(buffer + 1);
  }
  return buffer;
}

// `value` to `significant` digits (%g).
std::string Sig(double value, int significant) {
  if (!std::isfinite(value)) return "n/a";
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*g", significant, value);
  return buffer;
}

// The exact value for data-value attributes: round-trips to the same double; "nan" for none.
std::string Exact(double value) {
  if (!std::isfinite(value)) return "nan";
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.17g", value);
  return buffer;
}

// SVG coordinates: a tenth of a pixel is finer than any screen or printer resolves.
std::string Px(double value) { return Fixed(value, 1); }

std::string Attr(std::string_view name, std::string_view value) {
  std::string out(" ");
  out.append(name).append("=\"").append(EscapeHtml(value)).append("\"");
  return out;
}

// A table cell holding a number: rounded text, the exact value in data-value, `key` in data-key.
std::string NumCell(double value, int digits, const std::string& key = "") {
  return "<td class=\"num\"" + (key.empty() ? std::string() : Attr("data-key", key)) +
         Attr("data-value", Exact(value)) + ">" + Fixed(value, digits) + "</td>";
}
std::string IntCell(std::int64_t value, const std::string& key = "") {
  return "<td class=\"num\"" + (key.empty() ? std::string() : Attr("data-key", key)) +
         Attr("data-value", std::to_string(value)) + ">" + std::to_string(value) + "</td>";
}
std::string TextCell(std::string_view text) { return "<td>" + EscapeHtml(text) + "</td>"; }
std::string Th(std::string_view text) { return "<th>" + EscapeHtml(text) + "</th>"; }

// A statement that a section or part has no data.
std::string None(std::string_view text) { return "<p class=\"none\">" + EscapeHtml(text) + "</p>\n"; }

std::string UtcTime(std::int64_t unix_ms) {
  const std::time_t seconds = static_cast<std::time_t>(unix_ms / 1000);
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  char buffer[32];
  std::strftime(buffer, sizeof(buffer), "%Y-%m-%d %H:%M:%S UTC", &tm);
  return buffer;
}

// Decimals for a value in mm or deg in the parameter table: 0.1 um, 0.00001 deg (0.036 arcsec).
// mm and deg to a tenth of a micrometre and 1e-5 deg; a compliance (deg/(N*m), some 1e-4) to three digits more.
int DigitsOfUnit(const std::string& unit) { return unit == "mm" ? 4 : unit == "deg" ? 5 : 8; }

// ---- SVG ------------------------------------------------------------------------------------------------

// Ticks of a linear axis over [lo, hi]: steps of 1, 2 or 5 times a power of ten, about `count` of them.
std::vector<double> LinearTicks(double lo, double hi, int count) {
  std::vector<double> ticks;
  if (!(hi > lo)) return ticks;
  const double raw = (hi - lo) / count;
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  double step = power;
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    step = m * power;
    if (step >= raw) break;
  }
  for (double t = std::ceil(lo / step) * step; t <= hi + 1e-9 * step; t += step)
    ticks.push_back(std::abs(t) < 1e-9 * step ? 0.0 : t);
  return ticks;
}

// The decades [10^lo, 10^hi] that hold the positive values of `values` (at least one decade; 1e-3..1 when none
// is positive).
std::pair<int, int> Decades(const std::vector<double>& values) {
  double smallest = std::numeric_limits<double>::infinity(), largest = 0.0;
  for (double v : values) {
    if (v > 0.0 && std::isfinite(v)) {
      smallest = std::min(smallest, v);
      largest = std::max(largest, v);
    }
  }
  if (!(largest > 0.0)) return {-3, 0};
  int lo = static_cast<int>(std::floor(std::log10(smallest)));
  int hi = static_cast<int>(std::ceil(std::log10(largest)));
  if (hi <= lo) hi = lo + 1;
  return {lo, hi};
}

std::string DecadeLabel(int exponent) {
  if (exponent >= 0 && exponent <= 4) return Fixed(std::pow(10.0, exponent), 0);
  if (exponent < 0 && exponent >= -4) return Fixed(std::pow(10.0, exponent), -exponent);
  return "1e" + std::to_string(exponent);
}

// One SVG element built up by drawing calls; the page inlines it. Colours are attributes (not page CSS), so the
// drawing prints the same wherever it is pasted.
class Svg {
 public:
  Svg(double width, double height, const std::string& id, const std::string& label) {
    out_ << "<svg xmlns=\"http://www.w3.org/2000/svg\"" << Attr("id", id) << " width=\"" << Px(width) << "\" height=\""
         << Px(height) << "\" viewBox=\"0 0 " << Px(width) << " " << Px(height) << "\" role=\"img\""
         << Attr("aria-label", label) << " font-family=\"DejaVu Sans, Arial, sans-serif\" font-size=\"11\">\n"
         << "<title>" << EscapeHtml(label) << "</title>\n";
  }
  void Line(double x1, double y1, double x2, double y2, const char* stroke, double width = 1.0,
            const char* dash = nullptr) {
    out_ << "<line x1=\"" << Px(x1) << "\" y1=\"" << Px(y1) << "\" x2=\"" << Px(x2) << "\" y2=\"" << Px(y2)
         << "\" stroke=\"" << stroke << "\" stroke-width=\"" << Fixed(width, 1) << "\""
         << (dash ? std::string(" stroke-dasharray=\"") + dash + "\"" : "") << "/>\n";
  }
  void Rect(double x, double y, double w, double h, const char* fill, const char* stroke = "none",
            const std::string& extra = "") {
    out_ << "<rect x=\"" << Px(x) << "\" y=\"" << Px(y) << "\" width=\"" << Px(std::max(0.0, w)) << "\" height=\""
         << Px(std::max(0.0, h)) << "\" fill=\"" << fill << "\" stroke=\"" << stroke << "\"" << extra << "/>\n";
  }
  void Circle(double x, double y, double r, const char* fill, const std::string& extra = "") {
    out_ << "<circle cx=\"" << Px(x) << "\" cy=\"" << Px(y) << "\" r=\"" << Px(r) << "\" fill=\"" << fill << "\""
         << extra << "/>\n";
  }
  void Polyline(const std::vector<std::pair<double, double>>& points, const char* stroke, double width,
                const char* dash = nullptr, const std::string& extra = "") {
    out_ << "<polyline fill=\"none\" stroke=\"" << stroke << "\" stroke-width=\"" << Fixed(width, 1) << "\""
         << (dash ? std::string(" stroke-dasharray=\"") + dash + "\"" : "") << extra << " points=\"";
    for (std::size_t i = 0; i < points.size(); ++i) {
      out_ << (i ? " " : "") << Px(points[i].first) << "," << Px(points[i].second);
    }
    out_ << "\"/>\n";
  }
  void Polygon(const std::vector<std::pair<double, double>>& points, const char* fill, const std::string& extra = "") {
    out_ << "<polygon fill=\"" << fill << "\"" << extra << " points=\"";
    for (std::size_t i = 0; i < points.size(); ++i) {
      out_ << (i ? " " : "") << Px(points[i].first) << "," << Px(points[i].second);
    }
    out_ << "\"/>\n";
  }
  void Text(double x, double y, std::string_view text, const char* anchor = "start", const char* fill = "#000",
            double rotate = 0.0) {
    out_ << "<text x=\"" << Px(x) << "\" y=\"" << Px(y) << "\" text-anchor=\"" << anchor << "\" fill=\"" << fill
         << "\"";
    if (rotate != 0.0) out_ << " transform=\"rotate(" << Px(rotate) << " " << Px(x) << " " << Px(y) << ")\"";
    out_ << ">" << EscapeHtml(text) << "</text>\n";
  }
  void Raw(const std::string& markup) { out_ << markup; }
  std::string Finish() {
    out_ << "</svg>\n";
    return out_.str();
  }

 private:
  std::ostringstream out_;
};

// Distinct dark colours for the stick figures (readable printed in grey too: all dark, different hues).
constexpr const char* kPalette[] = {"#1f3a93", "#b03a2e", "#1e8449", "#7d3c98", "#b9770e",
                                    "#117a65", "#922b21", "#2e4053", "#6e2c00", "#4a235a"};

// ---- sections -------------------------------------------------------------------------------------------

void Header(const ReportData& d, std::ostringstream& out) {
  out << "<header>\n<h1>Calibration report: campaign <span id=\"campaign-id\">" << EscapeHtml(d.campaign)
      << "</span></h1>\n<table id=\"campaign-summary\">\n";
  out << "<tr><th>description</th>" << TextCell(d.description.empty() ? "(none)" : d.description) << "</tr>\n";
  out << "<tr><th>robot</th>" << TextCell(d.robot.id) << "</tr>\n";
  out << "<tr><th>measurement type</th>" << TextCell(ToString(d.measurement_type)) << "</tr>\n";
  out << "<tr><th>calibration measurements</th>" << IntCell(d.counts.calibration, "counts.calibration") << "</tr>\n";
  out << "<tr><th>... uploaded after the fit</th>" << IntCell(d.calibration_after_fit, "counts.after_fit") << "</tr>\n";
  out << "<tr><th>validation measurements</th>" << IntCell(d.counts.validation, "counts.validation") << "</tr>\n";
  out << "<tr><th>test measurements (ISO 9283)</th>" << IntCell(d.counts.test, "counts.test") << "</tr>\n";
  out << "<tr><th>campaign created</th>" << TextCell(UtcTime(d.created_unix_ms)) << "</tr>\n";
  out << "<tr><th>report made</th>" << TextCell(UtcTime(d.generated_unix_ms)) << "</tr>\n";
  out << "</table>\n";
  if (d.calibration_after_fit > 0) {
    const bool one = d.calibration_after_fit == 1;
    out << "<p class=\"warning\" id=\"after-fit\">" << d.calibration_after_fit << " calibration measurement"
        << (one ? " uploaded after this fit is" : "s uploaded after this fit are")
        << " not in it; fit again. The fit and the residuals per pose below are over the "
        << d.counts.calibration - d.calibration_after_fit << " calibration measurements it saw.</p>\n";
  }
  out << "<nav><ol class=\"toc\"><li><a href=\"#robot\">Robot</a></li><li><a href=\"#plan\">Plan</a></li>"
         "<li><a href=\"#fit\">Fit</a></li><li><a href=\"#residuals\">Residuals per pose</a></li>"
         "<li><a href=\"#validation\">Validation</a></li><li><a href=\"#iso9283\">ISO 9283 pose test</a></li></ol>"
         "</nav>\n</header>\n";
}

void RobotSection(const ReportData& d, std::ostringstream& out) {
  const api::Robot& r = d.robot;
  out << "<section id=\"robot\">\n<h2>1. Robot</h2>\n<table id=\"robot-summary\">\n";
  out << "<tr><th>name</th>" << TextCell(r.id) << "</tr>\n";
  out << "<tr><th>description</th>" << TextCell(r.description.empty() ? "(none)" : r.description) << "</tr>\n";
  out << "<tr><th>preset</th>" << TextCell(r.preset ? "yes" : "no") << "</tr>\n";
  out << "<tr><th>convention</th>" << TextCell(api::WireName(r.convention)) << "</tr>\n";
  out << "<tr><th>joints</th>" << IntCell(r.num_joints, "robot.num_joints") << "</tr>\n";
  if (r.urdf) {
    out << "<tr><th>URDF chain</th>" << TextCell(r.urdf->base_link + " -> " + r.urdf->tip_link) << "</tr>\n";
  }
  out << "</table>\n";
  const bool transform = r.convention == GeometryConvention::kTransform;
  out << "<table id=\"robot-joints\">\n<thead><tr><th>#</th><th>joint</th><th>type</th>";
  if (transform) {
    out << "<th>x (mm)</th><th>y (mm)</th><th>z (mm)</th><th>roll (deg)</th><th>pitch (deg)</th><th>yaw (deg)</th>";
  } else {
    out << "<th>a (mm)</th><th>alpha (deg)</th><th>d (mm)</th><th>theta (deg)</th>";
  }
  out << "<th>min</th><th>max</th><th>unit</th></tr></thead>\n<tbody>\n";
  for (std::size_t k = 0; k < r.joints.size(); ++k) {
    const api::JointWire& j = r.joints[k];
    out << "<tr>" << IntCell(static_cast<std::int64_t>(k + 1)) << TextCell(j.name) << TextCell(api::WireName(j.type));
    if (transform) {
      for (double v : j.xyz_mm) out << NumCell(v, 3);
      for (double v : j.rpy_deg) out << NumCell(v, 4);
    } else {
      out << NumCell(j.a_mm, 3) << NumCell(j.alpha_deg, 4) << NumCell(j.d_mm, 3) << NumCell(j.theta_deg, 4);
    }
    out << NumCell(j.min, 2) << NumCell(j.max, 2) << TextCell(r.joints[k].unit) << "</tr>\n";
  }
  out << "</tbody></table>\n</section>\n";
}

// One orthographic view of the stick figures: horizontal axis `h`, vertical axis `v` (0 x, 1 y, 2 z), at a
// scale shared with the other view (mm per pixel), centred on the given midpoints.
std::string StickView(const CellFigure& f, int h, int v, double mm_per_px, double mid_h, double mid_v,
                      const std::string& id, const std::string& title) {
  const double size = 420.0, margin = 44.0, plot = size - 2 * margin;
  const char* names = "xyz";
  Svg svg(size, size + 10, id, title);
  const auto X = [&](double mm) { return margin + plot / 2 + (mm - mid_h) / mm_per_px; };
  const auto Y = [&](double mm) { return margin + plot / 2 - (mm - mid_v) / mm_per_px; };
  svg.Rect(margin, margin, plot, plot, "#fff", "#000");
  const double half = plot / 2 * mm_per_px;
  for (double t : LinearTicks(mid_h - half, mid_h + half, 6)) {
    svg.Line(X(t), margin, X(t), margin + plot, "#ddd");
    svg.Text(X(t), margin + plot + 14, Fixed(t, 0), "middle");
  }
  for (double t : LinearTicks(mid_v - half, mid_v + half, 6)) {
    svg.Line(margin, Y(t), margin + plot, Y(t), "#ddd");
    svg.Text(margin - 4, Y(t) + 4, Fixed(t, 0), "end");
  }
  svg.Text(margin + plot / 2, size + 4, std::string(1, names[h]) + " (mm, tracker frame)", "middle");
  svg.Text(12, margin + plot / 2, std::string(1, names[v]) + " (mm)", "middle", "#000", -90.0);
  svg.Text(margin, margin - 8, title, "start");
  for (const CellFigure::Box& b : f.obstacles) {
    const auto clip_x = [&](double x) { return std::clamp(x, margin, margin + plot); };
    const auto clip_y = [&](double y) { return std::clamp(y, margin, margin + plot); };
    const double x0 = clip_x(X(b.min_mm[h])), x1 = clip_x(X(b.max_mm[h]));
    const double y0 = clip_y(Y(b.max_mm[v])), y1 = clip_y(Y(b.min_mm[v]));
    if (x1 - x0 < 0.5 || y1 - y0 < 0.5) continue;  // outside this view's frame
    svg.Rect(x0, y0, x1 - x0, y1 - y0, "#f2f2f2", "#666", " stroke-dasharray=\"4 2\" class=\"obstacle\"");
    svg.Text(x0 + 3, y0 + 12, b.id, "start", "#444");
  }
  for (std::size_t c = 0; c < f.chains.size(); ++c) {
    const char* colour = kPalette[c % (sizeof(kPalette) / sizeof(kPalette[0]))];
    std::vector<std::pair<double, double>> points;
    for (const auto& p : f.chains[c]) points.emplace_back(X(p[h]), Y(p[v]));
    svg.Polyline(points, colour, 1.6, nullptr, " class=\"configuration\" data-index=\"" + std::to_string(c + 1) + "\"");
    for (const auto& [x, y] : points) svg.Circle(x, y, 1.8, colour);
    if (!points.empty())
      svg.Text(points.back().first + 3, points.back().second - 3, std::to_string(c + 1), "start", colour);
  }
  // The base (first point of every chain) and the tracker at the origin.
  if (!f.chains.empty() && !f.chains[0].empty()) {
    const auto& b = f.chains[0][0];
    svg.Rect(X(b[h]) - 5, Y(b[v]) - 5, 10, 10, "#000", "none", " class=\"base\"");
    svg.Text(X(b[h]) + 7, Y(b[v]) + 14, "base", "start");
  }
  svg.Polygon({{X(0) - 7, Y(0) + 6}, {X(0) + 7, Y(0) + 6}, {X(0), Y(0) - 8}}, "#000", " class=\"tracker\"");
  svg.Text(X(0) + 9, Y(0) + 4, "tracker", "start");
  return svg.Finish();
}

std::string StickFigures(const CellFigure& f) {
  // One scale for both views, so that lengths compare between them; the tracker (origin) is always inside.
  std::array<double, 3> lo{0.0, 0.0, 0.0}, hi{0.0, 0.0, 0.0};
  const auto extend = [&](const std::array<double, 3>& p) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
  };
  for (const auto& chain : f.chains)
    for (const auto& p : chain) extend(p);
  // Obstacles do not set the scale (a floor slab would shrink the robot to a dot); they are cut at the frame.
  double span = 1.0;
  for (int a = 0; a < 3; ++a) span = std::max(span, hi[a] - lo[a]);
  const double plot = 420.0 - 2 * 44.0;
  const double mm_per_px = 1.08 * span / plot;
  const auto mid = [&](int a) { return 0.5 * (lo[a] + hi[a]); };
  std::ostringstream out;
  out << "<figure id=\"cell-figure\" class=\"views\">\n"
      << StickView(f, 0, 1, mm_per_px, mid(0), mid(1), "view-top", "top view (x-y)")
      << StickView(f, 0, 2, mm_per_px, mid(0), mid(2), "view-side", "side view (x-z)") << "<figcaption>The "
      << f.chains.size() << " planned configurations in cell <b>" << EscapeHtml(f.cell)
      << "</b> as stick figures: the base, each joint frame's origin, the flange and the tool point (nominal "
         "forward kinematics), numbered as in the table above; tracker frame with the tracker at the origin (at ("
      << Fixed(f.tracker_in_base_mm[0], 0) << ", " << Fixed(f.tracker_in_base_mm[1], 0) << ", "
      << Fixed(f.tracker_in_base_mm[2], 0)
      << ") mm in the robot's base frame; axes parallel to the base's); dashed boxes are the cell's obstacles, cut "
         "at the frame. Both views share one scale.</figcaption>\n</figure>\n";
  return out.str();
}

void IndicesRow(std::ostringstream& out, const char* label, const char* key, double planned, double random,
                int digits) {
  out << "<tr><th>" << label << "</th>" << NumCell(planned, digits, std::string("plan.") + key)
      << NumCell(random, digits, std::string("baseline.") + key) << "</tr>\n";
}

void PlanSectionHtml(const ReportData& d, std::ostringstream& out) {
  out << "<section id=\"plan\">\n<h2>2. Plan</h2>\n";
  if (!d.plan) {
    out << None(d.plan_missing) << "</section>\n";
    return;
  }
  const api::PlanResult& p = d.plan->plan;
  out << "<table id=\"plan-summary\">\n<tr><th>plan</th>" << TextCell(p.id) << "</tr>\n<tr><th>optimiser</th>"
      << TextCell(api::WireName(p.optimiser)) << "</tr>\n<tr><th>objective</th>" << TextCell(api::WireName(p.objective))
      << "</tr>\n<tr><th>measurement type</th>" << TextCell(ToString(p.measurement_type)) << "</tr>\n<tr><th>cell</th>"
      << TextCell(p.cell ? *p.cell : "(none)") << "</tr>\n<tr><th>termination</th>"
      << TextCell(api::WireName(p.summary.termination)) << "</tr>\n<tr><th>made</th>"
      << TextCell(UtcTime(p.created_unix_ms)) << "</tr>\n</table>\n";

  out << "<h3>Observability indices and predicted accuracy</h3>\n<table id=\"plan-indices\">\n"
         "<thead><tr><th>index</th><th>planned set</th><th>random set of the same size</th></tr></thead>\n<tbody>\n";
  const api::Indices& a = p.indices;
  const api::Indices& b = p.baseline.indices;
  IndicesRow(out, "condition number", "condition_number", a.condition_number, b.condition_number, 2);
  IndicesRow(out, "O1", "o1", a.o1, b.o1, 4);
  IndicesRow(out, "O2", "o2", a.o2, b.o2, 6);
  IndicesRow(out, "O3", "o3", a.o3, b.o3, 4);
  IndicesRow(out, "O4", "o4", a.o4, b.o4, 6);
  IndicesRow(out, "O5", "o5", a.o5, b.o5, 4);
  IndicesRow(out, "log det", "log_det", a.log_det, b.log_det, 3);
  const api::PredictedAccuracyWire& pa = p.predicted_accuracy;
  const api::PredictedAccuracyWire& pb = p.baseline.predicted_accuracy;
  IndicesRow(out, "predicted RMS position error (mm)", "predicted.rms_position_mm", pa.rms_position_mm,
             pb.rms_position_mm, 4);
  IndicesRow(out, "predicted max position error (mm)", "predicted.max_position_mm", pa.max_position_mm,
             pb.max_position_mm, 4);
  IndicesRow(out, "predicted RMS orientation error (deg)", "predicted.rms_orientation_deg", pa.rms_orientation_deg,
             pb.rms_orientation_deg, 5);
  IndicesRow(out, "predicted error index (mm)", "predicted.rms_error_mm", pa.rms_error_mm, pb.rms_error_mm, 4);
  out << "</tbody></table>\n<p class=\"note\">Predicted on " << pa.num_validation
      << " random validation configurations from the covariance the plan's measurements would give; columns "
         "scaled: "
      << EscapeHtml(a.scaling) << ".</p>\n";
  if (p.candidates) {
    std::string rejected;
    for (const api::CandidateRejectionWire& r : p.candidates->rejected) {
      rejected += (rejected.empty() ? "; rejected: " : ", ") + std::to_string(r.count) + " " + r.reason;
    }
    out << "<p id=\"plan-candidates\">Chosen from the cell's " << p.candidates->num_candidates << " candidate poses ("
        << p.candidates->num_usable << " usable" << EscapeHtml(rejected) << ").</p>\n";
    if (p.coverage && !p.coverage->warning.empty()) {
      out << "<p class=\"warning\" id=\"plan-coverage\">" << EscapeHtml(p.coverage->warning) << "</p>\n";
    }
  }
  if (p.pose_count) {
    // The curve a user reads to decide how many poses to measure.
    const api::PoseCountWire& c = *p.pose_count;
    out << "<h3>How many poses: predicted error against N</h3>\n<table id=\"pose-count\">\n<thead><tr><th>N</th>"
           "<th>predicted RMS error (mm)</th><th>predicted mean position error (mm)</th><th></th></tr></thead>\n"
           "<tbody>\n";
    for (const api::PoseCountPointWire& point : c.points) {
      const bool chosen = c.chosen && *c.chosen == point.num_configurations;
      out << "<tr>" << IntCell(point.num_configurations) << NumCell(point.predicted_error_mm, 4)
          << NumCell(point.predicted_mean_mm, 4) << TextCell(chosen ? "chosen" : "") << "</tr>\n";
    }
    out << "</tbody></table>\n<p class=\"note\">Goal " << Fixed(c.accuracy_goal_mm, 4)
        << " mm (mean position error); the robot's model error " << Fixed(c.model_error_mm, 4)
        << " mm RMS is included. " << EscapeHtml(c.message) << "</p>\n";
  }

  out << "<h3>Configurations</h3>\n<table id=\"plan-configurations\">\n<thead><tr><th>#</th>";
  for (std::size_t k = 0; k < p.joint_units.size(); ++k) {
    std::string header = k < d.robot.joints.size() ? d.robot.joints[k].name : "q" + std::to_string(k + 1);
    header.append(" (").append(p.joint_units[k]).append(")");
    out << Th(header);
  }
  const bool checks = p.configuration_checks.size() == p.configurations.size() && !p.configurations.empty();
  if (checks) out << "<th>feasible</th><th>min clearance (mm)</th>";
  out << "</tr></thead>\n<tbody>\n";
  for (std::size_t i = 0; i < p.configurations.size(); ++i) {
    out << "<tr>" << IntCell(static_cast<std::int64_t>(i + 1));
    for (std::size_t k = 0; k < p.configurations[i].size(); ++k) {
      out << NumCell(p.configurations[i][k], 3, "plan.configurations." + std::to_string(i) + "." + std::to_string(k));
    }
    if (checks) {
      out << TextCell(p.configuration_checks[i].feasible ? "yes" : "no")
          << NumCell(p.configuration_checks[i].min_clearance_mm, 1);
    }
    out << "</tr>\n";
  }
  out << "</tbody></table>\n";
  if (d.plan->figure) {
    out << StickFigures(*d.plan->figure);
  } else {
    out << None(d.plan->no_figure_reason);
  }
  out << "</section>\n";
}

void ResidualRow(std::ostringstream& out, const char* label, const char* key, const api::Residuals& r) {
  const std::string k = key;
  out << "<tr><th>" << label << "</th>" << IntCell(r.num_measurements, k + ".num_measurements")
      << NumCell(r.rms_position_mm, 4, k + ".rms_position_mm") << NumCell(r.max_position_mm, 4, k + ".max_position_mm")
      << NumCell(r.rms_orientation_deg, 5, k + ".rms_orientation_deg")
      << NumCell(r.max_orientation_deg, 5, k + ".max_orientation_deg")
      << NumCell(r.rms_weighted, 3, k + ".rms_weighted") << "</tr>\n";
}

// The fit's summary table: termination, counts, the model error beside the tracker's, the model and when.
void FitSummaryHtml(const api::CalibrationResult& c, std::ostringstream& out) {
  const api::FitSummary& s = c.summary;
  out << "<table id=\"fit-summary\">\n";
  out << "<tr><th>termination</th>" << TextCell(api::WireName(s.termination)) << "</tr>\n";
  out << "<tr><th>message</th>" << TextCell(s.message) << "</tr>\n";
  out << "<tr><th>measurements used</th>" << IntCell(s.num_measurements, "summary.num_measurements") << "</tr>\n";
  out << "<tr><th>distinct poses</th>" << IntCell(s.num_poses, "summary.num_poses") << "</tr>\n";
  out << "<tr><th>parameters estimated</th>" << IntCell(s.num_parameters, "summary.num_parameters") << "</tr>\n";
  out << "<tr><th>iterations</th>" << IntCell(s.iterations, "summary.iterations") << "</tr>\n";
  out << "<tr><th>sigma hat (unit weight)</th>" << NumCell(s.sigma_hat, 4, "summary.sigma_hat") << "</tr>\n";
  out << "<tr><th>condition number (stored fit)</th>" << NumCell(c.condition_number, 2, "condition_number")
      << "</tr>\n";
  out << "<tr><th>scaling</th>" << TextCell(c.scaling) << "</tr>\n";
  if (c.model_error.estimated) {
    // The robot error the geometric model does not explain, beside the tracker's own (RMS).
    const bool angle = c.measurement_type != MeasurementType::kPosition;
    out << "<tr><th>model error, RMS (mm)</th>"
        << NumCell(c.model_error.model_error_mm, 4, "model_error.model_error_mm")
        << "</tr>\n<tr><th>tracker, RMS (mm)</th>"
        << NumCell(c.model_error.tracker_rms_mm, 4, "model_error.tracker_rms_mm") << "</tr>\n";
    if (angle) {
      out << "<tr><th>model error, RMS (deg)</th>"
          << NumCell(c.model_error.model_error_deg, 5, "model_error.model_error_deg")
          << "</tr>\n<tr><th>tracker, RMS (deg)</th>"
          << NumCell(c.model_error.tracker_rms_deg, 5, "model_error.tracker_rms_deg") << "</tr>\n";
    }
  } else {
    out << "<tr><th>model error</th>" << TextCell("not estimated: the noise model is the whole error") << "</tr>\n";
  }
  out << "<tr><th>model</th>"
      << TextCell(api::ToCore(c.model).Describe() + (c.model_choice ? " (chosen by cross-validation, below)" : ""))
      << "</tr>\n";
  out << "<tr><th>fitted</th>" << TextCell(UtcTime(c.created_unix_ms)) << "</tr>\n</table>\n";
}

// Every candidate's held-out error over the folds: the comparison the model was chosen by.
void FitModelChoiceHtml(const api::ModelChoiceWire& choice, std::ostringstream& out) {
  out << "<h3>Model choice: " << choice.folds << "-fold cross-validation</h3>\n<table id=\"model-choice\">\n"
      << "<thead><tr><th>model</th><th>parameters</th><th>held-out E_xyz mean (mm)</th><th>standard error (mm)</th>"
         "<th>held-out RMS (mm)</th><th>chosen</th></tr></thead>\n<tbody>\n";
  for (const api::ModelCandidateWire& m : choice.candidates) {
    out << "<tr" << Attr("data-model", m.description) << ">" << TextCell(m.description)
        << IntCell(m.num_parameters, "num_parameters");
    if (m.failed_folds > 0) {
      out << "<td colspan=\"3\">" << EscapeHtml(std::to_string(m.failed_folds) + " fold(s) not eligible: " + m.note)
          << "</td>";
    } else {
      out << NumCell(m.cv_mean_mm, 4, "cv_mean_mm") << NumCell(m.cv_standard_error_mm, 4, "cv_standard_error_mm")
          << NumCell(m.cv_rms_mm, 4, "cv_rms_mm");
    }
    out << TextCell(m.chosen ? "chosen" : "") << "</tr>\n";
  }
  out << "</tbody></table>\n<p>The chosen model is the simplest whose mean is within one standard error of the "
         "best's (docs/identification.md, \"Beyond geometry\").</p>\n";
}

// A MAP fit: what the priors held, and for "auto" the scale's comparison.
void FitPriorsHtml(const api::PriorsResultWire& pr, std::ostringstream& out) {
  out << "<h3>Parameter priors</h3>\n<p id=\"priors\">Priors on " << pr.num_priors
      << " parameters; effective number of parameters " << Fixed(pr.effective_parameters, 1)
      << " (docs/identification.md, \"Parameter priors\").</p>\n";
  if (!pr.candidates.empty()) {
    out << "<table id=\"prior-choice\">\n<thead><tr><th>scale of the priors</th><th>held-out E_xyz mean (mm)</th>"
           "<th>standard error (mm)</th><th>chosen</th></tr></thead>\n<tbody>\n";
    for (const api::PriorScaleWire& s : pr.candidates) {
      out << "<tr>" << TextCell(std::isfinite(s.scale) ? "x " + Fixed(s.scale, 2) : "no priors");
      if (s.failed_folds > 0) {
        out << "<td colspan=\"2\">" << EscapeHtml(std::to_string(s.failed_folds) + " fold(s) failed: " + s.note)
            << "</td>";
      } else {
        out << NumCell(s.cv_mean_mm, 4) << NumCell(s.cv_standard_error_mm, 4);
      }
      out << TextCell(s.chosen ? "chosen" : "") << "</tr>\n";
    }
    out << "</tbody></table>\n";
  }
  if (pr.prior_determined.empty()) {
    out << None("The data, not the priors, determined every parameter.");
  } else {
    out << "<table id=\"prior-determined\">\n<thead><tr><th>determined by its prior</th><th>prior std</th>"
           "<th>unit</th><th>data's share of its information</th></tr></thead>\n<tbody>\n";
    for (const api::PriorDeterminedWire& pd : pr.prior_determined) {
      out << "<tr>" << TextCell(pd.parameter) << NumCell(pd.prior_std, 4) << TextCell(pd.unit)
          << NumCell(pd.data_share, 3) << "</tr>\n";
    }
    out << "</tbody></table>\n";
  }
}

// The residuals of the calibration measurements before and after the fit.
void FitResidualsTableHtml(const api::CalibrationResult& c, std::ostringstream& out) {
  out << "<h3>Residuals of the calibration measurements</h3>\n<table id=\"fit-residuals\">\n<thead><tr><th></th>"
         "<th>measurements</th><th>RMS position (mm)</th><th>max position (mm)</th><th>RMS orientation (deg)</th>"
         "<th>max orientation (deg)</th><th>RMS weighted (sigmas)</th></tr></thead>\n<tbody>\n";
  ResidualRow(out, "before (nominal, registered base)", "residuals_before", c.residuals_before);
  ResidualRow(out, "after calibration", "residuals_after", c.residuals_after);
  out << "</tbody></table>\n";
}

// The identified parameters, then the ones the fit did not estimate and why.
void FitParametersHtml(const api::CalibrationResult& c, std::ostringstream& out) {
  out << "<h3>Identified parameters</h3>\n";
  if (c.parameters.empty()) {
    out << None("The fit estimated no parameters.");
  } else {
    out << "<table id=\"parameters\">\n<thead><tr><th>#</th><th>parameter</th><th>unit</th><th>value (mm or deg, "
           "see unit)</th><th>std (mm or deg, see unit)</th><th>std (% of |value|)</th></tr></thead>\n<tbody>\n";
    for (std::size_t k = 0; k < c.parameters.size(); ++k) {
      const api::ParameterEstimate& p = c.parameters[k];
      const int digits = DigitsOfUnit(p.unit);
      out << "<tr" << Attr("data-parameter", p.name) << ">" << IntCell(static_cast<std::int64_t>(k + 1))
          << TextCell(p.name) << TextCell(p.unit) << NumCell(p.value, digits, "value") << NumCell(p.std, digits, "std")
          << NumCell(StdPercent(p.value, p.std), 1, "std_percent") << "</tr>\n";
    }
    out << "</tbody></table>\n";
  }

  out << "<h3>Parameters not estimated</h3>\n";
  if (c.dropped.empty()) {
    out << None("None: every error parameter of the model was estimated.");
  } else {
    out << "<table id=\"dropped\">\n<thead><tr><th>parameter</th><th>reason</th></tr></thead>\n<tbody>\n";
    for (const api::DroppedParameterWire& p : c.dropped) {
      out << "<tr" << Attr("data-parameter", p.name) << ">" << TextCell(p.name) << TextCell(p.reason) << "</tr>\n";
    }
    out << "</tbody></table>\n";
  }
}

// The covariance's most correlated pairs and the Jacobian's singular values, as the fit stored them.
void FitLinearizationHtml(const FitSection& f, std::ostringstream& out) {
  out << "<h3>Most correlated parameter pairs</h3>\n";
  if (!f.linearization_problem.empty()) {
    out << None("Not available: " + f.linearization_problem);
  } else if (f.correlations.empty()) {
    out << None("Fewer than two parameters were estimated: no pairs.");
  } else {
    out << "<p class=\"note\">Correlation coefficients rho of the estimated parameters' covariance at the "
           "solution, as the fit stored it; |rho| near 1 means the measurements hardly tell the two apart.</p>\n"
           "<table id=\"correlations\">\n<thead><tr><th>#</th><th>parameter</th><th>parameter</th><th>rho</th>"
           "</tr></thead>\n<tbody>\n";
    for (std::size_t k = 0; k < f.correlations.size(); ++k) {
      const Correlation& r = f.correlations[k];
      out << "<tr>" << IntCell(static_cast<std::int64_t>(k + 1)) << TextCell(r.a) << TextCell(r.b)
          << NumCell(r.rho, 4, "rho") << "</tr>\n";
    }
    out << "</tbody></table>\n";
  }

  out << "<h3>Singular values</h3>\n";
  if (!f.linearization_problem.empty()) {
    out << None("Not available: " + f.linearization_problem);
  } else {
    out << "<p class=\"note\">Of the weighted identification Jacobian with unit-norm columns at the solution, "
           "as the fit stored them; condition number "
        << "<span id=\"fit-condition-number\"" << Attr("data-value", Exact(f.condition_number)) << ">"
        << Fixed(f.condition_number, 2) << "</span>.</p>\n<table id=\"singular-values\">\n<thead><tr><th>#</th>"
        << "<th>singular value</th></tr></thead>\n<tbody>\n";
    for (std::size_t k = 0; k < f.singular_values.size(); ++k) {
      out << "<tr>" << IntCell(static_cast<std::int64_t>(k + 1)) << "<td class=\"num\" data-key=\"singular_value\""
          << Attr("data-value", Exact(f.singular_values[k])) << ">" << Sig(f.singular_values[k], 5) << "</td></tr>\n";
    }
    out << "</tbody></table>\n";
  }
}

// The robust fit's settings and the measurements it excluded.
void FitRobustHtml(const api::CalibrationResult& c, std::ostringstream& out) {
  out << "<h3>Robust fit</h3>\n";
  if (!c.robust.enabled) {
    out << None("The robust fit was off (reject_outliers: false): every measurement was used.");
    return;
  }
  out << "<table id=\"robust\">\n<tr><th>threshold (sigmas)</th>" << NumCell(c.robust.threshold, 3, "robust.threshold")
      << "</tr>\n<tr><th>robust scale</th>" << NumCell(c.robust.scale, 3, "robust.scale") << "</tr>\n<tr><th>fits</th>"
      << IntCell(c.robust.rounds, "robust.rounds") << "</tr>\n</table>\n";
  if (c.outliers.empty()) {
    out << None("No outliers: no measurement was excluded.");
    return;
  }
  // The largest normalised residuals first (ties: the earlier measurement), at most kMaxOutlierRows.
  std::vector<const api::OutlierWire*> listed;
  for (const api::OutlierWire& o : c.outliers) listed.push_back(&o);
  std::stable_sort(listed.begin(), listed.end(), [](const api::OutlierWire* a, const api::OutlierWire* b) {
    return a->normalized_residual > b->normalized_residual;
  });
  if (listed.size() > kMaxOutlierRows) {
    out << "<p class=\"note\" id=\"outliers-not-listed\">The " << kMaxOutlierRows << " largest of " << listed.size()
        << " excluded measurements are listed; " << listed.size() - kMaxOutlierRows
        << " more are not (GET .../calibration has them all).</p>\n";
    listed.resize(kMaxOutlierRows);
  }
  out << "<table id=\"outliers\">\n<thead><tr><th>sequence</th><th>reflector</th><th>normalised residual "
         "(sigmas)</th><th>cause</th></tr></thead>\n<tbody>\n";
  for (const api::OutlierWire* o : listed) {
    out << "<tr>" << IntCell(o->sequence, "sequence") << TextCell(o->reflector.empty() ? "-" : o->reflector)
        << NumCell(o->normalized_residual, 2, "normalized_residual")
        << TextCell(o->cause == OutlierMeasurement::Cause::kStale ? "stale tracker reading (repeats the shot before it)"
                                                                  : "residual beyond the threshold")
        << "</tr>\n";
  }
  out << "</tbody></table>\n";
}

void FitSectionHtml(const ReportData& d, std::ostringstream& out) {
  const FitSection& f = d.fit;
  const api::CalibrationResult& c = f.calibration;
  out << "<section id=\"fit\">\n<h2>3. Fit</h2>\n";
  FitSummaryHtml(c, out);
  if (c.model_choice) FitModelChoiceHtml(*c.model_choice, out);
  if (c.priors) FitPriorsHtml(*c.priors, out);
  FitResidualsTableHtml(c, out);
  FitParametersHtml(c, out);
  FitLinearizationHtml(f, out);
  FitRobustHtml(c, out);
  out << "</section>\n";
}

// Paired bars per configuration on a logarithmic axis: before (grey) and after (black), outliers marked.
std::string ResidualBars(const std::vector<PoseResidual>& poses, bool orientation, const std::string& id) {
  const std::size_t n = std::min(poses.size(), kMaxResidualBars);
  const auto before = [&](const PoseResidual& p) {
    return orientation ? p.before_orientation_deg : p.before_position_mm;
  };
  const auto after = [&](const PoseResidual& p) { return orientation ? p.after_orientation_deg : p.after_position_mm; };
  std::vector<double> values;
  for (std::size_t i = 0; i < n; ++i) {
    values.push_back(before(poses[i]));
    values.push_back(after(poses[i]));
  }
  // Plain variables, not a structured binding: the lambdas below use them (C++17 cannot capture bindings).
  const std::pair<int, int> decades = Decades(values);
  const int lo = decades.first, hi = decades.second;
  const double width = 900.0, height = 300.0, left = 64.0, right = 12.0, top = 28.0, bottom = 44.0;
  const double plot_w = width - left - right, plot_h = height - top - bottom;
  const std::string unit = orientation ? "deg" : "mm";
  Svg svg(width, height, id,
          std::string(orientation ? "orientation" : "position") + " residual per configuration before and after");
  const auto Y = [&](double value) {
    if (!(value > 0.0)) return top + plot_h;
    const double t = (std::log10(value) - lo) / (hi - lo);
    return top + plot_h * (1.0 - std::clamp(t, 0.0, 1.0));
  };
  svg.Rect(left, top, plot_w, plot_h, "#fff", "#000");
  for (int e = lo; e <= hi; ++e) {
    svg.Line(left, Y(std::pow(10.0, e)), left + plot_w, Y(std::pow(10.0, e)), "#ccc");
    svg.Text(left - 4, Y(std::pow(10.0, e)) + 4, DecadeLabel(e), "end");
  }
  svg.Text(14, top + plot_h / 2, "RMS per configuration (" + unit + ", log)", "middle", "#000", -90.0);
  const double slot = plot_w / std::max<std::size_t>(n, 1);
  const double bar = std::max(0.6, slot * 0.38);
  const std::size_t label_every = std::max<std::size_t>(1, n / 25 + (n % 25 ? 1 : 0));
  for (std::size_t i = 0; i < n; ++i) {
    const PoseResidual& p = poses[i];
    const double x = left + slot * static_cast<double>(i) + slot * 0.1;
    svg.Raw("<g class=\"pose" + std::string(p.outliers > 0 ? " has-outlier" : "") + "\"" +
            Attr("data-first-sequence", std::to_string(p.first_sequence)) +
            Attr("data-shots", std::to_string(p.shots)) + Attr("data-outliers", std::to_string(p.outliers)) +
            Attr("data-before", Exact(before(p))) + Attr("data-after", Exact(after(p))) + ">\n<title>configuration " +
            std::to_string(i + 1) + " (sequence " + std::to_string(p.first_sequence) + "-" +
            std::to_string(p.last_sequence) + ", " + std::to_string(p.shots) + " shots): before " + Sig(before(p), 4) +
            " " + unit + ", after " + Sig(after(p), 4) + " " + unit +
            (p.outliers > 0 ? ", " + std::to_string(p.outliers) + " outlier(s)" : "") + "</title>\n");
    svg.Rect(x, Y(before(p)), bar, top + plot_h - Y(before(p)), "#9a9a9a");
    svg.Rect(x + bar, Y(after(p)), bar, top + plot_h - Y(after(p)), "#000");
    if (p.outliers > 0) {
      const double cx = x + bar, cy = std::min(Y(before(p)), Y(after(p))) - 4;
      svg.Polygon({{cx - 5, cy - 8}, {cx + 5, cy - 8}, {cx, cy}}, "#d00000", " class=\"outlier-mark\"");
    }
    svg.Raw("</g>\n");
    if (i % label_every == 0) svg.Text(x + bar, top + plot_h + 14, std::to_string(i + 1), "middle");
  }
  svg.Text(left + plot_w / 2, height - 8, "configuration (in the order measured)", "middle");
  // Legend.
  svg.Rect(left + 8, 8, 10, 10, "#9a9a9a");
  svg.Text(left + 22, 17, "before calibration");
  svg.Rect(left + 140, 8, 10, 10, "#000");
  svg.Text(left + 154, 17, "after calibration");
  svg.Polygon({{left + 270, 8}, {left + 280, 8}, {left + 275, 17}}, "#d00000");
  svg.Text(left + 286, 17, "holds a shot the robust fit excluded");
  return svg.Finish();
}

void ResidualSection(const ReportData& d, std::ostringstream& out) {
  const FitSection& f = d.fit;
  out << "<section id=\"residuals\">\n<h2>4. Residuals per pose</h2>\n";
  if (f.poses.empty()) {
    out << None("No calibration measurements are stored.") << "</section>\n";
    return;
  }
  int outlier_poses = 0;
  for (const PoseResidual& p : f.poses) outlier_poses += p.outliers > 0 ? 1 : 0;
  out << "<p class=\"note\">Each configuration's calibration shots against the nominal model with the registered "
         "base (before) and the calibrated model (after): the RMS of their residuals, on a logarithmic axis. "
      << (d.calibration_after_fit > 0 ? "Only the measurements the fit saw. " : "") << f.poses.size()
      << " configuration(s), " << outlier_poses << " with excluded shots.";
  if (f.poses.size() > kMaxResidualBars) {
    out << " The first " << kMaxResidualBars << " configurations are drawn.";
  }
  out << "</p>\n<figure>\n"
      << ResidualBars(f.poses, false, "residual-position-chart")
      << "<figcaption>Position residual (mm).</figcaption>\n</figure>\n";
  if (d.measurement_type != MeasurementType::kPosition) {
    out << "<figure>\n"
        << ResidualBars(f.poses, true, "residual-orientation-chart") << "<figcaption>"
        << (d.measurement_type == MeasurementType::kPose ? "Orientation" : "Tool-axis")
        << " residual (deg).</figcaption>\n</figure>\n";
  }
  out << "</section>\n";
}

void AccuracyRow(std::ostringstream& out, const char* label, const char* key, const api::Statistics& before,
                 const api::Statistics& after, double factor, int digits) {
  const std::string k = key;
  out << "<tr" << Attr("data-error", k) << "><th>" << label << "</th>";
  for (const auto& [side, s] :
       {std::pair<const char*, const api::Statistics&>{"nominal", before}, {"calibrated", after}}) {
    const std::string prefix = std::string(side) + "." + k + ".";
    out << NumCell(s.mean * factor, digits, prefix + "mean") << NumCell(s.std * factor, digits, prefix + "std")
        << NumCell(s.max * factor, digits, prefix + "max") << NumCell(s.rp * factor, digits, prefix + "rp");
  }
  out << "</tr>\n";
}

// Empirical CDFs of E_xyz before and after on a logarithmic axis.
std::string Cdf(const std::vector<double>& before_mm, const std::vector<double>& after_mm) {
  std::vector<double> all = before_mm;
  all.insert(all.end(), after_mm.begin(), after_mm.end());
  const std::pair<int, int> decades = Decades(all);
  const int lo = decades.first, hi = decades.second;
  const double width = 640.0, height = 300.0, left = 56.0, right = 16.0, top = 28.0, bottom = 44.0;
  const double plot_w = width - left - right, plot_h = height - top - bottom;
  Svg svg(width, height, "exyz-cdf", "cumulative distribution of E_xyz before and after calibration");
  const auto X = [&](double mm) {
    if (!(mm > 0.0)) return left;
    return left + plot_w * std::clamp((std::log10(mm) - lo) / (hi - lo), 0.0, 1.0);
  };
  const auto Y = [&](double fraction) { return top + plot_h * (1.0 - fraction); };
  svg.Rect(left, top, plot_w, plot_h, "#fff", "#000");
  for (int e = lo; e <= hi; ++e) {
    const double x = X(std::pow(10.0, e));
    svg.Line(x, top, x, top + plot_h, "#ccc");
    svg.Text(x, top + plot_h + 14, DecadeLabel(e), "middle");
  }
  for (double f : {0.0, 0.25, 0.5, 0.75, 1.0}) {
    svg.Line(left, Y(f), left + plot_w, Y(f), "#eee");
    svg.Text(left - 4, Y(f) + 4, Fixed(100.0 * f, 0) + " %", "end");
  }
  const auto curve = [&](std::vector<double> values, const char* stroke, double width_px, const char* dash,
                         const char* name) {
    std::sort(values.begin(), values.end());
    std::vector<std::pair<double, double>> points;
    const double n = static_cast<double>(values.size());
    for (std::size_t i = 0; i < values.size(); ++i) {
      points.emplace_back(X(values[i]), Y(static_cast<double>(i) / n));
      points.emplace_back(X(values[i]), Y(static_cast<double>(i + 1) / n));
    }
    if (!points.empty()) points.emplace_back(left + plot_w, Y(1.0));
    svg.Polyline(
        points, stroke, width_px, dash,
        std::string(" class=\"cdf\" data-curve=\"") + name + "\" data-count=\"" + std::to_string(values.size()) + "\"");
  };
  curve(before_mm, "#808080", 2.5, "6 3", "before");
  curve(after_mm, "#000", 2.0, nullptr, "after");
  svg.Text(left + plot_w / 2, height - 8, "E_xyz (mm, log)", "middle");
  svg.Text(14, top + plot_h / 2, "share of validation poses", "middle", "#000", -90.0);
  svg.Line(left + 10, 13, left + 34, 13, "#808080", 2.5, "6 3");
  svg.Text(left + 40, 17, "before calibration (nominal model)");
  svg.Line(left + 250, 13, left + 274, 13, "#000", 2.0);
  svg.Text(left + 280, 17, "after calibration");
  return svg.Finish();
}

// A joint's error map: its value over its knots (deg against deg) with the 2-sigma band shaded.
std::string MapPlot(const MapCurve& c, const std::string& id) {
  const double width = 640.0, height = 220.0, left = 64.0, right = 16.0, top = 24.0, bottom = 40.0;
  const double plot_w = width - left - right, plot_h = height - top - bottom;
  double lo = 0.0, hi = 0.0;
  for (std::size_t i = 0; i < c.value_deg.size(); ++i) {
    lo = std::min(lo, c.value_deg[i] - c.band_deg[i]);
    hi = std::max(hi, c.value_deg[i] + c.band_deg[i]);
  }
  if (!(hi > lo)) hi = lo + 1e-3;
  const double a0 = c.angle_deg.front(), a1 = c.angle_deg.back() > a0 ? c.angle_deg.back() : a0 + 1.0;
  const auto X = [&](double a) { return left + plot_w * (a - a0) / (a1 - a0); };
  const auto Y = [&](double v) { return top + plot_h * (1.0 - (v - lo) / (hi - lo)); };
  Svg svg(width, height, id, "error map of joint " + c.joint + " with its 2-sigma band");
  svg.Rect(left, top, plot_w, plot_h, "#fff", "#000");
  svg.Line(left, Y(0.0), left + plot_w, Y(0.0), "#ccc");
  std::vector<std::pair<double, double>> band, line;
  for (std::size_t i = 0; i < c.angle_deg.size(); ++i)
    band.emplace_back(X(c.angle_deg[i]), Y(c.value_deg[i] + c.band_deg[i]));
  for (std::size_t i = c.angle_deg.size(); i-- > 0;)
    band.emplace_back(X(c.angle_deg[i]), Y(c.value_deg[i] - c.band_deg[i]));
  svg.Polygon(band, "#d5d8dc", " class=\"map-band\"");
  for (std::size_t i = 0; i < c.angle_deg.size(); ++i) line.emplace_back(X(c.angle_deg[i]), Y(c.value_deg[i]));
  svg.Polyline(line, "#000", 1.5, nullptr,
               " class=\"map-curve\" data-joint=\"" + EscapeHtml(c.joint) + "\" data-samples=\"" +
                   std::to_string(line.size()) + "\"");
  svg.Text(left - 4, Y(hi) + 4, Sig(hi, 3), "end");
  svg.Text(left - 4, Y(lo) + 4, Sig(lo, 3), "end");
  svg.Text(left, top + plot_h + 14, Fixed(a0, 1), "middle");
  svg.Text(left + plot_w, top + plot_h + 14, Fixed(a1, 1), "middle");
  svg.Text(left + plot_w / 2, height - 8, "joint " + c.joint + " angle (deg)", "middle");
  svg.Text(14, top + plot_h / 2, "error (deg)", "middle", "#000", -90.0);
  svg.Text(left + 6, 16, "fitted map (line) and its 2-sigma band (shaded); held at its end values beyond");
  return svg.Finish();
}

void MapSection(const ReportData& d, std::ostringstream& out) {
  if (d.fit.maps.empty()) return;
  out << "<section id=\"joint-maps\">\n<h2>Joint error maps</h2>\n<p class=\"note\">Each mapped joint's fitted "
         "angle error over its knots (docs/identification.md, \"Joint error maps\"); its constant, the joint's "
         "offset, is in the geometric parameters.</p>\n";
  for (std::size_t k = 0; k < d.fit.maps.size(); ++k) out << MapPlot(d.fit.maps[k], "map-" + std::to_string(k));
  out << "</section>\n";
}

void ValidationSectionHtml(const ReportData& d, std::ostringstream& out) {
  out << "<section id=\"validation\">\n<h2>5. Validation</h2>\n";
  if (!d.validation) {
    out << None(
               "No validation measurements: upload measurements with role validation to see the accuracy "
               "before and after calibration.")
        << "</section>\n";
    return;
  }
  const api::Evaluation& e = d.validation->evaluation;
  out << "<p class=\"note\">The " << e.num_validation
      << " validation measurements (not used by the fit) against the nominal model with the registered base "
         "(before) and the calibrated model (after), in the paper's form: E_xyz the position error, E_cos the "
         "angle between the tool axes, E_tot = E_xyz + h E_cos (E_cos in rad), h = "
      << "<span id=\"h-mm\"" << Attr("data-value", Exact(e.h_mm)) << ">" << Sig(e.h_mm, 6)
      << "</span> mm; RP = mean + 3 std.</p>\n";
  if (e.note) out << "<p class=\"note\">" << EscapeHtml(*e.note) << "</p>\n";
  out << "<table id=\"validation-table\">\n<thead><tr><th rowspan=\"2\">error</th><th colspan=\"4\">before "
         "calibration</th><th colspan=\"4\">after calibration</th></tr>\n<tr>"
         "<th>mean</th><th>std</th><th>max</th><th>mean + 3 std (RP)</th>"
         "<th>mean</th><th>std</th><th>max</th><th>mean + 3 std (RP)</th></tr></thead>\n<tbody>\n";
  AccuracyRow(out, "E_xyz (um)", "e_xyz_um", e.nominal.e_xyz_mm, e.calibrated.e_xyz_mm, kUmPerMm, 1);
  AccuracyRow(out, "E_cos (arcsec)", "e_cos_arcsec", e.nominal.e_cos_deg, e.calibrated.e_cos_deg, kArcsecPerDeg, 2);
  AccuracyRow(out, "E_tot (um)", "e_tot_um", e.nominal.e_tot_mm, e.calibrated.e_tot_mm, kUmPerMm, 1);
  out << "</tbody></table>\n";
  const api::Improvement& i = e.improvement_percent;
  out << "<table id=\"improvement\">\n<thead><tr><th>improvement (%)</th><th>E_xyz mean</th><th>E_xyz RP</th>"
         "<th>E_tot mean</th><th>E_tot RP</th></tr></thead>\n<tbody><tr><th>100 (before - after) / before</th>"
      << NumCell(i.e_xyz_mean, 1, "improvement.e_xyz_mean") << NumCell(i.e_xyz_rp, 1, "improvement.e_xyz_rp")
      << NumCell(i.e_tot_mean, 1, "improvement.e_tot_mean") << NumCell(i.e_tot_rp, 1, "improvement.e_tot_rp")
      << "</tr></tbody></table>\n";
  out << "<figure>\n"
      << Cdf(d.validation->e_xyz_before_mm, d.validation->e_xyz_after_mm)
      << "<figcaption>Cumulative distribution of E_xyz over the validation poses: the share of poses whose "
         "position error is at most the value on the axis. A curve further left is more accurate.</figcaption>\n"
         "</figure>\n</section>\n";
}

void Iso9283Rows(std::ostringstream& out, const char* set, const api::Iso9283FiguresWire& figures) {
  for (const api::Iso9283PoseWire& p : figures.poses) {
    const std::string key = std::string(set) + "." + p.pose;
    out << "<tr><th>" << set << "</th>" << TextCell(p.pose) << IntCell(p.cycles) << NumCell(p.ap_mm, 4, key + ".ap_mm")
        << NumCell(p.apx_mm, 4) << NumCell(p.apy_mm, 4) << NumCell(p.apz_mm, 4) << NumCell(p.apa_deg, 5)
        << NumCell(p.apb_deg, 5) << NumCell(p.apc_deg, 5) << NumCell(p.rpl_mm, 4, key + ".rpl_mm")
        << NumCell(p.rpa_deg, 5) << NumCell(p.rpb_deg, 5) << NumCell(p.rpc_deg, 5) << "</tr>\n";
  }
}

void Iso9283SectionHtml(const ReportData& d, std::ostringstream& out) {
  out << "<section id=\"iso9283\">\n<h2>6. ISO 9283 pose test</h2>\n";
  if (!d.iso9283) {
    out << None(d.iso9283_problem.empty()
                    ? "No test measurements: upload shots of role test, each tagged with its ISO 9283 pose (P1-P5) "
                      "and cycle (docs/iso9283.md)."
                    : d.iso9283_problem)
        << "</section>\n";
    return;
  }
  const api::Iso9283ReportWire& r = *d.iso9283;
  out << "<p class=\"note\">" << r.num_shots << " test shots, at most " << r.cycles
      << " cycles per pose; commands from "
      << (r.commands == api::TestCommands::kPlan ? "the test plan" : "the robot's model at each shot's joints")
      << ", tracker frame "
      << (r.frames == api::TestFrames::kCalibration ? "from the calibration" : "registered on the test shots")
      << ". measured: the test as the robot ran it; calibrated: the attained poses against the calibrated model, the "
         "accuracy the robot shows with commands compensated by this calibration. AP and RP in mm, angles in degrees "
         "about the base axes; an empty cell is not measurable.</p>\n";
  for (const std::string& note : r.notes) out << "<p class=\"note\">" << EscapeHtml(note) << "</p>\n";
  out << "<table id=\"iso9283-poses\">\n<thead><tr><th>set</th><th>pose</th><th>cycles</th><th>AP</th><th>APx</th>"
         "<th>APy</th><th>APz</th><th>APa</th><th>APb</th><th>APc</th><th>RPl</th><th>RPa</th><th>RPb</th><th>RPc</th>"
         "</tr></thead>\n<tbody>\n";
  Iso9283Rows(out, "measured", r.measured);
  if (r.calibrated) Iso9283Rows(out, "calibrated", *r.calibrated);
  out << "</tbody></table>\n<table id=\"iso9283-distances\">\n<thead><tr><th>set</th><th>poses</th><th>cycles</th>"
         "<th>D_c</th><th>AD</th><th>ADx</th><th>ADy</th><th>ADz</th><th>RD</th></tr></thead>\n<tbody>\n";
  const auto distances = [&](const char* set, const api::Iso9283FiguresWire& f) {
    for (const api::Iso9283DistanceWire& x : f.distances) {
      out << "<tr><th>" << set << "</th>" << TextCell(x.from + "-" + x.to) << IntCell(x.cycles)
          << NumCell(x.command_mm, 3) << NumCell(x.ad_mm, 4) << NumCell(x.adx_mm, 4) << NumCell(x.ady_mm, 4)
          << NumCell(x.adz_mm, 4) << NumCell(x.rd_mm, 4) << "</tr>\n";
    }
  };
  distances("measured", r.measured);
  if (r.calibrated) distances("calibrated", *r.calibrated);
  out << "</tbody></table>\n</section>\n";
}

constexpr const char* kStyle = R"(
body { font-family: "DejaVu Sans", Arial, sans-serif; font-size: 13px; color: #000; background: #fff;
       margin: 24px auto; max-width: 960px; padding: 0 16px; line-height: 1.35; }
h1 { font-size: 22px; margin: 0 0 12px 0; }
h2 { font-size: 18px; border-bottom: 2px solid #000; padding-bottom: 2px; margin-top: 32px; }
h3 { font-size: 14px; margin: 18px 0 6px 0; }
table { border-collapse: collapse; margin: 6px 0 10px 0; }
th, td { border: 1px solid #888; padding: 2px 7px; vertical-align: top; }
th { background: #eee; text-align: left; font-weight: bold; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
p.none { font-style: italic; border-left: 3px solid #888; padding-left: 8px; }
p.warning { font-weight: bold; border-left: 3px solid #d00000; padding-left: 8px; max-width: 900px; }
p.note { color: #222; max-width: 900px; }
figure { margin: 10px 0; }
figure.views svg { margin-right: 8px; }
figcaption { font-size: 12px; max-width: 880px; }
nav ol.toc { padding-left: 20px; }
svg { max-width: 100%; height: auto; }
@media print {
  @page { margin: 14mm; }
  body { margin: 0; max-width: none; padding: 0; font-size: 9.5pt; }
  nav { display: none; }
  section { break-before: page; page-break-before: always; }
  th { background: none; }
  tr, figure, svg { break-inside: avoid; page-break-inside: avoid; }
  a { color: #000; text-decoration: none; }
}
)";

}  // namespace

std::string EscapeHtml(std::string_view raw) {
  // Invalid UTF-8 is made visible as \xNN text first (api::SafeText), so that every byte below is well formed.
  std::string safe;
  if (!api::IsValidUtf8(raw)) {
    safe = api::SafeText(raw, std::string::npos);
    raw = safe;
  }
  std::string out;
  out.reserve(raw.size() + raw.size() / 8);
  for (const char ch : raw) {
    const unsigned char c = static_cast<unsigned char>(ch);
    switch (ch) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        if ((c < 0x20 && ch != '\n' && ch != '\t') || c == 0x7F) {
          out += "\xEF\xBF\xBD";  // U+FFFD
        } else {
          out += ch;
        }
    }
  }
  return out;
}

double StdPercent(double value, double std) {
  if (value == 0.0 || !std::isfinite(value) || !std::isfinite(std)) return kNaN;
  return 100.0 * std / std::abs(value);
}

std::vector<Correlation> TopCorrelations(const std::vector<std::string>& names, const Eigen::MatrixXd& rho,
                                         std::size_t count) {
  struct Pair {
    Eigen::Index i, j;
    double rho;
  };
  std::vector<Pair> pairs;
  const Eigen::Index n = std::min<Eigen::Index>(static_cast<Eigen::Index>(names.size()), rho.rows());
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = i + 1; j < n; ++j) pairs.push_back({i, j, rho(i, j)});
  std::stable_sort(pairs.begin(), pairs.end(),
                   [](const Pair& a, const Pair& b) { return std::abs(a.rho) > std::abs(b.rho); });
  std::vector<Correlation> out;
  for (std::size_t k = 0; k < std::min(count, pairs.size()); ++k) {
    out.push_back(
        {names[static_cast<std::size_t>(pairs[k].i)], names[static_cast<std::size_t>(pairs[k].j)], pairs[k].rho});
  }
  return out;
}

std::string RenderReport(const ReportData& data) {
  std::ostringstream out;
  out << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
         "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
         "<meta name=\"generator\" content=\"robocal\">\n<title>Calibration report: "
      << EscapeHtml(data.campaign) << "</title>\n<style>" << kStyle << "</style>\n</head>\n<body>\n";
  Header(data, out);
  RobotSection(data, out);
  PlanSectionHtml(data, out);
  FitSectionHtml(data, out);
  ResidualSection(data, out);
  MapSection(data, out);
  ValidationSectionHtml(data, out);
  Iso9283SectionHtml(data, out);
  out << "<footer><p class=\"note\">Made by robocal from the stored campaign, plan, calibration and measurements; "
         "the per-pose residuals are recomputed from them with the fit's own weighting. docs/report.md explains every "
         "section.</p></footer>\n</body>\n</html>\n";
  return out.str();
}

}  // namespace robocal::server::report
