#include "robocal/api/tracker_files.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <sstream>
#include <string_view>
#include <utility>

#include "robocal/api/json_reader.h"
#include "robocal/core/random.h"

namespace robocal::api {
namespace {

// The file formats are read by hand: they are line-oriented text with a handful of rules (a unit header line,
// comma or white-space separated fields, CSV quotes), and no Debian library reads Spatial Analyzer exports; a
// general CSV library would still leave the unit, column and line-number rules here.

// No export has more columns than this, and no import more points (the server's own batch limit is lower).
constexpr std::ptrdiff_t kMaxCsvFields = 1000;
constexpr std::size_t kMaxTrackerPoints = 100000;
// Target and reflector names longer than this are no names a tracker program writes.
constexpr std::size_t kMaxTargetLength = 128;

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

std::string Trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t\n\r\f\v");
  if (first == std::string::npos) return "";
  const auto last = s.find_last_not_of(" \t\n\r\f\v");
  return s.substr(first, last - first + 1);
}

double UnitScale(TrackerFileUnit unit) {
  if (unit == TrackerFileUnit::kM) return 1000.0;
  if (unit == TrackerFileUnit::kIn) return 25.4;
  return 1.0;
}

// The unit a header word names ("Millimeters", "mm", "metres", "inch", ...), or none.
std::optional<TrackerFileUnit> UnitOfWord(const std::string& word) {
  const std::string w = Lower(Trim(word));
  for (const char* mm : {"mm", "millimeter", "millimeters", "millimetre", "millimetres"}) {
    if (w == mm) return TrackerFileUnit::kMm;
  }
  for (const char* m : {"m", "meter", "meters", "metre", "metres"}) {
    if (w == m) return TrackerFileUnit::kM;
  }
  for (const char* in : {"in", "inch", "inches"}) {
    if (w == in) return TrackerFileUnit::kIn;
  }
  return std::nullopt;
}

std::string LineReason(int line, const std::string& why) { return "line " + std::to_string(line) + ": " + why; }

// A printable, bounded excerpt of a field for a reason.
std::string Shown(const std::string& field) {
  std::string out;
  for (char c : field.substr(0, 40)) out += (static_cast<unsigned char>(c) < 0x20 || c == 0x7F) ? '?' : c;
  return "'" + out + (field.size() > 40 ? "...'" : "'");
}

// A finite decimal number filling the whole field (digits, sign, point, exponent: no hex, no inf or nan, which
// strtod would take). A number too small for a double reads as what strtod makes of it (0 or subnormal).
std::optional<double> Number(const std::string& field) {
  const std::string f = Trim(field);
  if (f.empty() || f.find_first_not_of("0123456789+-.eE") != std::string::npos) return std::nullopt;
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(f.c_str(), &end);
  if (end != f.c_str() + f.size() || !std::isfinite(value) || (errno == ERANGE && std::abs(value) > 1.0)) {
    return std::nullopt;
  }
  return value;
}

// The file's lines as views into `text`, without their line ends: LF, CRLF and a lone CR each end a line, as
// editors count them; a leading UTF-8 byte order mark is dropped.
std::vector<std::string_view> Lines(const std::string& text) {
  std::vector<std::string_view> lines;
  const std::string_view all(text);
  std::size_t start = all.rfind("\xEF\xBB\xBF", 0) == 0 ? 3 : 0;
  while (true) {
    const std::size_t end = all.find_first_of("\r\n", start);
    if (end == std::string_view::npos) {
      lines.push_back(all.substr(start));
      break;
    }
    lines.push_back(all.substr(start, end - start));
    start = end + (all[end] == '\r' && end + 1 < all.size() && all[end + 1] == '\n' ? 2 : 1);
  }
  return lines;
}

// Splits an SA row: at commas if it has any, else at runs of white space. A row of more than `max_fields` fields
// gives max_fields + 1 of them (enough to say it has too many, without building a field per comma of a 4 MiB line).
std::vector<std::string> SplitSaRow(const std::string& line, std::size_t max_fields) {
  std::vector<std::string> fields;
  if (line.find(',') != std::string::npos) {
    if (static_cast<std::size_t>(std::count(line.begin(), line.end(), ',')) >= max_fields + 1) {
      return std::vector<std::string>(max_fields + 1);
    }
    std::size_t start = 0;
    while (true) {
      const std::size_t comma = line.find(',', start);
      fields.push_back(Trim(line.substr(start, comma == std::string::npos ? std::string::npos : comma - start)));
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
  } else {
    std::size_t i = 0;
    while (i < line.size() && fields.size() <= max_fields) {
      while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
      if (i == line.size()) break;
      const std::size_t start = i;
      while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
      fields.push_back(line.substr(start, i - start));
    }
  }
  return fields;
}

// Splits a CSV row at `delimiter`, with RFC 4180 quotes ("a ""b""" is a "b"); false for an unclosed quote.
bool SplitCsvRow(const std::string& line, char delimiter, std::vector<std::string>* fields) {
  fields->clear();
  std::string field;
  bool quoted = false, was_quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        field += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        field += c;
      }
    } else if (c == '"' && Trim(field).empty()) {
      quoted = was_quoted = true;
      field.clear();
    } else if (c == delimiter) {
      fields->push_back(was_quoted ? field : Trim(field));
      field.clear();
      was_quoted = false;
    } else {
      field += c;
    }
  }
  if (quoted) return false;
  fields->push_back(was_quoted ? field : Trim(field));
  return true;
}

