#include "compare_plot.hpp"

#include "commands.hpp"
#include "process.hpp"

#include "pmg/sparse/file_io.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <sstream>

namespace pmg::tools {

namespace {

/// One CSV field: quoted (quotes doubled) where it holds a comma, a quote or a line break.
std::string csv_field(const std::string& text) {
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

}  // namespace

std::string summary_csv(const std::vector<study::SolverRun>& runs) {
  auto number = [](double v) {
    if (!std::isfinite(v)) return std::string();
    std::ostringstream out;
    out.precision(10);
    out << v;
    return out.str();
  };
  std::string csv = "solver,seconds,error,rel_residual,iterations\n";
  for (const auto& r : runs)
    csv += csv_field(r.name) + "," + (r.ok() ? number(r.setup_s + r.solve_s) : std::string()) + "," +
           number(r.rel_error) + "," + number(r.rel_residual) + "," + std::to_string(r.iterations) + "\n";
  return csv;
}

void plot(const std::vector<study::SolverRun>& runs, const std::string& history, const std::string& png,
          const std::string& title) {
  const std::string script = find_data_file("plot_history.py");
  const ScratchDir scratch(std::filesystem::temp_directory_path() / ("pmg_plot_" + std::to_string(::getpid())));
  const std::string data = history.empty() ? (scratch.path / "history.csv").string() : history;
  if (history.empty()) study::write_history(data, runs);
  const std::string summary = (scratch.path / "summary.csv").string();
  write_file_atomically(summary, summary_csv(runs));
  const int rc = run_program({"/usr/bin/python3", script, data, png, title, "--summary", summary});
  if (!WIFEXITED(rc) || WEXITSTATUS(rc) != 0)
    throw Error("plotting failed (needs /usr/bin/python3 with matplotlib: apt install python3-matplotlib)");
  std::cout << "plot: " << png << "\n";
}

}  // namespace pmg::tools
