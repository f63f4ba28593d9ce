// What every dialect's reader and the writer share: lines and columns of a file, numbers with their byte spans,
// words compared without case, and the number format a rewritten value keeps. Written by hand because the
// controllers' languages have no parser a library offers, and a target's bytes must be found exactly where
// they are.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "robocal/programs/program.h"

namespace robocal::programs {

/// A file's text with its line starts, for line and column of a byte offset and for errors that name them.
/// Lines end with "\n", "\r\n" or a lone "\r".
class SourceText {
 public:
  SourceText(const ProgramFile& file, int file_index);

  const std::string& name() const { return name_; }
  std::string_view text() const { return text_; }
  int file_index() const { return file_index_; }
  /// 1-based line and byte column of `offset` (offset <= size).
  int LineOf(std::size_t offset) const;
  int ColumnOf(std::size_t offset) const;
  int line_count() const { return static_cast<int>(line_starts_.size()); }
  /// The bytes of a 1-based line without its line end.
  std::string_view Line(int line) const;
  /// The offset of a 1-based line's first byte.
  std::size_t LineStart(int line) const { return line_starts_[line - 1]; }
  /// Throws ProgramError at `offset`.
  [[noreturn]] void Fail(std::size_t offset, const std::string& reason) const;

 private:
  std::string name_;
  std::string_view text_;
  int file_index_ = 0;
  std::vector<std::size_t> line_starts_;
};

/// A number as written: its value and its span in the text (offset, length).
struct ScannedNumber {
  double value = 0.0;
  std::size_t offset = 0;
  std::size_t length = 0;
};

/// The number starting exactly at `pos`: [+-] digits [. digits] [(e|E) [+-] digits], or [+-] . digits; nullopt if
/// none starts there or it does not end at a character that can end a number (a letter or digit glued to it,
/// "1.2.3", "12abc"). Never throws.
std::optional<ScannedNumber> ScanNumber(std::string_view text, std::size_t pos);

/// The offset of the first byte at or after `pos` that is not a space or tab (text.size() if none).
std::size_t SkipBlanks(std::string_view text, std::size_t pos);
/// The same, skipping line ends too.
std::size_t SkipWhitespace(std::string_view text, std::size_t pos);

/// ASCII case-insensitive equality.
bool EqualsNoCase(std::string_view a, std::string_view b);
/// `text` at `pos` starts with `word` (case-insensitive) and the byte after it is not a letter, digit or '_'.
bool WordAt(std::string_view text, std::size_t pos, std::string_view word);
/// Lower-case copy (ASCII).
std::string LowerCase(std::string_view text);

/// The unit of a rewritten number, which sets the fewest decimals it is written with: mm 3, m 6, deg 4, rad 6
/// (1e-6 rad is 5.7e-5 deg), a quaternion's component 7.
enum class NumberUnit { kMm, kM, kDeg, kRad, kQuaternion };
int MinimumDecimals(NumberUnit unit);

/// `value` written in the format of `original` (the number's text as it was): the same sign style (a '+' kept),
/// the same leading zero style (".5" stays without its 0), and max(original's decimals, the unit's minimum)
/// decimals, in fixed notation. When `value` written that way reads back as the value `original` reads at that
/// precision (the change does not show at the written precision), `original` is returned unchanged: a target
/// that compensation leaves where it was stays byte for byte.
std::string FormatLike(std::string_view original, double value, NumberUnit unit);
/// A number of an inserted target: fixed notation with the unit's minimum decimals.
std::string FormatInserted(double value, NumberUnit unit);

}  // namespace robocal::programs