// The delimiter of a CSV header: the most frequent of ',', ';' and tab outside quotes (0 if none occurs).
char CsvDelimiter(const std::string& header) {
  int counts[3] = {0, 0, 0};
  const char delimiters[3] = {',', ';', '\t'};
  bool quoted = false;
  for (char c : header) {
    if (c == '"') quoted = !quoted;
    for (int k = 0; k < 3; ++k) counts[k] += !quoted && c == delimiters[k];
  }
  char best = 0;
  int count = 0;
  for (int k = 0; k < 3; ++k) {
    if (counts[k] > count) {
      best = delimiters[k];
      count = counts[k];
    }
  }
  return best;
}

// A field's number with `decimal` as the decimal separator ("," in European exports: "0,25" is 0.25).
std::optional<double> Number(const std::string& field, char decimal) {
  if (decimal == '.') return Number(field);
  std::string f = field;
  if (f.find('.') != std::string::npos) return std::nullopt;  // with decimal commas a point is no number
  std::replace(f.begin(), f.end(), ',', '.');
  return Number(f);
}

// Checks a point's position (already in mm) and records its problems; true if usable.
bool CheckPosition(const Eigen::Vector3d& p, int line, Problems* problems) {
  // Each coordinate first: the norm of coordinates near the largest double overflows.
  if (p.cwiseAbs().maxCoeff() > kMaxTrackerDistanceMm || !(p.norm() <= kMaxTrackerDistanceMm)) {
    std::ostringstream why;
    why.precision(6);
    const double metres = p.stableNorm() / 1000.0;  // stableNorm: the plain norm of 1e308 overflows
    why << "the point is ";
    if (std::isfinite(metres)) {
      why << metres << " m from the tracker, beyond 1 km";
    } else {
      why << "too far from the tracker for a double";
    }
    why << ": a wrong unit or column?";
    problems->Add("text", LineReason(line, why.str()));
    return false;
  }
  return true;
}

void ReadSa(const ImportMeasurementsRequest& req, const std::vector<std::string_view>& lines,
            std::vector<TrackerPoint>* points, Problems* problems) {
  std::optional<TrackerFileUnit> declared;
  int declared_line = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const int line = static_cast<int>(i) + 1;
    const std::string text = Trim(std::string(lines[i]));
    if (text.empty()) continue;
    if (text.rfind("//", 0) == 0) {
      // A header line; "// Units: Millimeters" (or "Unit = mm") declares the unit: the first word after the
      // separator ("Millimeters (mm)", "Meters, Degrees" declare mm and m). Other header lines are comments.
      const std::string header = Trim(text.substr(2));
      const std::string lower = Lower(header);
      const std::size_t name = lower.rfind("units", 0) == 0 ? 5 : lower.rfind("unit", 0) == 0 ? 4 : 0;
      if (name == 0) continue;
      const std::size_t sep = header.find_first_not_of(" \t", name);
      if (sep == std::string::npos || (header[sep] != ':' && header[sep] != '=')) continue;
      const std::size_t first = header.find_first_not_of(" \t", sep + 1);
      std::string word;
      for (std::size_t k = first;
           k != std::string::npos && k < header.size() && std::isalpha(static_cast<unsigned char>(header[k])); ++k) {
        word += header[k];
      }
      if (word.empty() && first != std::string::npos) word = header.substr(first);
      const std::optional<TrackerFileUnit> unit = UnitOfWord(word);
      if (!unit) {
        problems->Add("text", LineReason(line, "unknown unit " + Shown(Trim(word)) + " (mm, m or in)"));
      } else if (declared && *unit != *declared) {
        problems->Add("text", LineReason(line, std::string("declares ") + WireName(*unit) + ", line " +
                                                   std::to_string(declared_line) + " declared " + WireName(*declared)));
      } else {
        declared = unit;
        declared_line = line;
      }
      continue;
    }
    if (points->size() >= kMaxTrackerPoints) {
      problems->Add("text", LineReason(line, "more than " + std::to_string(kMaxTrackerPoints) + " points"));
      break;
    }
    const std::vector<std::string> fields = SplitSaRow(text, 6);
    if (fields.size() != 6) {
      problems->Add("text", LineReason(line, "expected 6 fields (collection group target x y z), got " +
                                                 std::to_string(fields.size())));
      continue;
    }
    TrackerPoint p;
    p.line = line;
    p.target = fields[2];
    bool ok = true;
    if (p.target.size() > kMaxTargetLength) {
      problems->Add("text", LineReason(line, "target name longer than " + std::to_string(kMaxTargetLength)));
      ok = false;
    }
    static const char* const kAxes[3] = {"x", "y", "z"};
    for (int k = 0; k < 3; ++k) {
      const std::optional<double> v = Number(fields[3 + k]);
      if (!v) {
        problems->Add("text",
                      LineReason(line, std::string(kAxes[k]) + " " + Shown(fields[3 + k]) + " is not a finite number"));
        ok = false;
      } else {
        p.position_mm[k] = *v;
      }
    }
    if (ok) points->push_back(std::move(p));
  }
  // The unit: the request's or the file's, and never two different ones.
  std::optional<TrackerFileUnit> unit = req.unit;
  if (declared && unit && *declared != *unit) {
    problems->Add("unit", std::string("the request says ") + WireName(*unit) + ", the file declares " +
                              WireName(*declared) + " (line " + std::to_string(declared_line) + ")");
  } else if (!unit) {
    unit = declared;
  }
  if (!unit) {
    problems->Add("unit", "the file declares no unit (a '// Units: mm' line) and the request gives none");
    points->clear();  // positions in no known unit are no points
    return;
  }
  const double scale = UnitScale(*unit);
  std::vector<TrackerPoint> kept;
  for (TrackerPoint& p : *points) {
    p.position_mm *= scale;
    if (CheckPosition(p.position_mm, p.line, problems)) kept.push_back(std::move(p));
  }
  *points = std::move(kept);
}

