// A comma-separated list of numbers from a command-line option ("2,4,8"), for the FEM accuracy
// tables (mixed_accuracy, cook_membrane). std::stod's exceptions name a bad entry.
#pragma once

#include <string>
#include <vector>

inline std::vector<double> parse_list(const char* text) {
  std::vector<double> v;
  const std::string s(text);
  size_t start = 0;
  while (start <= s.size()) {
    const size_t end = s.find(',', start);
    v.push_back(std::stod(s.substr(start, end - start)));
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return v;
}
