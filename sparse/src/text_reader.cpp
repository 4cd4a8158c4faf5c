#include "pmg/sparse/text_reader.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <istream>
#include <sstream>

namespace pmg {

TextReader::TextReader(std::istream& in, std::string name, char comment)
    : in_(in), name_(std::move(name)), comment_(comment) {}

bool TextReader::next_line(std::string& line) {
  ++line_no_;
  if (!std::getline(in_, line)) return false;
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return true;
}

bool TextReader::next_data_line(std::string& line) {
  while (next_line(line)) {
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == comment_) continue;
    return true;
  }
  return false;
}

std::vector<std::string> TextReader::next_tokens(const char* what) {
  std::string line;
  if (!next_data_line(line)) fail(std::string("file ends where ") + what + " was expected");
  return split_tokens(line);
}

void TextReader::fail(const std::string& what) const {
  throw InputError(name_ + ":" + std::to_string(line_no_) + ": " + what);
}

long long TextReader::to_integer(const std::string& tok, const char* what) const {
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(tok.c_str(), &end, 10);
  if (end == tok.c_str() || *end != '\0' || errno == ERANGE)
    fail(std::string("expected an integer ") + what + ", found '" + tok + "'");
  return v;
}

double TextReader::to_real(const std::string& tok, const char* what) const {
  char* end = nullptr;
  const double v = std::strtod(tok.c_str(), &end);
  if (end == tok.c_str() || *end != '\0')
    fail(std::string("expected ") + what + ", found '" + tok + "'");
  if (!std::isfinite(v)) fail("value '" + tok + "' is not finite");
  return v;
}

std::vector<std::string> split_tokens(const std::string& line) {
  std::istringstream ss(line);
  std::vector<std::string> out;
  for (std::string tok; ss >> tok;) out.push_back(tok);
  return out;
}

}  // namespace pmg