// A CSV export's header row: its index among the lines, its 1-based line, its text, the delimiter and decimal
// separator of the file, and the column names.
struct CsvHeader {
  std::size_t index = 0;
  int line = 0;
  std::string text;
  char delimiter = 0;
  char decimal = '.';
  std::vector<std::string> names;
};

// The header: the first line that is not blank, split at the request's delimiter or the most frequent one. False
// when there is none (no line: "no points" follows) or it is not usable (a problem says why).
bool ReadCsvHeader(const ImportMeasurementsRequest& req, const std::vector<std::string_view>& lines, CsvHeader* header,
                   Problems* problems) {
  std::size_t header_index = 0;
  while (header_index < lines.size() && Trim(std::string(lines[header_index])).empty()) ++header_index;
  if (header_index == lines.size()) return false;  // "no points" follows
  header->index = header_index;
  header->line = static_cast<int>(header_index) + 1;
  header->text = std::string(lines[header_index]);
  const std::string& header_text = header->text;
  const int header_line = header->line;
  // Each delimiter's wire name is the character itself.
  const char delimiter = req.delimiter ? WireName(*req.delimiter)[0] : CsvDelimiter(header_text);
  header->delimiter = delimiter;
  header->decimal = req.decimal == TrackerFileDecimal::kComma ? ',' : '.';
  if (delimiter != 0 && std::count(header_text.begin(), header_text.end(), delimiter) >= kMaxCsvFields) {
    problems->Add("text", LineReason(header_line, "more than " + std::to_string(kMaxCsvFields) + " columns"));
    return false;
  }
  if (delimiter == 0 || !SplitCsvRow(header_text, delimiter, &header->names)) {
    problems->Add("text", LineReason(header_line, "the header has no ',', ';' or tab between column names"));
    return false;
  }
  if (header->names.size() < 3) {
    problems->Add("text", LineReason(header_line, "the header has " + std::to_string(header->names.size()) +
                                                      " column(s) at delimiter " + Shown(std::string(1, delimiter)) +
                                                      ": is the delimiter right?"));
    return false;
  }
  return true;
}

// A column the import needs: the request's field that names it, its name, and its index in the header.
struct CsvWanted {
  std::string field;
  std::string name;
  int index = -1;
};

// The columns the import needs: target (matching by name), x, y, z, the nest, the joints, the orientation; each
// role's entries in `wanted` (SIZE_MAX: not read).
struct CsvLayout {
  std::vector<CsvWanted> wanted;
  std::size_t target = SIZE_MAX;
  std::size_t axes[3] = {SIZE_MAX, SIZE_MAX, SIZE_MAX};
  std::size_t reflector = SIZE_MAX;
  std::vector<std::size_t> joint_columns, orientation_columns;
  // The largest header index of a wanted column.
  std::size_t max_index = 0;
};

CsvLayout WantedCsvColumns(const ImportMeasurementsRequest& req) {
  const bool with_joints = !req.joints.columns.empty();
  CsvLayout layout;
  std::vector<CsvWanted>& wanted = layout.wanted;
  const auto want = [&](const std::string& field, const std::string& name) {
    wanted.push_back({field, name});
    return wanted.size() - 1;
  };
  layout.target =
      req.match == TrackerFileMatch::kName && !with_joints ? want("columns.target", req.columns.target) : SIZE_MAX;
  layout.axes[0] = want("columns.x", req.columns.x);
  layout.axes[1] = want("columns.y", req.columns.y);
  layout.axes[2] = want("columns.z", req.columns.z);
  layout.reflector = req.columns.reflector.empty() ? SIZE_MAX : want("columns.reflector", req.columns.reflector);
  for (std::size_t k = 0; k < req.joints.columns.size(); ++k) {
    layout.joint_columns.push_back(want("joints.columns[" + std::to_string(k) + "]", req.joints.columns[k]));
  }
  for (std::size_t k = 0; k < req.orientation.columns.size(); ++k) {
    layout.orientation_columns.push_back(
        want("orientation.columns[" + std::to_string(k) + "]", req.orientation.columns[k]));
  }
  return layout;
}

