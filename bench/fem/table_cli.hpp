// The command line of the FEM accuracy tables (mixed_accuracy, cook_membrane): a comma-separated
// list of numbers from an option ("2,4,8"), and main() reporting any error on one line.
#pragma once

#include <cstdio>
#include <exception>
#include <string>
#include <vector>

/// The numbers of a comma-separated list; std::stod's exceptions name a bad entry.
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

/// run(argc, argv)'s exit code, or 1 after printing "error: ..." for an exception it throws.
template <class Run>
int run_reporting_errors(const Run& run, int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
