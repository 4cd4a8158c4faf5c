// pmg/sparse/convergence.hpp — the stopping logic shared by every iterative method (CG, PCG, MCG,
// stationary multigrid), so all decide identically: relative residual against tol, true-residual
// confirmation, divergence, NaN/Inf, stagnation, iteration limit. For implementers of solvers.
#pragma once

#include "pmg/sparse/krylov.hpp"

#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace pmg::detail {

class ConvergenceTracker {
 public:
  ConvergenceTracker(const char* method, const KrylovParams& p, SolveMonitor* m)
      : method_(method), p_(p), monitor_(m) {
    if (!(p.rel_tol >= 0.0)) throw InputError(std::string(method) + ": rel_tol must be >= 0");
    if (!(p.abs_tol >= 0.0)) throw InputError(std::string(method) + ": abs_tol must be >= 0");
    if (p.max_iterations < 0) throw InputError(std::string(method) + ": max_iterations < 0");
    if (p.check_every < 1) throw InputError(std::string(method) + ": check_every must be >= 1");
    if (monitor_) monitor_->start();
  }

  /// Initial residual norm r0_norm = ||b - A x0|| and b_norm = ||b||; returns false if there is
  /// nothing to do: r0 = 0, or the start meets the request already. The reference of every
  /// relative residual (tol, the monitor, the result) is ||b||, as in SciPy and PETSc, or ||r0||
  /// where b = 0 (or b_norm < 0: not given), so that a warm start at an answer succeeds at once.
  bool start(double r0_norm, double b_norm = -1.0) {
    r0_ = b_norm > 0.0 && std::isfinite(b_norm) ? b_norm : r0_norm;
    result_.initial_residual = r0_norm;
    if (!std::isfinite(r0_norm)) {
      fail(SolveStatus::non_finite, "initial residual norm is not finite: NaN/Inf in A, or ||b - A x0|| beyond "
                                    "double range (squares of entries above about 1e154 overflow: scale the "
                                    "system towards 1)");
      return false;
    }
    const double rel0 = r0_norm > 0 ? r0_norm / r0_ : 0.0;
    // Divergence and stagnation are judged against the start (a guess far off: rel0 > 1).
    start_rel_ = std::max(1.0, rel0);
    reference_ = start_rel_;
    if (monitor_) monitor_->record(0, rel0);
    if (r0_norm == 0.0 || (!p_.fixed_iterations && (r0_norm <= p_.abs_tol || rel0 <= p_.rel_tol))) {
      result_.status = SolveStatus::converged;
      result_.rel_residual = result_.true_rel_residual = rel0;
      done_ = true;
      return false;
    }
    result_.rel_residual = rel0;
    return true;
  }

  double r0() const { return r0_; }
  bool done() const { return done_; }

  /// A curvature or scalar that must be positive (p^T A p, r^T z).
  bool check_positive(double value, const char* what, int it) {
    if (!std::isfinite(value)) {
      fail(SolveStatus::non_finite, std::string(what) + " is not finite at iteration " + std::to_string(it) +
                                        ": NaN/Inf in the operator or preconditioner, or an overflow of double "
                                        "range (scale the system towards 1)");
      return false;
    }
    if (value > 0.0) return true;
    // r^T M^{-1} r indicts the preconditioner (a cycle's smoother or transfers), a curvature
    // p^T A p the operator. Zero or below the smallest normal double: singular on this direction,
    // or products of tiny values that underflowed; both are named.
    const bool preconditioner = std::string(what).find("M^{-1}") != std::string::npos;
    const std::string at = std::string(what) + " = " + fmt(value) + " at iteration " + std::to_string(it) + ": ";
    if (value > -std::numeric_limits<double>::min())
      fail(SolveStatus::breakdown, at + (preconditioner ? "the preconditioner" : "the operator") +
                                       " is singular on this direction, or the values underflowed (values far "
                                       "below 1 in A and b: scale them towards 1)");
    else
      fail(SolveStatus::breakdown,
           at + (preconditioner ? "the preconditioner is not symmetric positive definite (a multigrid "
                                  "cycle: check its smoother settings and prolongations)"
                                : "the operator is not symmetric positive definite"));
    return false;
    return true;
  }

  /// CG-type methods: the decrease α rᵀz of the energy functional in this iteration (call before
  /// after_iteration). A flat residual is then called stagnation only if the energy norm of the
  /// error is flat too.
  void add_energy_decrease(double d) {
    energy_.push_back((energy_.empty() ? 0.0 : energy_.back()) + d);
  }

