// pmg/multigrid/smoothers.hpp — smoothers on 3x3-block matrices.
//
// A smoother improves x for A x = b in place. pre_smooth() and post_smooth() are adjoint to each
// other (forward then backward Gauss–Seidel), so a V-cycle that uses them is symmetric. set-up is
// split: the ordering (colouring) depends on the pattern and is built once; update() takes new
// values on the same pattern (inverted diagonal blocks).
#pragma once

#include "pmg/sparse/bcsr.hpp"

#include <vector>

namespace pmg::mg {

class Smoother {
 public:
  virtual ~Smoother() = default;
  virtual void pre_smooth(const Vector& b, Vector& x) const = 0;
  virtual void post_smooth(const Vector& b, Vector& x) const = 0;
  /// New values of the matrix the smoother was built for (same pattern, same object).
  virtual void update() = 0;
};

enum class Ordering {
  natural,     ///< rows in order, one thread (the serial reference)
  multicolor,  ///< rows grouped by a greedy colouring of the block graph; a colour runs in parallel
};

struct GaussSeidelParams {
  int sweeps = 5;  ///< per pre- and per post-smoothing (the seed's 5)
  Ordering ordering = Ordering::multicolor;
  /// Point (scalar) Gauss–Seidel instead of 3x3-block: the three unknowns of a block row are
  /// relaxed one after another with their scalar diagonal (forward 0,1,2; backward 2,1,0), which
  /// in natural order is exactly scalar Gauss–Seidel on the scalar matrix.
  bool pointwise = false;
};

/// 3x3-block Gauss–Seidel: x_I <- D_I⁻¹ (b_I - Σ_{J≠I} A_IJ x_J). pre: forward sweeps; post:
/// backward sweeps (colours in reverse order). Keeps a reference to A. Multicolour: the block rows
/// are copied in colour order (pattern once, values on update()), so that a colour streams a
/// contiguous part of the matrix instead of rows scattered over all of it.
class BlockGaussSeidel final : public Smoother {
 public:
  BlockGaussSeidel(const Bcsr& A, const GaussSeidelParams& params = {});
  void pre_smooth(const Vector& b, Vector& x) const override;
  void post_smooth(const Vector& b, Vector& x) const override;
  void update() override;
  /// Block rows grouped by colour (one group holding every row in natural order).
  const std::vector<std::vector<index_t>>& colors() const { return colors_; }
  /// One sweep, forward or backward.
  void sweep(const Vector& b, Vector& x, bool forward) const;

 private:
  const Bcsr& A_;
  GaussSeidelParams params_;
  std::vector<std::vector<index_t>> colors_;
  std::vector<double> inv_diag_;
  std::vector<double> diag_;  ///< pointwise: the diagonal blocks themselves
  // Colour-ordered copy (multicolour only): position k holds block row order_[k] of A.
  std::vector<index_t> order_, color_start_;
  BlockPattern colored_;          ///< row_ptr/col_idx in colour order (columns keep A's numbering)
  std::vector<offset_t> source_;  ///< block of A behind each block of the copy
  std::vector<double> colored_values_;
};

struct JacobiParams {
  int sweeps = 5;
  double omega = 0.6;  ///< damping; block Jacobi diverges for ω too large (ω ρ(D⁻¹A) ≥ 2)
};

/// Damped 3x3-block Jacobi: x <- x + ω D⁻¹ (b - A x). Symmetric by construction.
class BlockJacobi final : public Smoother {
 public:
  BlockJacobi(const Bcsr& A, const JacobiParams& params = {});
  void pre_smooth(const Vector& b, Vector& x) const override { smooth(b, x); }
  void post_smooth(const Vector& b, Vector& x) const override { smooth(b, x); }
  void update() override;

 private:
  void smooth(const Vector& b, Vector& x) const;
  const Bcsr& A_;
  JacobiParams params_;
  std::vector<double> inv_diag_;
};

struct ChebyshevParams {
  int degree = 4;               ///< polynomial degree = residual evaluations per smoothing
  double lower_fraction = 0.1;  ///< smooth eigenvalues in [f λmax, λmax] of D⁻¹A
  int power_iterations = 15;    ///< estimate of λmax (then raised by 10%)
};

/// Chebyshev polynomial smoother on D⁻¹A (D: 3x3 diagonal blocks): damps the upper part of the
/// spectrum with no ordering or colouring, so it parallelises like SpMV. The same polynomial before
/// and after keeps the cycle symmetric.
class Chebyshev final : public Smoother {
 public:
  Chebyshev(const Bcsr& A, const ChebyshevParams& params = {});
  void pre_smooth(const Vector& b, Vector& x) const override { smooth(b, x); }
  void post_smooth(const Vector& b, Vector& x) const override { smooth(b, x); }
  void update() override;
  double lambda_max() const { return lambda_max_; }
  /// D⁻¹: the inverted 3x3 diagonal blocks, 9 doubles each, row-major (as of the last update()).
  const std::vector<double>& inverse_diagonal() const { return inv_diag_; }

 private:
  void smooth(const Vector& b, Vector& x) const;
  void apply_inverse_diagonal(const Vector& r, Vector& z) const;
  const Bcsr& A_;
  ChebyshevParams params_;
  std::vector<double> inv_diag_;
  double lambda_max_ = 0.0;
};

/// Inverts the 3x3 diagonal blocks of A (Cholesky); throws InputError naming a block that is not
/// SPD.
std::vector<double> inverse_diagonal_blocks(const Bcsr& A);

}  // namespace pmg::mg