// Each wanted column's index in the header (names matched without regard to case or surrounding white space); false
// when one is missing (a problem for each).
bool FindCsvColumns(const CsvHeader& header, CsvLayout* layout, Problems* problems) {
  bool columns_ok = true;
  for (CsvWanted& w : layout->wanted) {
    for (std::size_t c = 0; c < header.names.size(); ++c) {
      if (Lower(Trim(header.names[c])) == Lower(Trim(w.name))) {
        w.index = static_cast<int>(c);
        break;
      }
    }
    if (w.index < 0) {
      problems->Add(w.field, "no column " + Shown(w.name) + " in the header (line " + std::to_string(header.line) +
                                 ": " + Shown(header.text) + ")");
      columns_ok = false;
    }
  }
  if (!columns_ok) return false;
  for (const CsvWanted& w : layout->wanted) {
    layout->max_index = std::max(layout->max_index, static_cast<std::size_t>(w.index));
  }
  return true;
}

// The points of a CSV export's data rows, in the request's units and layout.
class CsvPointReader {
 public:
  CsvPointReader(const ImportMeasurementsRequest& req, const CsvHeader& header, const CsvLayout& layout,
                 Problems* problems)
      : req_(req),
        layout_(layout),
        decimal_(header.decimal),
        scale_(req.unit ? UnitScale(*req.unit) : 1.0),
        joint_scale_(req.joints.unit == AngleUnit::kRad ? kDegPerRad : 1.0),
        angle_scale_(req.orientation.unit == AngleUnit::kDeg ? kRadPerDeg : 1.0),
        problems_(problems) {}

  // The point of a row split into `fields` (each wanted column present), appended to *points when usable; its
  // problems recorded.
  void Add(const std::vector<std::string>& fields, int line, std::vector<TrackerPoint>* points) const {
    const std::vector<CsvWanted>& wanted = layout_.wanted;
    TrackerPoint p;
    p.line = line;
    bool ok = true;
    if (layout_.target != SIZE_MAX) p.target = fields[wanted[layout_.target].index];
    if (layout_.reflector != SIZE_MAX) p.reflector = fields[wanted[layout_.reflector].index];
    if (p.target.size() > kMaxTargetLength || p.reflector.size() > kMaxTargetLength) {
      problems_->Add("text", LineReason(line, "target or reflector longer than " + std::to_string(kMaxTargetLength)));
      ok = false;
    }
    for (int k = 0; k < 3; ++k) {
      double v = 0.0;
      if (Read(fields, wanted[layout_.axes[k]], line, &v)) {
        p.position_mm[k] = v * scale_;
      } else {
        ok = false;
      }
    }
    for (std::size_t k : layout_.joint_columns) {
      double v = 0.0;
      if (Read(fields, wanted[k], line, &v)) {
        p.joints_deg.push_back(v * joint_scale_);
      } else {
        ok = false;
      }
    }
    std::vector<double> angles;
    for (std::size_t k : layout_.orientation_columns) {
      double v = 0.0;
      if (Read(fields, wanted[k], line, &v)) {
        angles.push_back(v);
      } else {
        ok = false;
      }
    }
    if (ok && !angles.empty()) ok = SetOrientation(angles, line, &p);
    if (ok && CheckPosition(p.position_mm, line, problems_)) points->push_back(std::move(p));
  }

 private:
  // A field's number, or a problem naming the line and the column.
  bool Read(const std::vector<std::string>& row, const CsvWanted& w, int line, double* out) const {
    const std::string& field = row[static_cast<std::size_t>(w.index)];
    const std::optional<double> v = Number(field, decimal_);
    if (!v) {
      std::string why = "column " + Shown(w.name) + ": " + Shown(field) + " is not a finite number";
      if (decimal_ == '.' && field.find(',') != std::string::npos && Number(field, ',').has_value()) {
        why += " (decimal commas: give decimal \",\")";
      }
      problems_->Add("text", LineReason(line, why));
      return false;
    }
    *out = *v;
    return true;
  }

  // The measured orientation from the orientation columns' values; false when a quaternion is not of unit norm.
  bool SetOrientation(const std::vector<double>& angles, int line, TrackerPoint* p) const {
    bool ok = true;
    Eigen::Quaterniond q;
    if (req_.orientation.representation == OrientationRepresentation::kQuaternion) {
      const bool w_first = req_.orientation.order == QuaternionOrder::kWxyz;
      q = w_first ? Eigen::Quaterniond(angles[0], angles[1], angles[2], angles[3])
                  : Eigen::Quaterniond(angles[3], angles[0], angles[1], angles[2]);
      const double norm = q.norm();
      if (!(std::abs(norm - 1.0) < 1e-3)) {
        std::ostringstream why;
        why << "the quaternion's norm is " << norm << ", not 1: are the columns and their order right?";
        problems_->Add("text", LineReason(line, why.str()));
        ok = false;
      }
      q.normalize();
    } else {
      q = Eigen::Quaterniond(
          EulerToRotation(req_.orientation.sequence, req_.orientation.convention == EulerConvention::kIntrinsic,
                          angles[0] * angle_scale_, angles[1] * angle_scale_, angles[2] * angle_scale_));
    }
    if (q.w() < 0.0) q.coeffs() *= -1.0;
    p->has_orientation = true;
    p->quaternion = {q.w(), q.x(), q.y(), q.z()};
    return ok;
  }

