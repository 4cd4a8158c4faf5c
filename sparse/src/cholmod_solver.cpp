#include "pmg/sparse/cholmod_solver.hpp"

#include <cholmod.h>

#include <chrono>
#include <cmath>
#include <string>

namespace pmg {

// CHOLMOD's long-integer interface (cholmod_l_*): our row pointers are 64-bit. The column indices
// are widened once in analyze(); factorize() points CHOLMOD at the caller's values directly.
struct CholmodSolver::Impl {
  cholmod_common common;
  cholmod_factor* factor = nullptr;
  std::shared_ptr<const CsrPattern> pattern;
  std::vector<SuiteSparse_long> p, i;
  bool factorized = false;

  Impl() {
    cholmod_l_start(&common);
    common.supernodal = CHOLMOD_SUPERNODAL;
    common.print = 0;  // errors are reported by exceptions, not printed by CHOLMOD
  }
  ~Impl() {
    if (factor) cholmod_l_free_factor(&factor, &common);
    cholmod_l_finish(&common);
  }
  // A symmetric matrix in CSR is its own CSC; stype = 1 reads the upper triangle of that view.
  cholmod_sparse view(const double* values) {
    cholmod_sparse A{};
    A.nrow = A.ncol = p.size() - 1;
    A.nzmax = i.size();
    A.p = p.data();
    A.i = i.data();
    A.x = const_cast<double*>(values);
    A.stype = 1;
    A.itype = CHOLMOD_LONG;
    A.xtype = values ? CHOLMOD_REAL : CHOLMOD_PATTERN;
    A.dtype = CHOLMOD_DOUBLE;
    A.sorted = 1;
    A.packed = 1;
    return A;
  }
};

CholmodSolver::CholmodSolver() : impl_(std::make_unique<Impl>()) {}
CholmodSolver::~CholmodSolver() = default;

void CholmodSolver::analyze(const Csr& A) {
  if (A.rows() != A.cols()) throw InputError("CHOLMOD: matrix is not square");
  Impl& d = *impl_;
  if (d.factor) cholmod_l_free_factor(&d.factor, &d.common);
  d.factorized = false;
  d.pattern = A.shared_pattern();
  const CsrPattern& pat = A.pattern();
  d.p.assign(pat.row_ptr.begin(), pat.row_ptr.end());
  d.i.assign(pat.col_idx.begin(), pat.col_idx.end());
  n_ = A.rows();
  cholmod_sparse view = d.view(nullptr);
  d.factor = cholmod_l_analyze(&view, &d.common);
  if (!d.factor || d.common.status < CHOLMOD_OK)
    throw Error("CHOLMOD: symbolic analysis failed (status " + std::to_string(d.common.status) + ")");
}

void CholmodSolver::factorize(const Csr& A) {
  Impl& d = *impl_;
  if (!d.factor) throw Error("CHOLMOD: factorize() before analyze()");
  if (A.shared_pattern() != d.pattern && (A.pattern().row_ptr != d.pattern->row_ptr ||
                                          A.pattern().col_idx != d.pattern->col_idx))
    throw InputError("CHOLMOD: factorize() with a pattern other than the analysed one");
  for (double v : A.values())
    if (!std::isfinite(v)) throw InputError("CHOLMOD: matrix has NaN/Inf entries");
  d.factorized = false;
  cholmod_sparse view = d.view(A.values().data());
  cholmod_l_factorize(&view, d.factor, &d.common);
  if (d.common.status == CHOLMOD_NOT_POSDEF || d.factor->minor < d.factor->n)
    throw Error("CHOLMOD: matrix is not positive definite (factorisation fails at column " +
                std::to_string(d.factor->minor) + " of " + std::to_string(d.factor->n) + ")");
  if (d.common.status < CHOLMOD_OK)
    throw Error("CHOLMOD: numeric factorisation failed (status " + std::to_string(d.common.status) +
                ")");
  d.factorized = true;
}

double CholmodSolver::factor_nnz() const {
  return impl_->factorized ? impl_->common.lnz : 0.0;
}

void CholmodSolver::setup_impl(const LinearOperator& A) {
  scalar_.setup(A, "CHOLMOD");
  analyze(scalar_.csr());
  factorize(scalar_.csr());
}

void CholmodSolver::update_impl() {
  scalar_.refresh();
  factorize(scalar_.csr());
}

SolveResult CholmodSolver::solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const {
  const auto t0 = std::chrono::steady_clock::now();
  if (monitor) monitor->start(), monitor->record(0, 1.0);
  apply(b, x);
  Vector r;
  system().residual(b, x, r);
  SolveResult res;
  res.status = SolveStatus::converged;
  res.iterations = 1;
  const double bn = b.norm();
  res.initial_residual = bn;  // a direct solve ignores x0: report relative to ||b||
  res.rel_residual = res.true_rel_residual = bn > 0 ? r.norm() / bn : 0.0;
  if (monitor) monitor->record(1, res.rel_residual);
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

void CholmodSolver::apply_impl(const Vector& b, Vector& x) const {
  Impl& d = *impl_;
  if (!d.factorized) throw Error("CHOLMOD: solve before a successful factorize()");
  cholmod_dense B{};
  B.nrow = B.d = B.nzmax = static_cast<size_t>(b.size());
  B.ncol = 1;
  B.x = const_cast<double*>(b.data());
  B.xtype = CHOLMOD_REAL;
  B.dtype = CHOLMOD_DOUBLE;
  cholmod_dense* X = cholmod_l_solve(CHOLMOD_A, d.factor, &B, &d.common);
  if (!X) throw Error("CHOLMOD: solve failed (status " + std::to_string(d.common.status) + ")");
  x = Eigen::Map<const Vector>(static_cast<const double*>(X->x), b.size());
  cholmod_l_free_dense(&X, &d.common);
}

}  // namespace pmg
