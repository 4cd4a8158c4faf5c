// pmg/sparse/cholmod_solver.hpp — sparse Cholesky through CHOLMOD (supernodal), with the symbolic
// analysis (ordering, elimination tree, supernodes: once per pattern) separate from the numeric
// factorisation (once per change of values), as Eigen's analyzePattern/factorize.
#pragma once

#include "pmg/sparse/csr.hpp"

#include <memory>

namespace pmg {

class CholmodSolver final : public LinearOperator {
 public:
  CholmodSolver();
  ~CholmodSolver() override;
  CholmodSolver(const CholmodSolver&) = delete;
  CholmodSolver& operator=(const CholmodSolver&) = delete;

  /// Symbolic analysis of a symmetric matrix (only one triangle is read).
  void analyze(const Csr& A);
  /// Numeric factorisation; A must have the analysed pattern. Throws Error naming the column where
  /// positive definiteness fails.
  void factorize(const Csr& A);
  void compute(const Csr& A) {
    analyze(A);
    factorize(A);
  }
  /// x = A^{-1} b (same as apply).
  void solve(const Vector& b, Vector& x) const { apply(b, x); }

  index_t rows() const override { return n_; }
  index_t cols() const override { return n_; }
  /// Nonzeros in the factor L (after factorize).
  double factor_nnz() const;

 private:
  void apply_impl(const Vector& b, Vector& x) const override;
  struct Impl;
  std::unique_ptr<Impl> impl_;
  index_t n_ = 0;
};

}  // namespace pmg