  const ImportMeasurementsRequest& req_;
  const CsvLayout& layout_;
  const char decimal_;
  const double scale_, joint_scale_, angle_scale_;
  Problems* problems_;
};

void ReadCsv(const ImportMeasurementsRequest& req, const std::vector<std::string_view>& lines,
             std::vector<TrackerPoint>* points, Problems* problems) {
  if (!req.unit) problems->Add("unit", "required for format csv (mm, m or in)");
  CsvHeader header;
  if (!ReadCsvHeader(req, lines, &header, problems)) return;
  CsvLayout layout = WantedCsvColumns(req);
  if (!FindCsvColumns(header, &layout, problems)) return;
  const CsvPointReader reader(req, header, layout, problems);
  const char delimiter = header.delimiter;
  std::vector<std::string> fields;
  for (std::size_t i = header.index + 1; i < lines.size(); ++i) {
    const int line = static_cast<int>(i) + 1;
    const std::string row(lines[i]);
    if (Trim(row).empty()) continue;
    if (points->size() >= kMaxTrackerPoints) {
      problems->Add("text", LineReason(line, "more than " + std::to_string(kMaxTrackerPoints) + " points"));
      break;
    }
    if (std::count(row.begin(), row.end(), delimiter) >= kMaxCsvFields) {
      problems->Add("text", LineReason(line, "more than " + std::to_string(kMaxCsvFields) + " fields"));
      continue;
    }
    if (!SplitCsvRow(row, delimiter, &fields)) {
      problems->Add("text", LineReason(line, "a quote is not closed"));
      continue;
    }
    if (layout.max_index >= fields.size()) {
      for (const CsvWanted& w : layout.wanted) {
        if (static_cast<std::size_t>(w.index) < fields.size()) continue;
        problems->Add("text", LineReason(line, "no value in column " + Shown(w.name) + " (" +
                                                   std::to_string(fields.size()) + " fields)"));
        break;
      }
      continue;
    }
    reader.Add(fields, line, points);
  }
}

}  // namespace

const char* EnumTable<TrackerFileFormat>::Name(TrackerFileFormat v) {
  return v == TrackerFileFormat::kCsv ? "csv" : "sa";
}
const char* EnumTable<TrackerFileUnit>::Name(TrackerFileUnit v) {
  switch (v) {
    case TrackerFileUnit::kM:
      return "m";
    case TrackerFileUnit::kIn:
      return "in";
    case TrackerFileUnit::kMm:
      break;
  }
  return "mm";
}
const char* EnumTable<TrackerFileMatch>::Name(TrackerFileMatch v) {
  return v == TrackerFileMatch::kOrder ? "order" : "name";
}
const char* EnumTable<TrackerFileDelimiter>::Name(TrackerFileDelimiter v) {
  switch (v) {
    case TrackerFileDelimiter::kSemicolon:
      return ";";
    case TrackerFileDelimiter::kTab:
      return "\t";
    case TrackerFileDelimiter::kComma:
      break;
  }
  return ",";
}
const char* EnumTable<TrackerFileDecimal>::Name(TrackerFileDecimal v) {
  return v == TrackerFileDecimal::kComma ? "," : ".";
}
const char* EnumTable<AngleUnit>::Name(AngleUnit v) { return v == AngleUnit::kRad ? "rad" : "deg"; }
const char* EnumTable<QuaternionOrder>::Name(QuaternionOrder v) {
  return v == QuaternionOrder::kXyzw ? "xyzw" : "wxyz";
}
const char* EnumTable<EulerConvention>::Name(EulerConvention v) {
  return v == EulerConvention::kExtrinsic ? "extrinsic" : "intrinsic";
}
const char* EnumTable<OrientationRepresentation>::Name(OrientationRepresentation v) {
  return v == OrientationRepresentation::kQuaternion ? "quaternion" : "euler";
}

