#include "pmg/sparse/text_reader.hpp"

#include "pmg/sparse/file_io.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <istream>
#include <limits>
#include <sstream>

namespace pmg {

TextReader::TextReader(std::istream& in, std::string name, char comment)
    : in_(in), name_(std::move(name)), comment_(comment) {
  // The size of a seekable input bounds every count read from it (remaining_bytes()).
  const auto here = in_.tellg();
  if (here >= 0 && in_.seekg(0, std::ios::end)) {
    const auto end = in_.tellg();
    if (end >= 0) size_ = static_cast<long long>(end);
  }
  in_.clear();
  if (here >= 0) in_.seekg(here);
}

bool TextReader::next_line(std::string& line) {
  ++line_no_;
  line.clear();
  // std::getline would grow one string without bound on an input without line breaks (/dev/zero):
  // characters are taken one at a time from the stream's buffer and a line is refused past
  // kMaxLineLength.
  std::streambuf* buf = in_.rdbuf();
  if (!buf || !in_.good()) {
    in_.setstate(std::ios::failbit);
    return false;
  }
  for (bool any = false;; any = true) {
    int c;
    try {
      c = buf->sbumpc();
    } catch (const std::exception&) {  // a file buffer's read error (EIO, a folder)
      in_.setstate(std::ios::badbit);
      fail("read error");
    }
    if (c == std::char_traits<char>::eof()) {
      in_.setstate(any ? std::ios::eofbit : std::ios::eofbit | std::ios::failbit);
      if (!any) return false;
      break;
    }
    if (c == '\n') break;
    if (line.size() == kMaxLineLength)
      fail("a line longer than " + std::to_string(kMaxLineLength) + " characters: not a text file of this format");
    line.push_back(static_cast<char>(c));
  }
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return true;
}

namespace {
// Every character isspace() accepts in the C locale: a line of only \v or \f is blank, as it is to
// the tokenizer.
constexpr const char* kBlank = " \t\r\n\v\f";
}  // namespace

bool TextReader::next_data_line(std::string& line) {
  while (next_line(line)) {
    const auto first = line.find_first_not_of(kBlank);
    if (first == std::string::npos || line[first] == comment_) continue;
    return true;
  }
  return false;
}

std::vector<std::string> TextReader::next_tokens(const char* what) {
  std::string line;
  if (!next_data_line(line)) fail(std::string("file ends where ") + what + " was expected");
  auto tokens = split_tokens(line);
  if (tokens.empty()) fail(std::string("expected ") + what + ", found a blank line");
  return tokens;
}

void TextReader::fail(const std::string& what) const {
  throw InputError(name_ + ":" + std::to_string(line_no_) + ": " + what);
}

std::string printable(const std::string& tok) {
  std::string out;
  for (unsigned char c : tok.substr(0, 64)) {
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    }
  }
  if (tok.size() > 64) out += "...";
  return out;
}

long long TextReader::to_integer(const std::string& tok, const char* what) const {
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(tok.c_str(), &end, 10);
  // The whole token must be the number: strtoll stops at an embedded NUL, the token does not.
  if (end == tok.c_str() || end != tok.c_str() + tok.size() || errno == ERANGE)
    fail(std::string("expected an integer ") + what + ", found '" + printable(tok) + "'");
  return v;
}

long long TextReader::to_count(const std::string& tok, const char* what, long long limit,
                               const char* limit_is) const {
  const long long n = to_integer(tok, what);
  if (n < 0) fail(std::string("negative ") + what + " " + tok);
  if (n > limit)
    fail(std::string(what) + " " + tok + " is more than the " + std::to_string(limit) + " " + limit_is +
         " (a truncated file, or a damaged count)");
  return n;
}

long long TextReader::remaining_bytes() const {
  // An unseekable input (a pipe, /dev/zero) cannot hold more than this machine can store.
  if (size_ < 0) return static_cast<long long>(std::min<double>(static_cast<double>(physical_memory_bytes()), 9e18));
  const auto pos = in_.tellg();
  if (pos < 0) return 0;
  return std::max<long long>(0, size_ - static_cast<long long>(pos));
}

double TextReader::to_real(const std::string& tok, const char* what) const {
  char* end = nullptr;
  const double v = std::strtod(tok.c_str(), &end);
  if (end == tok.c_str() || end != tok.c_str() + tok.size())
    fail(std::string("expected ") + what + ", found '" + printable(tok) + "'");
  if (!std::isfinite(v)) fail("value '" + printable(tok) + "' is not finite");
  return v;
}

std::vector<std::string> split_tokens(const std::string& line) {
  std::istringstream ss(line);
  std::vector<std::string> out;
  for (std::string tok; ss >> tok;) out.push_back(tok);
  return out;
}

}  // namespace pmg
