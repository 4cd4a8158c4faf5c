// Validators for pmg's numeric options: every value is checked when the command line is read,
// before any work, and the message names the option. CLI11's own PositiveNumber and Range let NaN
// through (every comparison with NaN is false); these do not.
#pragma once

#include <CLI/CLI.hpp>
#include <omp.h>

#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

namespace pmg::tools {

namespace detail {
inline bool read_double(const std::string& text, double& v) {
  char* end = nullptr;
  v = std::strtod(text.c_str(), &end);
  return end != text.c_str() && *end == '\0';
}
}  // namespace detail

/// A finite number in [lo, hi] (either bound open when the flag says so).
inline CLI::Validator FiniteRange(double lo, double hi, bool open_lo = false, bool open_hi = false) {
  const std::string desc = std::string(open_lo ? "(" : "[") + CLI::detail::to_string(lo) + " - " +
                           CLI::detail::to_string(hi) + (open_hi ? ")" : "]");
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        double v;
        if (!detail::read_double(text, v)) return "'" + text + "' is not a number";
        if (!std::isfinite(v)) return "'" + text + "' is not a finite number";
        if (v < lo || v > hi || (open_lo && v == lo) || (open_hi && v == hi))
          return "'" + text + "' is outside " + desc;
        return {};
      },
      "FINITE in " + desc);
}

/// A finite number > 0 (a time, a length, a modulus).
inline CLI::Validator FinitePositive() { return FiniteRange(0.0, 1e300, true, false); }
/// A finite number >= 0.
inline CLI::Validator FiniteNonNegative() { return FiniteRange(0.0, 1e300); }
/// A relative tolerance: in (0, 1).
inline CLI::Validator Tolerance() { return FiniteRange(0.0, 1.0, true, true); }
/// An OpenMP thread count: 1 to 1024 (omit the option for OMP_NUM_THREADS).
inline CLI::Validator ThreadCount() { return CLI::Range(1, 1024); }

/// --threads N, the one definition for every subcommand that runs solves: the most OpenMP
/// threads the run uses, set as the command line is read (before the subcommand's work; under
/// mpirun it overrides the per-rank share). Omitted: OMP_NUM_THREADS.
inline CLI::Option* add_threads_option(CLI::App* sub) {
  return sub
      ->add_option_function<int>(
          "--threads", [](const int& n) { omp_set_num_threads(n); }, "OpenMP threads (default: OMP_NUM_THREADS)")
      ->check(ThreadCount());
}

/// --allow tangled,cracked: mesh defects a user accepts on purpose (check_mesh refuses them).
inline CLI::Option* add_allow_option(CLI::App* sub, std::vector<std::string>& allow) {
  return sub
      ->add_option("--allow", allow,
                   "accept a mesh file with these defects on purpose: tangled (overlapping elements), "
                   "cracked (coincident vertices, non-manifold boundary)")
      ->delimiter(',')
      ->check(CLI::IsMember({"tangled", "cracked"}));
}

}  // namespace pmg::tools