  /// Records iteration it with recursive residual norm r_norm. Returns true when the recursive
  /// residual meets the tolerance (the caller then checks the true residual).
  bool after_iteration(int it, double r_norm) {
    const double rel = r_norm / r0_;
    result_.iterations = it;
    result_.rel_residual = rel;
    if (monitor_) monitor_->record(it, rel);
    if (!std::isfinite(rel)) {
      fail(SolveStatus::non_finite, "residual became NaN/Inf at iteration " + std::to_string(it));
      return false;
    }
    if (rel > p_.divergence_limit * start_rel_) {
      fail(SolveStatus::diverged, "relative residual " + fmt(rel) + " exceeds the divergence limit " +
                                      fmt(p_.divergence_limit) + " at iteration " +
                                      std::to_string(it));
      return false;
    }
    const int W = p_.stagnation_window;
    if (rel < p_.stagnation_factor * reference_) {
      reference_ = rel;
      last_progress_ = it;
    } else if (W > 0 && it - last_progress_ >= W && !energy_progress(W) && rel > p_.rel_tol) {
      // (Below the tolerance the residual has no progress left to make: a method that tests it only
      // every check_every iterations is waiting for its test, not stagnating.)
      fail(SolveStatus::stagnated, "no progress in " + std::to_string(W) +
                                       " iterations (relative residual " + fmt(rel) +
                                       (energy_.empty() ? "" : ", energy norm of the error flat") +
                                       ")");
      return false;
    }
    if (p_.fixed_iterations) {
      // Exactly solved, or so nearly that ‖r‖² and the curvatures pᵀAp underflow (‖r‖ below
      // √DBL_MIN ≈ 1.5e-154): another iteration would divide by zero, so the run ends here as
      // converged instead of reporting a breakdown of an SPD system.
      if (rel == 0.0 || r_norm < std::sqrt(std::numeric_limits<double>::min())) finish_converged(rel);
      else if (it >= p_.max_iterations) {
        result_.status = SolveStatus::completed;
        result_.true_rel_residual = std::numeric_limits<double>::quiet_NaN();
        done_ = true;
      }
      return false;
    }
    if (rel <= p_.rel_tol || r_norm <= p_.abs_tol) return true;
    if (it >= p_.max_iterations)
      fail(SolveStatus::iteration_limit, "relative residual " + fmt(rel) + " after " +
                                             std::to_string(it) + " iterations, tolerance " +
                                             fmt(p_.rel_tol));
    return false;
  }

  /// Verdict on the true residual after the recursive one converged: true = converged (done);
  /// false = the caller replaces its residual by the true one and goes on (at most twice).
  bool accept_true_residual(double true_norm) {
    const double rel = true_norm / r0_;
    // The recursive and the true residual differ by rounding; allow that much above tol.
    if (rel <= 2.0 * p_.rel_tol || true_norm <= 2.0 * p_.abs_tol) {
      finish_converged(rel);
      return true;
    }
    if (++replacements_ > 2) {
      fail(SolveStatus::stagnated, "true relative residual " + fmt(rel) + " stays above the tolerance " +
                                       fmt(p_.rel_tol) + " (limit of attainable accuracy; from a start near "
                                       "the solution, rhs_floor accepts ||r|| <= rhs_floor ||b||)");
      return true;
    }
    return false;
  }

  /// Whether the energy functional still fell by more than 1e-8 of its total decrease over the last
  /// W iterations (no data: false).
  bool energy_progress(int W) const {
    const size_t k = energy_.size();
    if (k <= static_cast<size_t>(W)) return !energy_.empty();
    return energy_[k - 1] - energy_[k - 1 - W] > 1e-8 * energy_[k - 1];
  }

  void fail(SolveStatus s, const std::string& why) {
    result_.status = s;
    result_.message = std::string(method_) + ": " + why;
    done_ = true;
  }

  /// Final result; throws SolveError on failure if so configured. true_norm may be NaN (unknown).
  SolveResult finish(double true_norm) {
    if (!done_) fail(SolveStatus::iteration_limit, "stopped before convergence");
    // A curvature that vanishes because the iterate already solves the system to rounding (a
    // method testing its residual only every check_every iterations gets there) is not a
    // breakdown: the true residual decides.
    if (result_.status == SolveStatus::breakdown && !p_.fixed_iterations && std::isfinite(true_norm) &&
        (true_norm <= p_.rel_tol * r0_ || true_norm <= p_.abs_tol)) {
      result_.message.clear();
      finish_converged(true_norm / r0_);
    }
    if (!result_.ok() && std::isfinite(true_norm)) result_.true_rel_residual = true_norm / r0_;
    if (monitor_) result_.seconds = monitor_->elapsed();
    if (!result_.ok() && p_.throw_on_failure) throw SolveError(result_);
    return result_;
  }

  const SolveResult& result() const { return result_; }

 private:
  void finish_converged(double true_rel) {
    result_.status = SolveStatus::converged;
    result_.true_rel_residual = true_rel;
    done_ = true;
  }
  static std::string fmt(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3e", v);
    return buf;
  }

  const char* method_;
  const KrylovParams p_;  // a copy: callers pass temporaries (with_rhs_floor)
  SolveMonitor* monitor_;
  SolveResult result_;
  double r0_ = 0.0;
  double reference_ = 1.0;
  double start_rel_ = 1.0;  // max(1, ||r0|| / reference norm)
  int last_progress_ = 0;
  int replacements_ = 0;
  std::vector<double> energy_;
  bool done_ = false;
};

}  // namespace pmg::detail
