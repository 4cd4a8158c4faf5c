// pmg/sparse/text_reader.hpp — line-oriented text parsing that knows where it is, so every error
// reads "file:line: what is wrong". Shared by the Matrix Market and mesh readers.
#pragma once

#include "pmg/sparse/types.hpp"

#include <cstddef>
#include <iosfwd>
#include <string>
#include <vector>

namespace pmg {

/// `text` as an error message shows it: its first 64 bytes, printable ASCII as is and any other
/// byte (control, NUL, non-ASCII) as \\xNN, "..." after a longer text.
std::string printable(const std::string& text);

/// Reads a text stream line by line and throws errors that name the file and the line (see the
/// file comment). Holds a reference to the stream, which must outlive it.
class TextReader {
 public:
  /// The longest line accepted (1 MiB): longer is an error naming the line, so that an input
  /// without line breaks is refused after reading that much.
  static constexpr std::size_t kMaxLineLength = std::size_t(1) << 20;

  /// comment: lines whose first non-blank character is this are skipped by next_data_line().
  TextReader(std::istream& in, std::string name, char comment = '#');

  /// Next line (the line counter then names it, or the missing line at end of file).
  bool next_line(std::string& line);
  /// Next line that is neither blank nor a comment.
  bool next_data_line(std::string& line);
  /// Next data line split on white space (never empty); fails with `what` at end of file.
  std::vector<std::string> next_tokens(const char* what);

  /// Throws InputError "name:line: what" for the current line.
  [[noreturn]] void fail(const std::string& what) const;
  /// The whole token as an integer (an embedded NUL or trailing junk is an error).
  long long to_integer(const std::string& token, const char* what) const;
  /// A count read from the file: an integer in [0, limit]. Readers pass as limit what the rest of
  /// the input could hold (remaining_bytes() / the fewest bytes an item takes), so that nothing is
  /// allocated for a declared size the data does not back.
  /// `limit_is` says what sets the limit in the message.
  long long to_count(const std::string& token, const char* what, long long limit,
                     const char* limit_is = "the rest of the file could hold") const;
  /// Bytes left after the current position (for an unseekable stream: this machine's memory).
  long long remaining_bytes() const;
  /// Whether the input's size is known (a file, not a pipe): only then does remaining_bytes()
  /// back a declared count, so a reader reserves for it in full.
  bool seekable() const { return size_ >= 0; }
  /// A finite real number.
  double to_real(const std::string& token, const char* what = "a real value") const;

  /// The input's name as messages give it (usually the file path).
  const std::string& name() const { return name_; }
  /// Number of the current line, 1-based: the line last read, or at end of file the missing one
  /// (0 before the first read).
  long line_number() const { return line_no_; }

 private:
  std::istream& in_;
  std::string name_;
  char comment_;
  long line_no_ = 0;
  long long size_ = -1;  ///< of a seekable input, else -1
};

/// The whitespace-separated tokens of a line (every isspace character separates, vertical tab
/// and form feed too).
std::vector<std::string> split_tokens(const std::string& line);

}  // namespace pmg
