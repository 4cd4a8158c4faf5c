// pmg/sparse/operator.hpp — the one interface that maps a vector to a vector.
//
// Matrices (Csr, Bcsr, BinBcsr), preconditioners, direct solvers and (later) smoothers and V-cycles
// all implement LinearOperator, so any of them can precondition or smooth any other. The public
// apply() checks sizes and then calls the private virtual apply_impl(); kernels never re-check.
#pragma once

#include "pmg/sparse/types.hpp"

#include <string>

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

/// Approximates the inverse of an operator: apply(r, z) gives z = M^{-1} r. A preconditioner is set
/// up from values that change (a matrix); update() recomputes from new values on the same pattern.
class Preconditioner : public LinearOperator {
 public:
  /// Short human-readable name for tables ("jacobi", "block-jacobi", ...).
  virtual std::string name() const = 0;
};

}  // namespace pmg
