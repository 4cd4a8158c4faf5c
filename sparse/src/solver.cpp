#include "pmg/sparse/solver.hpp"

#include "pmg/sparse/bcsr.hpp"
#include "pmg/sparse/bin_bcsr.hpp"
#include "pmg/sparse/csr.hpp"
#include "pmg/sparse/params.hpp"
#include "pmg/sparse/vector_ops.hpp"
#include "pmg/sparse/timer.hpp"
#include "pmg/sparse/threads.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

namespace pmg {

std::string TimingBreakdown::to_string() const {
  if (empty()) return "";
  const double n = static_cast<double>(count);
  double total = 0.0;
  for (const auto& p : parts) total += p.second;
  // Per repetition in milliseconds; a set-up or update in seconds.
  const bool once = unit == "set-up" || unit == "update";
  auto time = [n, once](double s) {
    char buf[32];
    if (once) std::snprintf(buf, sizeof buf, "%.3f s", s);
    else std::snprintf(buf, sizeof buf, "%.2f ms", 1e3 * s / n);
    return std::string(buf);
  };
  std::string out = (once ? unit + " " : "one " + unit + " ") + time(total) + ":";
  for (size_t k = 0; k < parts.size(); ++k)
    out += (k ? ", " : " ") + parts[k].first + " " + time(parts[k].second);
  return once ? out : out + " (" + std::to_string(count) + " " + unit + "s)";
}

void DirectSolveParams::visit(ParamVisitor& v) {
  v.real("tol", tol, 0.0, 1.0,
         "relative residual ||b - A x|| / ||b|| the solve must reach (checked; refined while above)");
  v.integer("refinement_steps", refinement_steps, 0, 100,
            "steps of iterative refinement x += M (b - A x) taken while the residual is above tol");
  v.boolean("throw_on_failure", throw_on_failure,
            "a solve that misses tol throws SolveError (false: only its status says so)");
}

void Solver::setup(const LinearOperator& A) {
  std::lock_guard<std::recursive_mutex> lock(lock_);
  if (A.rows() != A.cols())
    throw InputError(name() + ": the operator is " + std::to_string(A.rows()) + "x" +
                     std::to_string(A.cols()) + ", a solver needs a square one");
  if (A.rows() == 0)
    throw InputError(name() + ": the operator is 0x0: there is nothing to solve (are all unknowns fixed?)");
  A_ = nullptr;  // a failed set-up leaves the solver unusable rather than half set up
  n_ = 0;
  setup_impl(A);
  A_ = &A;
  n_ = A.rows();
  if (owned_.get() != &A) owned_.reset();  // a copy from an earlier setup(const CsrView&)
}

void Solver::setup(const CsrView& A) {
  std::lock_guard<std::recursive_mutex> lock(lock_);
  A_ = nullptr;  // a set-up that throws (an invalid view too) leaves the solver not set up
  n_ = 0;
  auto copy = std::make_unique<Csr>(to_csr(A, name() + ": matrix"));
  setup(*copy);
  owned_ = std::move(copy);
}

void Solver::update(const CsrView& A) {
  std::lock_guard<std::recursive_mutex> lock(lock_);
  if (!owned_ || A_ != owned_.get())
    throw InputError(name() + ": update() with a view needs a set-up from a view (setup(const CsrView&))");
  Csr fresh = to_csr(A, name() + ": matrix");
  const CsrPattern &p = fresh.pattern(), &q = owned_->pattern();
  if (p.rows != q.rows || p.cols != q.cols || p.row_ptr != q.row_ptr || p.col_idx != q.col_idx)
    throw InputError(name() + ": update() with a view: the pattern differs from the set-up's (set the solver up again)");
  std::vector<double> before = std::move(owned_->values());
  owned_->values() = std::move(fresh.values());
  try {
    update();
  } catch (...) {
    // Refused values (not positive definite, say): the kept matrix and the set-up as they were.
    owned_->values() = std::move(before);
    try {
      update();
    } catch (...) {
    }
    throw;
  }
}

SolveResult Solver::solve(const double* b, double* x, SolveMonitor* monitor) const {
  std::lock_guard<std::recursive_mutex> lock(lock_);
  const index_t n = system().rows();
  if (!b || !x) throw InputError(name() + ": solve() on arrays: b and x must not be null");
  const Vector bv = Eigen::Map<const Vector>(b, n);
  Vector xv = Eigen::Map<const Vector>(x, n);
  try {
    const SolveResult r = solve(bv, xv, monitor);
    Eigen::Map<Vector>(x, n) = xv;
    return r;
  } catch (const SolveError&) {
    Eigen::Map<Vector>(x, n) = xv;  // the state the solve left, as solve(Vector) leaves it
    throw;
  }
}

void Solver::update() {
  std::lock_guard<std::recursive_mutex> lock(lock_);
  if (!A_) throw Error(name() + ": update() before setup()");
  update_impl();
}

const LinearOperator& Solver::system() const {
  if (!A_) throw Error(name() + ": used before setup()");
  return *A_;
}

namespace {

/// ||A||_inf from the entries where the operator has them (CSR, BCSR); else the lower bound
/// ||A x||_inf / ||x||_inf of the answer x (which only makes the backward error larger).
double infinity_norm(const LinearOperator& A, const Vector& x) {
  double norm = 0.0;
  if (const Csr* S = A.csr_matrix()) {
    const auto& rp = S->pattern().row_ptr;
    for (index_t i = 0; i < S->rows(); ++i) {
      double sum = 0.0;
      for (auto k = rp[i]; k < rp[i + 1]; ++k) sum += std::abs(S->values()[k]);
      norm = std::max(norm, sum);
    }
    return norm;
  }
  if (const Bcsr* B = A.bcsr_matrix()) {  // symmetric or not: rows of 3 x 3 blocks, row-major
    const auto& rp = B->pattern().row_ptr;
    for (index_t I = 0; I < B->pattern().rows; ++I)
      for (int r = 0; r < 3; ++r) {
        double sum = 0.0;
        for (auto k = rp[I]; k < rp[I + 1]; ++k)
          for (int c = 0; c < 3; ++c) sum += std::abs(B->values()[9 * k + 3 * r + c]);
        norm = std::max(norm, sum);
      }
    return norm;
  }
  const double xn = x.lpNorm<Eigen::Infinity>();
  if (!(xn > 0)) return 0.0;
  Vector y(x.size());
  A.apply(x, y);
  return y.lpNorm<Eigen::Infinity>() / xn;
}

}  // namespace

DirectVerdict judge_direct_answer(const LinearOperator& A, const Vector& b, const Vector& x, const Vector& r,
                                  double tol) {
  DirectVerdict v;
  const double bn = ops::norm2(b);
  v.rel_residual = bn > 0 ? ops::norm2(r) / bn : 0.0;
  if (v.rel_residual <= tol) {
    v.ok = true;
    return v;
  }
  const double a = infinity_norm(A, x);
  const double xi = x.lpNorm<Eigen::Infinity>(), bi = b.lpNorm<Eigen::Infinity>();
  v.backward_error = r.lpNorm<Eigen::Infinity>() / (a * xi + bi);
  v.growth = bi > 0 ? a * xi / bi : 0.0;
  v.ok = std::isfinite(v.backward_error) && v.backward_error <= kDirectBackwardError && v.growth <= kDirectGrowth;
  return v;
}

SolveResult Solver::solve(const Vector& b, Vector& x, SolveMonitor* monitor) const {
  std::lock_guard<std::recursive_mutex> lock(lock_);
  const LinearOperator& A = system();
  if (b.size() != A.rows())
    throw InputError(name() + ": right-hand side has " + std::to_string(b.size()) +
                     " entries, the operator has " + std::to_string(A.rows()) + " rows");
  if (x.size() == 0) x = Vector::Zero(b.size());
  if (x.size() != b.size())
    throw InputError(name() + ": initial guess has " + std::to_string(x.size()) + " entries, the "
                     "operator has " + std::to_string(A.rows()) + " rows");
  if (!ops::all_finite(b)) throw InputError(name() + ": right-hand side has NaN/Inf");
  if (!ops::all_finite(x)) throw InputError(name() + ": initial guess has NaN/Inf");
  const ThreadBudget budget;  // the cores free now (pmg/sparse/threads.hpp)
  // Scale invariance over double's range: a right-hand side far from 1 is solved as b / s, s the
  // power of two of its largest entry (exact, barring subnormal entries), so that products such as
  // r^T M^-1 r neither underflow nor overflow; the answer is scaled back.
  const double bmax = b.lpNorm<Eigen::Infinity>();
  if (bmax > 0 && (bmax < kScaleBelow || bmax > kScaleAbove)) {
    const double s = std::ldexp(1.0, std::ilogb(bmax));
    const Vector bs = b / s;
    Vector xs = x / s;
    SolveResult res;
    try {
      res = solve_impl(bs, xs, monitor);
    } catch (SolveError& e) {
      x = xs * s;
      e.result.initial_residual *= s;
      throw;
    }
    x = xs * s;
    res.initial_residual *= s;
    return res;
  }
  return solve_impl(b, x, monitor);
}

SolveResult Solver::solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const {
  const auto t0 = Clock::now();
  const LinearOperator& A = system();
  const DirectSolveParams* check = direct_check();
  if (monitor) monitor->start();
  SolveResult res;
  Vector r, z;
  if (check) {
    x.setZero();  // a direct solve does not use the initial guess: residuals relative to ||b||
    r = b;
  } else {
    A.residual(b, x, r);
  }
  // ops::norm2 neither overflows nor underflows: the check holds at any scale the factorisation
  // itself survives.
  res.initial_residual = ops::norm2(r);
  const double r0 = res.initial_residual;
  if (monitor) monitor->record(0, r0 > 0 ? 1.0 : 0.0);
  double rel = 0.0;
  // One correction; a direct solve then refines while its residual is above tol and falling.
  const int max_corrections = check ? 1 + check->refinement_steps : 1;
  Vector kept;  // a direct solve's x before a refinement step, restored if the step does not help
  for (int k = 0; k < max_corrections && r0 > 0; ++k) {
    apply(r, z);
    if (k > 0) kept = x;
    ops::axpy(1.0, z, x);
    A.residual(b, x, r);
    const double next = ops::norm2(r) / r0;
    if (monitor) monitor->record(k + 1, next);
    if (k > 0 && !(next < rel)) {
      x = kept;  // a refinement step that did not help is undone (a NaN one included)
      A.residual(b, x, r);
      break;
    }
    rel = next;
    res.iterations = k + 1;
    if (!std::isfinite(rel) || !check || rel <= check->tol) break;
  }
  DirectVerdict verdict;
  if (check && std::isfinite(rel)) verdict = judge_direct_answer(A, b, x, r, check->tol);
  res.rel_residual = res.true_rel_residual = rel;
  res.seconds = seconds_since(t0);
  if (!std::isfinite(rel) || !ops::all_finite(x)) {
    res.status = SolveStatus::non_finite;
    res.message = name() + ": the solution has NaN/Inf" +
                  (check ? std::string(": the matrix is singular or not positive definite") : std::string());
    if (check && !check->throw_on_failure) return res;
    throw SolveError(res);
  }
  if (!check) {
    res.status = SolveStatus::completed;  // one correction, no tolerance asked
    return res;
  }
  if (verdict.ok) {
    res.status = SolveStatus::converged;
    return res;
  }
  char text[480];
  std::snprintf(text, sizeof text,
                "%s: the true relative residual ||b - A x|| / ||b|| = %.3g is above the tolerance "
                "%.3g after the solve and %d refinement step%s, and the answer is no rounding-level "
                "solution either (backward error %.3g, growth ||A|| ||x|| / ||b|| = %.3g): the matrix "
                "is singular (are the boundary conditions missing?) or too ill-conditioned for a direct solve",
                name().c_str(), rel, check->tol, res.iterations - 1, res.iterations == 2 ? "" : "s",
                verdict.backward_error, verdict.growth);
  res.status = SolveStatus::stagnated;
  res.message = text;
  if (check->throw_on_failure) throw SolveError(res);
  return res;
}

Vector diagonal_of(const LinearOperator& A, const std::string& who) {
  if (const Csr* c = A.csr_matrix()) return c->diagonal();
  if (const Bcsr* b = A.bcsr_matrix()) return b->diagonal();
  if (const BinBcsr* bin = A.bin_bcsr_matrix()) {
    const std::vector<double>& d = bin->diagonal_blocks();
    Vector out(A.rows());
    for (index_t i = 0; i < A.rows(); ++i) out[i] = d[9 * (i / 3) + 4 * (i % 3)];
    return out;
  }
  if (const DiagonalBlocksSource* mf = A.diagonal_blocks_source()) {
    std::vector<double> d;
    mf->diagonal_blocks(d);
    Vector out(A.rows());
    for (index_t i = 0; i < A.rows(); ++i) out[i] = d[9 * (i / 3) + 4 * (i % 3)];
    return out;
  }
  throw InputError(who + " needs the matrix entries (CSR, BCSR or BIN-BCSR) or a diagonal, which "
                   "this operator does not provide");
}

std::vector<double> diagonal_blocks_of(const LinearOperator& A, const std::string& who) {
  if (const Bcsr* b = A.bcsr_matrix()) return b->diagonal_blocks();
  if (const BinBcsr* bin = A.bin_bcsr_matrix()) return bin->diagonal_blocks();
  if (const Csr* c = A.csr_matrix()) {
    if (c->rows() % 3 != 0)
      throw InputError(who + " needs 3x3 blocks: the size " + std::to_string(c->rows()) +
                       " is not divisible by 3");
    const CsrPattern& p = c->pattern();
    std::vector<double> d(3 * static_cast<size_t>(c->rows()), 0.0);
    for (index_t i = 0; i < p.rows; ++i)
      for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k) {
        const index_t j = p.col_idx[k];
        if (j / 3 == i / 3) d[9 * (i / 3) + 3 * (i % 3) + j % 3] = c->values()[k];
      }
    return d;
  }
  if (const DiagonalBlocksSource* mf = A.diagonal_blocks_source()) {
    std::vector<double> d;
    mf->diagonal_blocks(d);
    return d;
  }
  throw InputError(who + " needs the matrix entries (CSR, BCSR or BIN-BCSR) or diagonal blocks, which "
                   "this operator does not provide");
}

const Bcsr& as_bcsr(const LinearOperator& A, const std::string& who) {
  if (const Bcsr* b = A.bcsr_matrix()) return *b;
  throw InputError(who + " needs a 3x3-block (BCSR) matrix");
}

void ScalarMatrix::setup(const LinearOperator& A, const std::string& who) {
  direct_ = A.csr_matrix();
  block_ = A.bcsr_matrix();
  copy_.reset();
  if (block_) copy_ = std::make_unique<Csr>(block_->to_csr());
  else if (!direct_)
    throw InputError(who + " needs the matrix entries as CSR or BCSR (convert BIN-BCSR or a "
                           "matrix-free operator first)");
}

void ScalarMatrix::refresh() {
  if (block_) block_->copy_values_to(*copy_);
}

const Csr& ScalarMatrix::csr() const {
  if (direct_) return *direct_;
  if (!copy_) throw Error("ScalarMatrix: used before setup()");
  return *copy_;
}

}  // namespace pmg