namespace {

// The csv column names of `columns` (the request's r): each a non-empty name, `reflector` possibly empty.
void ReadCsvColumnNames(ObjectReader& r, TrackerFileFormat format, CsvColumns* columns) {
  const nlohmann::json* c = r.Get("columns");
  if (c == nullptr) return;
  Problems& problems = *r.problems();
  if (format != TrackerFileFormat::kCsv) problems.Add("columns", "only with format \"csv\"");
  ObjectReader cr(*c, "columns", &problems);
  for (auto [key, out] : {std::pair<const char*, std::string*>{"target", &columns->target},
                          {"x", &columns->x},
                          {"y", &columns->y},
                          {"z", &columns->z},
                          {"reflector", &columns->reflector}}) {
    if (cr.String(key, false, out, 128) && Trim(*out).empty() && std::string(key) != "reflector") {
      problems.Add(JoinPath("columns", key), "must name a column");
    }
  }
  cr.RejectUnknown(WireFieldNames<CsvColumns>());
}

// The `columns` array of `reader` (joints or orientation): between min and max names, each non-empty, at most 128
// characters, each named once.
void ReadNamedColumns(ObjectReader& reader, std::size_t min, std::size_t max, std::vector<std::string>* out) {
  Problems& problems = *reader.problems();
  const nlohmann::json* a = reader.Array("columns", true, min, max);
  if (a == nullptr) return;
  for (std::size_t k = 0; k < a->size(); ++k) {
    const std::string at = JoinPath(reader.path(), "columns") + "[" + std::to_string(k) + "]";
    const nlohmann::json& v = (*a)[k];
    if (!v.is_string() || Trim(v.get<std::string>()).empty() || v.get<std::string>().size() > 128) {
      problems.Add(at, "must name a column (a non-empty string of at most 128 characters)");
    } else if (std::find(out->begin(), out->end(), v.get<std::string>()) != out->end()) {
      problems.Add(at, "\"" + v.get<std::string>() + "\" is named twice");
    } else {
      out->push_back(v.get<std::string>());
    }
  }
}

// `joints` (the request's r): the joint columns and their unit; no plan to match then.
void ReadJointColumns(ObjectReader& r, TrackerFileFormat format, JointColumns* joints) {
  const nlohmann::json* j = r.Get("joints");
  if (j == nullptr) return;
  Problems& problems = *r.problems();
  if (format != TrackerFileFormat::kCsv) problems.Add("joints", "only with format \"csv\"");
  ObjectReader jr(*j, "joints", &problems);
  ReadNamedColumns(jr, 1, static_cast<std::size_t>(kMaxJoints), &joints->columns);
  jr.Enum("unit", true, &joints->unit);
  jr.RejectUnknown(WireFieldNames<JointColumns>());
  // Each row carries its joints: there is no plan to match.
  for (const char* key : {"plan", "match", "shots_per_configuration"}) {
    if (r.Has(key)) problems.Add(key, "not with joints: each row is a measurement at its own joints");
  }
}

// `orientation` (the request's r): a quaternion's four columns and order, or Euler angles' three columns, sequence,
// convention and unit.
void ReadOrientationColumns(ObjectReader& r, OrientationColumns* oc) {
  const nlohmann::json* o = r.Get("orientation");
  if (o == nullptr) return;
  Problems& problems = *r.problems();
  if (!r.Has("joints")) problems.Add("orientation", "only with joints (a file matched to a plan gives points)");
  ObjectReader orr(*o, "orientation", &problems);
  OrientationRepresentation representation{};
  if (!orr.Enum("representation", true, &representation)) return;
  oc->representation = representation;
  const bool quaternion = representation == OrientationRepresentation::kQuaternion;
  const std::size_t count = quaternion ? 4 : 3;
  ReadNamedColumns(orr, count, count, &oc->columns);
  if (quaternion) {
    orr.Enum("order", true, &oc->order);
    orr.RejectUnknown(WireFieldNamesOf(*oc));
    return;
  }
  if (orr.String("sequence", true, &oc->sequence, 8)) {
    try {
      (void)EulerToRotation(oc->sequence, true, 0.0, 0.0, 0.0);
    } catch (const std::invalid_argument& e) {
      problems.Add("orientation.sequence", e.what());
    }
  }
  orr.Enum("convention", true, &oc->convention);
  orr.Enum("unit", true, &oc->unit);
  orr.RejectUnknown(WireFieldNamesOf(*oc));
}

// `rows` (the request's r): ascending 1-based line numbers of the text, each once.
void ReadRowNumbers(ObjectReader& r, std::vector<int>* rows) {
  const nlohmann::json* a = r.Array("rows", false, 1, kMaxTrackerFileBytes);
  if (a == nullptr) return;
  Problems& problems = *r.problems();
  for (std::size_t k = 0; k < a->size(); ++k) {
    const nlohmann::json& v = (*a)[k];
    if (!v.is_number_integer() || v.get<std::int64_t>() < 1 ||
        v.get<std::int64_t>() > static_cast<std::int64_t>(kMaxTrackerFileBytes)) {
      problems.Add(IndexPath("rows", k), "expected a line number of the text, 1 or more");
    } else if (!rows->empty() && v.get<std::int64_t>() <= rows->back()) {
      problems.Add(IndexPath("rows", k), "lines must be ascending, each once");
    } else {
      rows->push_back(static_cast<int>(v.get<std::int64_t>()));
    }
  }
}

}  // namespace

bool HasText(const std::string& text) { return !Trim(text).empty(); }

