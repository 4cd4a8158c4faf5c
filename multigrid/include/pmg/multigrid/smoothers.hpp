// pmg/multigrid/smoothers.hpp — smoothers on 3x3-block matrices.
//
// A smoother is a Solver (pmg/sparse/solver.hpp) with two extra variants: pre_smooth() and
// post_smooth() improve x for A x = b in place, and are adjoint to each other (forward then
// backward Gauss–Seidel), so a V-cycle that uses them is symmetric. Set-up is split as for every
// Solver: setup(A) builds what depends on the pattern (colouring, the colour-ordered copy) once;
// update() takes new values on the same pattern (inverted diagonal blocks). apply(b, x) is one pre-
// and one post-smoothing from x = 0 (symmetric), so a smoother can also precondition CG.
//
// Any other Solver can smooth a cycle's level too: the cycle then uses it as a correction
// x += M (b - A x) (see Richardson below).
#pragma once

#include "pmg/sparse/bcsr.hpp"
#include "pmg/sparse/params.hpp"
#include "pmg/sparse/solver.hpp"

#include <memory>
#include <vector>

namespace pmg::mg {

/// A Solver that can also smooth in place, before and after a coarse correction (see the file
/// comment).
class Smoother : public Solver {
 public:
  /// Improves x for A x = b in place (the smoothing before a coarse correction). Requires setup();
  /// b and x must have rows() entries (not re-checked: the cycle's hot path).
  virtual void pre_smooth(const Vector& b, Vector& x) const = 0;
  /// Improves x for A x = b in place (the smoothing after a coarse correction): the adjoint of
  /// pre_smooth() (backward sweeps after forward ones), so that a cycle using both is symmetric.
  /// Same preconditions as pre_smooth().
  virtual void post_smooth(const Vector& b, Vector& x) const = 0;
  /// pre_smooth() of x = 0 (sets x): a smoother may skip work that x = 0 makes trivial (a cycle's
  /// lower levels, and the first cycle of a preconditioner application, start from zero).
  virtual void pre_smooth_from_zero(const Vector& b, Vector& x) const {
    x.setZero(b.size());
    pre_smooth(b, x);
  }

 protected:
  /// x = post(pre(0)): the symmetric smoothing step as a preconditioner.
  void apply_impl(const Vector& b, Vector& x) const override {
    pre_smooth_from_zero(b, x);
    post_smooth(b, x);
  }
};

/// The order in which Gauss–Seidel visits the block rows.
enum class Ordering {
  natural,     ///< rows in order, one thread (the serial reference)
  multicolor,  ///< rows grouped by a greedy colouring of the block graph; a colour runs in parallel
};

/// Parameters of BlockGaussSeidel (solver keys: see visit()).
struct GaussSeidelParams {
  int sweeps = 5;  ///< per pre- and per post-smoothing (the seed's 5)
  /// Row order: natural (serial) or multicolour (parallel within a colour).
  Ordering ordering = Ordering::multicolor;
  /// Point (scalar) Gauss–Seidel instead of 3x3-block: the three unknowns of a block row are
  /// relaxed one after another with their scalar diagonal (forward 0,1,2; backward 2,1,0), which
  /// in natural order is exactly scalar Gauss–Seidel on the scalar matrix.
  bool pointwise = false;
  /// The keys sweeps and ordering.
  void visit(ParamVisitor& v);
};

/// 3x3-block Gauss–Seidel: x_I <- D_I⁻¹ (b_I - Σ_{J≠I} A_IJ x_J). pre: forward sweeps; post:
/// backward sweeps (colours in reverse order). Needs a Bcsr. Multicolour: the block rows are
/// copied in colour order (pattern once, values on update()), so that a colour streams a
/// contiguous part of the matrix instead of rows scattered over all of it.
class BlockGaussSeidel final : public Smoother {
 public:
  /// Not yet set up. Throws InputError when params.sweeps is negative.
  explicit BlockGaussSeidel(const GaussSeidelParams& params = {});
  /// Constructs and sets up on A, which must outlive the smoother (see Solver::setup()).
  BlockGaussSeidel(const Bcsr& A, const GaussSeidelParams& params = {}) : BlockGaussSeidel(params) { setup(A); }
  std::string name() const override { return params_.pointwise ? "point-gauss-seidel" : "gauss-seidel"; }
  void pre_smooth(const Vector& b, Vector& x) const override;
  void post_smooth(const Vector& b, Vector& x) const override;
  /// Block rows grouped by colour (one group holding every row in natural order).
  const std::vector<std::vector<index_t>>& colors() const { return colors_; }
  /// One sweep, forward or backward.
  void sweep(const Vector& b, Vector& x, bool forward) const;

