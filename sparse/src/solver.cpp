#include "pmg/sparse/solver.hpp"

#include "pmg/sparse/bin_bcsr.hpp"
#include "pmg/sparse/vector_ops.hpp"
#include "pmg/sparse/timer.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>

namespace pmg {

std::string TimingBreakdown::to_string() const {
  if (empty()) return "";
  const double n = static_cast<double>(count);
  double total = 0.0;
  for (const auto& p : parts) total += p.second;
  auto ms = [n](double s) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2f ms", 1e3 * s / n);
    return std::string(buf);
  };
  std::string out = "one " + unit + " " + ms(total) + ":";
  for (size_t k = 0; k < parts.size(); ++k)
    out += (k ? ", " : " ") + parts[k].first + " " + ms(parts[k].second);
  return out + " (" + std::to_string(count) + " " + unit + "s)";
}

void Solver::setup(const LinearOperator& A) {
  if (A.rows() != A.cols())
    throw InputError(name() + ": the operator is " + std::to_string(A.rows()) + "x" +
                     std::to_string(A.cols()) + ", a solver needs a square one");
  A_ = nullptr;  // a failed set-up leaves the solver unusable rather than half set up
  n_ = 0;
  setup_impl(A);
  A_ = &A;
  n_ = A.rows();
}

void Solver::update() {
  if (!A_) throw Error(name() + ": update() before setup()");
  update_impl();
}

const LinearOperator& Solver::system() const {
  if (!A_) throw Error(name() + ": used before setup()");
  return *A_;
}

SolveResult Solver::solve(const Vector& b, Vector& x, SolveMonitor* monitor) const {
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
  return solve_impl(b, x, monitor);
}

SolveResult Solver::solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const {
  const auto t0 = Clock::now();
  const LinearOperator& A = system();
  if (monitor) monitor->start();
  Vector r, z;
  A.residual(b, x, r);
  SolveResult res;
  res.initial_residual = ops::norm2(r);
  if (monitor) monitor->record(0, res.initial_residual > 0 ? 1.0 : 0.0);
  if (res.initial_residual > 0) {
    apply(r, z);
    ops::axpy(1.0, z, x);
    A.residual(b, x, r);
  }
  const double rn = ops::norm2(r);
  res.iterations = 1;
  res.rel_residual = res.true_rel_residual =
      res.initial_residual > 0 ? rn / res.initial_residual : 0.0;
  if (monitor) monitor->record(1, res.rel_residual);
  res.status = std::isfinite(rn) ? SolveStatus::converged : SolveStatus::non_finite;
  if (!std::isfinite(rn)) {
    res.message = name() + ": the solution has NaN/Inf";
    throw SolveError(res);
  }
  res.seconds = seconds_since(t0);
  return res;
}

Vector diagonal_of(const LinearOperator& A, const std::string& who) {
  if (const auto* c = dynamic_cast<const Csr*>(&A)) return c->diagonal();
  if (const auto* b = dynamic_cast<const Bcsr*>(&A)) return b->diagonal();
  if (const auto* bin = dynamic_cast<const BinBcsr*>(&A)) {
    const std::vector<double>& d = bin->diagonal_blocks();
    Vector out(A.rows());
    for (index_t i = 0; i < A.rows(); ++i) out[i] = d[9 * (i / 3) + 4 * (i % 3)];
    return out;
  }
  if (const auto* mf = dynamic_cast<const DiagonalBlocksSource*>(&A)) {
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
  if (const auto* b = dynamic_cast<const Bcsr*>(&A)) return b->diagonal_blocks();
  if (const auto* bin = dynamic_cast<const BinBcsr*>(&A)) return bin->diagonal_blocks();
  if (const auto* c = dynamic_cast<const Csr*>(&A)) {
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
  if (const auto* mf = dynamic_cast<const DiagonalBlocksSource*>(&A)) {
    std::vector<double> d;
    mf->diagonal_blocks(d);
    return d;
  }
  throw InputError(who + " needs the matrix entries (CSR, BCSR or BIN-BCSR) or diagonal blocks, which "
                   "this operator does not provide");
}

const Bcsr& as_bcsr(const LinearOperator& A, const std::string& who) {
  if (const auto* b = dynamic_cast<const Bcsr*>(&A)) return *b;
  throw InputError(who + " needs a 3x3-block (BCSR) matrix");
}

void ScalarMatrix::setup(const LinearOperator& A, const std::string& who) {
  direct_ = dynamic_cast<const Csr*>(&A);
  block_ = dynamic_cast<const Bcsr*>(&A);
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
