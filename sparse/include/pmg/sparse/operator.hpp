// pmg/sparse/operator.hpp — the one interface that maps a vector to a vector.
//
// Matrices (Csr, Bcsr, BinBcsr) implement it directly; everything that approximates an inverse
// (Krylov solvers, preconditioners, smoothers, cycles, direct solvers) is a Solver
// (pmg/sparse/solver.hpp), which is a LinearOperator too, so any of them can precondition or smooth
// any other. The public
// apply() checks sizes and then calls the protected virtual apply_impl(); kernels never re-check.
#pragma once

#include "pmg/sparse/types.hpp"

#include <mutex>
#include <string>
#include <vector>

namespace pmg {

namespace fem {
class ElasticityOperator;
}
class Csr;
class Bcsr;
class BinBcsr;
class SaddlePointOperator;
class DiagonalBlocksSource;
class SinglePrecisionSource;

/// A linear map from vectors of cols() entries to vectors of rows() entries (see the file comment):
/// the base of every matrix and every Solver.
class LinearOperator {
 public:
  virtual ~LinearOperator() = default;

  /// Number of rows: the size of the result of apply().
  virtual index_t rows() const = 0;
  /// Number of columns: the size of the argument of apply().
  virtual index_t cols() const = 0;

  /// y = Op(x). y is resized to rows(); x must have cols() entries (InputError otherwise) and must
  /// not be the same vector as y.
  void apply(const Vector& x, Vector& y) const;

  /// y = Op(x) and returns dot(x, y) (square operators only: InputError otherwise, or when x does
  /// not have cols() entries). Matrices override apply_dot_impl() with a fused
  /// kernel that reads y once (the merged CG's first step); the default applies then dots.
  double apply_dot(const Vector& x, Vector& y) const;

  /// r = b - Op(x). r is resized to rows(); x must have cols() entries and b rows() entries
  /// (InputError otherwise).
  void residual(const Vector& b, const Vector& x, Vector& r) const;

  // Capabilities: what the operator is or offers, asked instead of cast to (Csr, Bcsr, BinBcsr
  // and the matrix-free operators answer for themselves; nullptr: not this).

  /// This operator as scalar CSR (nullptr: it is not one).
  virtual const Csr* csr_matrix() const { return nullptr; }
  /// This operator as a 3x3-block BCSR matrix (nullptr: it is not one).
  virtual const Bcsr* bcsr_matrix() const { return nullptr; }
  /// This operator as a BIN-BCSR matrix (nullptr: it is not one).
  virtual const BinBcsr* bin_bcsr_matrix() const { return nullptr; }
  /// The operator as a saddle-point system [A Bᵀ; B -C] (pmg/sparse/saddle_point.hpp), or nullptr.
  virtual const SaddlePointOperator* saddle_point_operator() const { return nullptr; }
  /// Its 3x3 diagonal blocks, computed without a matrix (a matrix-free operator; nullptr: none).
  virtual const DiagonalBlocksSource* diagonal_blocks_source() const { return nullptr; }
  /// Its product in single precision (a matrix-free operator; nullptr: none).
  virtual const SinglePrecisionSource* single_precision_source() const { return nullptr; }
  /// The matrix-free elasticity operator this is (its element arrays, for device kernels that
  /// re-implement its product; nullptr: another operator).
  virtual const fem::ElasticityOperator* elasticity_operator() const { return nullptr; }

 protected:
  /// y = Op(x), the operator's kernel. Called by apply() with x of cols() entries and y already
  /// resized to rows(); need not re-check sizes, and may assume x and y do not alias.
  virtual void apply_impl(const Vector& x, Vector& y) const = 0;
  /// y = Op(x), returning dot(x, y); called by apply_dot() on a square operator with sizes checked
  /// and y resized. The default calls apply_impl() and then dots; override with a fused kernel.
  virtual double apply_dot_impl(const Vector& x, Vector& y) const;
  /// r = b - Op(x); called by residual() with sizes checked and r resized to rows(). The default
  /// applies into r and subtracts; matrices override it with a one-pass kernel.
  virtual void residual_impl(const Vector& b, const Vector& x, Vector& r) const;

  /// Throws InputError, prefixed with `what`, unless rows() == cols().
  void check_square(const char* what) const;

  /// When set (a Solver sets it to its own lock), apply(), apply_dot() and residual() hold this
  /// lock around the kernel, so that calls on one object from several threads run one at a time
  /// (a matrix has none: its products only read it).
  std::recursive_mutex* call_lock_ = nullptr;
  /// call_lock_ held (or nothing, when there is none) until the returned object goes.
  std::unique_lock<std::recursive_mutex> hold_call_lock() const;
};

/// An operator held as no matrix (a matrix-free FEM operator) that can still compute its 3x3
/// diagonal blocks: what Jacobi, block-Jacobi and Chebyshev smoothing need. diagonal_of() and
/// diagonal_blocks_of() (pmg/sparse/solver.hpp) read it like a matrix's. The operator says it
/// offers this by overriding LinearOperator::diagonal_blocks_source() to return itself (the query
/// is asked, never cast to).
class DiagonalBlocksSource {
 public:
  virtual ~DiagonalBlocksSource() = default;
  /// 9 doubles per 3x3 block row, row-major, into `blocks` (resized).
  virtual void diagonal_blocks(std::vector<double>& blocks) const = 0;
};

/// An operator that can also apply itself in single precision: what a multigrid cycle's float
/// levels (precision=single) ask of a level's matrix-free operator. The operator says it offers
/// this by overriding LinearOperator::single_precision_source() to return itself.
class SinglePrecisionSource {
 public:
  virtual ~SinglePrecisionSource() = default;
  /// y = A x in float (x and y distinct; y resized).
  virtual void apply_single(const Eigen::VectorXf& x, Eigen::VectorXf& y) const = 0;
  /// r = b - A x in float (x distinct from r; b may be r; r resized). The default applies into a
  /// temporary and subtracts; an operator overrides it with one pass (the smoothers' residuals).
  virtual void residual_single(const Eigen::VectorXf& b, const Eigen::VectorXf& x, Eigen::VectorXf& r) const {
    Eigen::VectorXf z;
    apply_single(x, z);
    r = b - z;
  }
};


}  // namespace pmg