 private:
  void setup_impl(const LinearOperator& A) override;
  void update_impl() override;
  const Bcsr* A_ = nullptr;
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

/// Parameters of BlockJacobi (solver keys: see visit()).
struct JacobiParams {
  /// Jacobi sweeps per pre- and per post-smoothing (>= 0).
  int sweeps = 5;
  double omega = 0.6;  ///< damping; block Jacobi diverges for ω too large (ω ρ(D⁻¹A) ≥ 2)
  /// l1 block Jacobi (A. H. Baker, R. D. Falgout, T. V. Kolev and U. M. Yang, "Multigrid smoothers
  /// for ultraparallel computing", SIAM J. Sci. Comput. 33, 2011): D is each 3x3 diagonal block
  /// plus, on its diagonal, the absolute sums of the scalar row's entries in the row's other
  /// blocks. Convergent for every SPD A with ω = 1: no damping to tune. BCSR only.
  bool l1 = false;
  /// The keys sweeps and (damped, not l1) omega.
  void visit(ParamVisitor& v);
};

/// Damped 3x3-block Jacobi: x <- x + ω D⁻¹ (b - A x). Symmetric by construction. Any matrix with
/// 3x3 diagonal blocks (CSR, BCSR, BIN-BCSR); the l1 variant reads BCSR.
class BlockJacobi final : public Smoother {
 public:
  /// Not yet set up. Throws InputError when params.omega is not positive or params.sweeps is
  /// negative.
  explicit BlockJacobi(const JacobiParams& params = {});
  /// Constructs and sets up on A, which must outlive the smoother (see Solver::setup()).
  BlockJacobi(const Bcsr& A, const JacobiParams& params = {}) : BlockJacobi(params) { setup(A); }
  std::string name() const override { return params_.l1 ? "l1-jacobi" : "damped-jacobi"; }
  void pre_smooth(const Vector& b, Vector& x) const override { smooth(b, x); }
  void post_smooth(const Vector& b, Vector& x) const override { smooth(b, x); }

 private:
  void setup_impl(const LinearOperator& A) override;
  void update_impl() override;
  void smooth(const Vector& b, Vector& x) const;
  void invert_diagonal(const LinearOperator& A);
  JacobiParams params_;
  std::vector<double> inv_diag_;
  mutable Vector r_;
};

/// Parameters of Richardson (solver keys: see visit()).
struct RichardsonParams {
  int iterations = 1;   ///< corrections per pre- and per post-smoothing
  double omega = 1.0;   ///< damping of each correction
  /// The keys iterations and omega.
  void visit(ParamVisitor& v);
};

/// Richardson iteration with any Solver M as its preconditioner: x <- x + ω M (b - A x). With
/// M = CHOLMOD it is an exact solve, with M = block Jacobi the damped block-Jacobi smoother, with
/// M = a multigrid cycle a stationary multigrid method. Symmetric when M is.
class Richardson final : public Smoother {
 public:
  /// Takes ownership of M, which is set up with this smoother. Throws InputError when M is null,
  /// params.iterations is negative or params.omega is not positive.
  Richardson(std::unique_ptr<Solver> M, const RichardsonParams& params = {});
  std::string name() const override { return "richardson(" + M_->name() + ")"; }
  bool is_linear() const override { return M_->is_linear(); }
  bool is_symmetric() const override { return M_->is_symmetric(); }
  SolverNeeds needs() const override { return M_->needs(); }
  TimingBreakdown timings() const override { return M_->timings(); }
  TimingBreakdown setup_timings() const override { return M_->setup_timings(); }
  void reset_timings() const override { M_->reset_timings(); }
  void pre_smooth(const Vector& b, Vector& x) const override { smooth(b, x); }
  void post_smooth(const Vector& b, Vector& x) const override { smooth(b, x); }

 private:
  void setup_impl(const LinearOperator& A) override;
  void update_impl() override { M_->update(); }
  void smooth(const Vector& b, Vector& x) const;
  std::unique_ptr<Solver> M_;
  RichardsonParams params_;
  mutable Vector r_, z_;
};

/// Inverts the 3x3 diagonal blocks of A (Cholesky); throws InputError naming a block that is not
/// SPD.
std::vector<double> inverse_diagonal_blocks(const LinearOperator& A);

}  // namespace pmg::mg