ImportMeasurementsRequest ParseImportMeasurementsRequest(const nlohmann::json& body) {
  Problems problems;
  ImportMeasurementsRequest req;
  ObjectReader r(body, "", &problems);
  // The table's rows (request_id, role, format, text, unit, plan, match, shots_per_configuration, the csv's
  // delimiter and decimal, payload); then what depends on the format or on other members.
  ReadRequest(r, &req);
  if (r.Has("shots_per_configuration") && req.match != TrackerFileMatch::kOrder) {
    problems.Add("shots_per_configuration", "only with match \"order\"");
  }
  ReadCsvColumnNames(r, req.format, &req.columns);
  if (req.decimal == TrackerFileDecimal::kComma && req.delimiter == TrackerFileDelimiter::kComma) {
    problems.Add("decimal", "a decimal comma needs another delimiter (\";\" or a tab)");
  }
  if ((r.Has("delimiter") || r.Has("decimal")) && req.format != TrackerFileFormat::kCsv) {
    problems.Add(r.Has("delimiter") ? "delimiter" : "decimal", "only with format \"csv\"");
  }
  ReadJointColumns(r, req.format, &req.joints);
  ReadOrientationColumns(r, &req.orientation);
  ReadRowNumbers(r, &req.rows);
  r.RejectUnknown(WireFieldNames<ImportMeasurementsRequest>());
  problems.ThrowIfAny("invalid measurement import");
  return req;
}

std::vector<TrackerPoint> ReadTrackerPoints(const ImportMeasurementsRequest& request, Problems* problems) {
  std::vector<TrackerPoint> points;
  const std::vector<std::string_view> lines = Lines(request.text);
  if (request.format == TrackerFileFormat::kSa) {
    ReadSa(request, lines, &points, problems);
  } else {
    ReadCsv(request, lines, &points, problems);
  }
  if (points.empty() && problems->empty()) problems->Add("text", "no points");
  return points;
}

std::vector<int> DataRowLines(const std::string& text) {
  std::vector<int> data;
  bool header = false;
  const std::vector<std::string_view> lines = Lines(text);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (Trim(std::string(lines[i])).empty()) continue;
    if (header) data.push_back(static_cast<int>(i) + 1);
    header = true;
  }
  return data;
}

DataRowSplit SplitDataRows(const std::vector<int>& data_lines, std::size_t calibration_rows, std::uint64_t seed) {
  Rng rng(seed);
  std::vector<int> drawn = DrawDistinct(data_lines, std::min(calibration_rows, data_lines.size()), &rng);
  std::sort(drawn.begin(), drawn.end());
  DataRowSplit split;
  for (int line : data_lines) {
    (std::binary_search(drawn.begin(), drawn.end(), line) ? split.calibration : split.validation).push_back(line);
  }
  return split;
}

int ConfigurationOfTarget(const std::string& target) {
  std::size_t start = target.size();
  while (start > 0 && std::isdigit(static_cast<unsigned char>(target[start - 1]))) --start;
  if (start == target.size()) return -1;
  // One number only: in "P001_2" or "P7.8" the last number may be a shot or a decimal, not the configuration.
  if (std::any_of(target.begin(), target.begin() + static_cast<std::ptrdiff_t>(start),
                  [](char c) { return std::isdigit(static_cast<unsigned char>(c)); })) {
    return -2;
  }
  const std::string digits = target.substr(start);
  // Leading zeros are padding ("P007"); more than 9 digits is no configuration of any plan.
  const std::size_t first = digits.find_first_not_of('0');
  if (first == std::string::npos || digits.size() - first > 9) return -1;
  return std::stoi(digits.substr(first)) - 1;
}

namespace {

// Every point names one of the campaign's nests, and a campaign without nests has no nest column; false after a
// problem that leaves nothing to check.
bool CheckNests(const ImportMeasurementsRequest& request, const std::vector<TrackerPoint>& points,
                const std::vector<CampaignReflectorWire>& reflectors, Problems* problems) {
  if (reflectors.empty() && !request.columns.reflector.empty()) {
    problems->Add("columns.reflector", "the campaign has no reflector nests");
    return false;
  }
  if (reflectors.empty()) return true;
  std::string known;
  for (const CampaignReflectorWire& r : reflectors) known += (known.empty() ? "" : ", ") + r.id;
  for (const TrackerPoint& p : points) {
    if (p.reflector.empty()) {
      problems->Add("text", LineReason(p.line, "no nest in column " + Shown(request.columns.reflector)));
    } else if (ReflectorIndex(reflectors, p.reflector) < 0) {
      problems->Add("text",
                    LineReason(p.line, "unknown nest " + Shown(p.reflector) + " (the campaign has " + known + ")"));
    }
  }
  return true;
}

}  // namespace

