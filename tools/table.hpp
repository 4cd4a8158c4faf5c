// Plain-text tables for the tools' summaries: columns sized to their widest cell.
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace pmg::tools {

class Table {
 public:
  explicit Table(std::vector<std::string> header) : header_(std::move(header)) {}
  void add(std::vector<std::string> row) { rows_.push_back(std::move(row)); }
  void print(std::ostream& out) const;

 private:
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
};

/// printf-style formatting of one number ("%.3g" and friends); NaN prints as "-".
std::string fmt(const char* format, double value);

/// A count with its noun, singular for one: count_of(1, "thread") is "1 thread", 2 "2 threads".
std::string count_of(long n, const std::string& noun);

}  // namespace pmg::tools
