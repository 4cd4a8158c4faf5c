// pmg/sparse/operator.hpp — the one interface that maps a vector to a vector.
//
// Matrices (Csr, Bcsr, BinBcsr) implement it directly; everything that approximates an inverse
// (Krylov solvers, preconditioners, smoothers, cycles, direct solvers) is a Solver
// (pmg/sparse/solver.hpp), which is a LinearOperator too, so any of them can precondition or smooth
// any other. The public
// apply() checks sizes and then calls the private virtual apply_impl(); kernels never re-check.
#pragma once

#include "pmg/sparse/types.hpp"

#include <string>
#include <vector>

namespace pmg {

class LinearOperator {
 public:
  virtual ~LinearOperator() = default;

  virtual index_t rows() const = 0;
  virtual index_t cols() const = 0;

  /// y = Op(x). y is resized to rows(); x must have cols() entries.
  void apply(const Vector& x, Vector& y) const;

  /// y = Op(x) and returns dot(x, y) (square operators only). Matrices override this with a fused
  /// kernel that reads y once (the merged CG's first step); the default applies then dots.
  double apply_dot(const Vector& x, Vector& y) const;

  /// r = b - Op(x).
  void residual(const Vector& b, const Vector& x, Vector& r) const;

 protected:
  virtual void apply_impl(const Vector& x, Vector& y) const = 0;
  virtual double apply_dot_impl(const Vector& x, Vector& y) const;
  virtual void residual_impl(const Vector& b, const Vector& x, Vector& r) const;

  void check_square(const char* what) const;
};

/// An operator held as no matrix (a matrix-free FEM operator) that can still compute its 3x3
/// diagonal blocks: what Jacobi, block-Jacobi and Chebyshev smoothing need. diagonal_of() and
/// diagonal_blocks_of() (pmg/sparse/solver.hpp) read it like a matrix's.
class DiagonalBlocksSource {
 public:
  virtual ~DiagonalBlocksSource() = default;
  /// 9 doubles per 3x3 block row, row-major, into `blocks` (resized).
  virtual void diagonal_blocks(std::vector<double>& blocks) const = 0;
};


}  // namespace pmg