Eigen::Matrix3d EulerToRotation(const std::string& sequence, bool intrinsic, double a, double b, double c) {
  const auto axis = [&](char letter) -> Eigen::Vector3d {
    switch (std::toupper(static_cast<unsigned char>(letter))) {
      case 'X':
        return Eigen::Vector3d::UnitX();
      case 'Y':
        return Eigen::Vector3d::UnitY();
      case 'Z':
        return Eigen::Vector3d::UnitZ();
      default:
        return Eigen::Vector3d::Zero();
    }
  };
  const bool valid =
      sequence.size() == 3 &&
      std::all_of(sequence.begin(), sequence.end(), [&](char l) { return !axis(l).isZero(); }) &&
      std::toupper(static_cast<unsigned char>(sequence[0])) != std::toupper(static_cast<unsigned char>(sequence[1])) &&
      std::toupper(static_cast<unsigned char>(sequence[1])) != std::toupper(static_cast<unsigned char>(sequence[2]));
  if (!valid) {
    throw std::invalid_argument("'" + sequence.substr(0, 8) +
                                "' is not an Euler sequence: three of X, Y, Z with no axis twice in a row (XYZ, "
                                "ZYX, ZXZ, ...)");
  }
  const Eigen::Matrix3d r1 = Eigen::AngleAxisd(a, axis(sequence[0])).toRotationMatrix();
  const Eigen::Matrix3d r2 = Eigen::AngleAxisd(b, axis(sequence[1])).toRotationMatrix();
  const Eigen::Matrix3d r3 = Eigen::AngleAxisd(c, axis(sequence[2])).toRotationMatrix();
  return intrinsic ? Eigen::Matrix3d(r1 * r2 * r3) : Eigen::Matrix3d(r3 * r2 * r1);
}

MeasurementBatchRequest PointsWithJoints(const ImportMeasurementsRequest& request,
                                         const std::vector<TrackerPoint>& points, Problems* problems,
                                         const std::vector<CampaignReflectorWire>& reflectors) {
  MeasurementBatchRequest batch;
  if (!CheckNests(request, points, reflectors, problems) || !problems->empty()) return batch;
  batch.request_id = request.request_id;
  batch.role = request.role;
  batch.measurements.reserve(points.size());
  for (const TrackerPoint& p : points) {
    MeasurementWire w;
    w.joints = p.joints_deg;
    w.pose.position_mm = {p.position_mm.x(), p.position_mm.y(), p.position_mm.z()};
    w.pose.has_orientation = p.has_orientation;
    w.pose.quaternion = p.quaternion;
    w.reflector = p.reflector;
    batch.measurements.push_back(std::move(w));
  }
  return batch;
}

MeasurementBatchRequest MatchToConfigurations(const ImportMeasurementsRequest& request,
                                              const std::vector<TrackerPoint>& points,
                                              const std::vector<std::vector<double>>& configurations,
                                              Problems* problems,
                                              const std::vector<CampaignReflectorWire>& reflectors) {
  MeasurementBatchRequest batch;
  if (!CheckNests(request, points, reflectors, problems)) return batch;
  batch.request_id = request.request_id;
  batch.role = request.role;
  const std::size_t m = configurations.size();
  std::vector<int> configuration(points.size(), -1);
  if (request.match == TrackerFileMatch::kOrder) {
    std::size_t shots = static_cast<std::size_t>(request.shots_per_configuration);
    if (shots == 0 && m > 0 && points.size() % m == 0) shots = points.size() / m;
    if (shots == 0 || points.size() != m * shots) {
      problems->Add("text", std::to_string(points.size()) + " points for the plan's " + std::to_string(m) +
                                " configurations" +
                                (request.shots_per_configuration > 0
                                     ? " at " + std::to_string(shots) + " shots each"
                                     : ": give shots_per_configuration, or as many shots of every configuration") +
                                " (match \"order\")");
      return batch;
    }
    for (std::size_t k = 0; k < points.size(); ++k) configuration[k] = static_cast<int>(k / shots);
  } else {
    for (std::size_t k = 0; k < points.size(); ++k) {
      const int c = ConfigurationOfTarget(points[k].target);
      if (c == -2) {
        problems->Add("text", LineReason(points[k].line, "target " + Shown(points[k].target) +
                                                             " holds more than one number: name a point by its "
                                                             "configuration alone (P007), or match by order"));
      } else if (c < 0) {
        problems->Add("text", LineReason(points[k].line, "target " + Shown(points[k].target) +
                                                             " has no configuration number (its trailing digits, 1..." +
                                                             std::to_string(m) + ")"));
      } else if (static_cast<std::size_t>(c) >= m) {
        problems->Add("text",
                      LineReason(points[k].line, "target " + Shown(points[k].target) + " is configuration " +
                                                     std::to_string(c + 1) + "; the plan has " + std::to_string(m)));
      } else {
        configuration[k] = c;
      }
    }
  }
  if (!problems->empty()) return batch;
  batch.measurements.reserve(points.size());
  for (std::size_t k = 0; k < points.size(); ++k) {
    MeasurementWire w;
    w.joints = configurations[configuration[k]];
    w.pose.position_mm = {points[k].position_mm.x(), points[k].position_mm.y(), points[k].position_mm.z()};
    w.pose.has_orientation = false;
    w.reflector = points[k].reflector;
    batch.measurements.push_back(std::move(w));
  }
  return batch;
}

// The shapes' to_json / from_json, instantiated here once (ROBOCAL_WIRE_DECLARE).
ROBOCAL_WIRE_DEFINE(CsvColumns);
ROBOCAL_WIRE_DEFINE(JointColumns);
ROBOCAL_WIRE_DEFINE(OrientationColumns);
ROBOCAL_WIRE_DEFINE(ImportMeasurementsRequest);

}  // namespace robocal::api
