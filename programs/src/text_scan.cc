// Lines, numbers and number formats shared by the dialects' readers and the writer (text_scan.h).
#include "robocal/programs/text_scan.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>

namespace robocal::programs {
namespace {

bool IsDigit(char c) { return c >= '0' && c <= '9'; }
bool IsWordChar(char c) { return IsDigit(c) || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }
char Lower(char c) { return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c; }

// Decimals of a number's text: the digits after its point, up to an exponent.
int DecimalsOf(std::string_view text) {
  const std::size_t point = text.find('.');
  if (point == std::string_view::npos) return 0;
  int decimals = 0;
  for (std::size_t i = point + 1; i < text.size() && IsDigit(text[i]); ++i) ++decimals;
  return decimals;
}

std::string Fixed(double value, int decimals) {
  // A value as large as 1e300 takes 300 digits: the length snprintf needs, then the digits.
  const int n = std::snprintf(nullptr, 0, "%.*f", decimals, value);
  if (n <= 0) return "0";
  std::string out(static_cast<std::size_t>(n) + 1, '\0');
  std::snprintf(out.data(), out.size(), "%.*f", decimals, value);
  out.resize(static_cast<std::size_t>(n));
  // "-0.000" reads as zero; it is written without its sign.
  if (out.find_first_not_of("-0.") == std::string::npos && !out.empty() && out[0] == '-') out.erase(0, 1);
  return out;
}

}  // namespace

ProgramError::ProgramError(std::string file, int line, int column, const std::string& reason)
    : std::runtime_error(file + ":" + std::to_string(line) + ":" + std::to_string(column) + ": " + reason),
      file_(std::move(file)),
      line_(line),
      column_(column),
      reason_(reason) {}

SourceText::SourceText(const ProgramFile& file, int file_index)
    : name_(file.name), text_(file.text), file_index_(file_index) {
  line_starts_.push_back(0);
  for (std::size_t i = 0; i < text_.size(); ++i) {
    if (text_[i] == '\r') {
      if (i + 1 < text_.size() && text_[i + 1] == '\n') ++i;
      line_starts_.push_back(i + 1);
    } else if (text_[i] == '\n') {
      line_starts_.push_back(i + 1);
    }
  }
}

int SourceText::LineOf(std::size_t offset) const {
  const auto it = std::upper_bound(line_starts_.begin(), line_starts_.end(), offset);
  return static_cast<int>(it - line_starts_.begin());
}

int SourceText::ColumnOf(std::size_t offset) const {
  return static_cast<int>(offset - line_starts_[LineOf(offset) - 1]) + 1;
}

std::string_view SourceText::Line(int line) const {
  const std::size_t begin = line_starts_[line - 1];
  std::size_t end = line < line_count() ? line_starts_[line] : text_.size();
  while (end > begin && (text_[end - 1] == '\n' || text_[end - 1] == '\r')) --end;
  return text_.substr(begin, end - begin);
}

void SourceText::Fail(std::size_t offset, const std::string& reason) const {
  offset = std::min(offset, text_.size());
  throw ProgramError(name_, LineOf(offset), ColumnOf(offset), reason);
}

std::optional<ScannedNumber> ScanNumber(std::string_view text, std::size_t pos) {
  std::size_t i = pos;
  if (i < text.size() && (text[i] == '+' || text[i] == '-')) ++i;
  const std::size_t mantissa = i;
  std::size_t digits = 0;
  while (i < text.size() && IsDigit(text[i])) ++i, ++digits;
  if (i < text.size() && text[i] == '.') {
    ++i;
    while (i < text.size() && IsDigit(text[i])) ++i, ++digits;
  }
  if (digits == 0) return std::nullopt;
  if (i < text.size() && (text[i] == 'e' || text[i] == 'E')) {
    std::size_t j = i + 1;
    if (j < text.size() && (text[j] == '+' || text[j] == '-')) ++j;
    if (j < text.size() && IsDigit(text[j])) {
      while (j < text.size() && IsDigit(text[j])) ++j;
      i = j;
    } else {
      return std::nullopt;
    }
  }
  if (i < text.size() && (IsWordChar(text[i]) || text[i] == '.')) return std::nullopt;
  ScannedNumber number;
  number.offset = pos;
  number.length = i - pos;
  // from_chars takes no '+' and no bare ".5" is a problem for it only without a digit before: it reads both.
  const char* first = text.data() + mantissa;
  const auto [end, ec] = std::from_chars(first, text.data() + i, number.value);
  if (ec != std::errc() || end != text.data() + i || !std::isfinite(number.value)) return std::nullopt;
  if (text[pos] == '-') number.value = -number.value;
  return number;
}

std::size_t SkipBlanks(std::string_view text, std::size_t pos) {
  while (pos < text.size() && (text[pos] == ' ' || text[pos] == '\t')) ++pos;
  return pos;
}

std::size_t SkipWhitespace(std::string_view text, std::size_t pos) {
  while (pos < text.size() && (text[pos] == ' ' || text[pos] == '\t' || text[pos] == '\r' || text[pos] == '\n')) {
    ++pos;
  }
  return pos;
}

bool EqualsNoCase(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (Lower(a[i]) != Lower(b[i])) return false;
  }
  return true;
}

bool WordAt(std::string_view text, std::size_t pos, std::string_view word) {
  if (pos > text.size() || text.size() - pos < word.size()) return false;
  if (!EqualsNoCase(text.substr(pos, word.size()), word)) return false;
  const std::size_t after = pos + word.size();
  return after == text.size() || !IsWordChar(text[after]);
}

std::string LowerCase(std::string_view text) {
  std::string out(text);
  for (char& c : out) c = Lower(c);
  return out;
}

int MinimumDecimals(NumberUnit unit) {
  switch (unit) {
    case NumberUnit::kMm:
      return 3;
    case NumberUnit::kM:
      return 6;
    case NumberUnit::kDeg:
      return 4;
    case NumberUnit::kRad:
      return 6;
    case NumberUnit::kQuaternion:
      return 7;
  }
  return 6;
}

std::string FormatLike(std::string_view original, double value, NumberUnit unit) {
  const int decimals = std::max(DecimalsOf(original), MinimumDecimals(unit));
  std::string written = Fixed(value, decimals);
  const std::optional<ScannedNumber> before = ScanNumber(original, 0);
  if (before && Fixed(before->value, decimals) == written) return std::string(original);
  const bool plus = !original.empty() && original[0] == '+';
  const std::size_t digits = (!original.empty() && (original[0] == '+' || original[0] == '-')) ? 1 : 0;
  const bool bare_point = original.size() > digits && original[digits] == '.';
  if (bare_point) {
    // ".5" style: the leading zero of a magnitude below 1 left out.
    const std::size_t zero = written[0] == '-' ? 1 : 0;
    if (written.size() > zero + 1 && written[zero] == '0' && written[zero + 1] == '.') written.erase(zero, 1);
  }
  if (plus && written[0] != '-') written.insert(written.begin(), '+');
  return written;
}

std::string FormatInserted(double value, NumberUnit unit) { return Fixed(value, MinimumDecimals(unit)); }

}  // namespace robocal::programs
