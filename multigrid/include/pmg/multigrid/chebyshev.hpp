// pmg/multigrid/chebyshev.hpp — the Chebyshev polynomial smoother on D⁻¹A (D: 3x3 diagonal
// blocks). It needs only products with A and A's diagonal blocks (CSR, BCSR or BIN-BCSR), no
// ordering or colouring, so it parallelises like SpMV.
#pragma once

#include "pmg/multigrid/smoothers.hpp"

#include <memory>

namespace pmg::mg {

/// Which polynomial in D⁻¹A: the first-kind Chebyshev polynomial on [f λmax, λmax] (Saad,
/// "Iterative Methods for Sparse Linear Systems", Alg. 12.1), or the fourth-kind one on [0, λmax]
/// (Lottes, "Optimal polynomial smoothers for multigrid V-cycles", Numer. Linear Algebra Appl.
/// 2023; Phillips & Fischer, "Optimal Chebyshev smoothers and one-sided V-cycles", 2022), which
/// needs no lower bound, and its variant with Lottes' optimised weights (degree <= 6).
enum class ChebyshevKind { first, fourth, optimal_fourth };

/// Parameters of Chebyshev (solver keys: see visit()).
struct ChebyshevParams {
  int degree = 4;               ///< polynomial degree = products with A per smoothing
  /// Which polynomial (see ChebyshevKind).
  ChebyshevKind kind = ChebyshevKind::first;
  double lower_fraction = 0.1;  ///< first kind: smooth eigenvalues in [f λmax, λmax] of D⁻¹A
  int power_iterations = 15;    ///< steps of the estimate of λmax (then raised by 10%) at setup()
  /// How setup() estimates λmax of D⁻¹A: power iteration, or Lanczos — the largest eigenvalue of
  /// the tridiagonal matrix of as many CG steps on A preconditioned by D (PETSc's Chebyshev
  /// estimate), which converges to λmax far faster where the top of the spectrum is clustered
  /// (power iteration from 15 steps underestimated it past the 10% margin on a diffusion
  /// hierarchy and broke CG; 10 Lanczos steps came within 5% on the elasticity levels where 15
  /// power steps were up to 12% low, docs/scaling.md).
  bool lanczos = false;
  /// update(): 0 repeats the set-up estimate; k > 0 runs k power iterations started from the last
  /// power iteration's vector (a time step moves the spectrum little; matrix-free levels pay per
  /// product). After a Lanczos set-up the first such update has no vector yet: it runs
  /// max(k, kColdPowerIterations) power iterations from the fixed start vector, so the updates'
  /// estimates are the power iteration's (the Lanczos bound holds for the set-up's operator).
  int update_iterations = 0;
  /// Power iterations of an update that has no earlier power vector to start from.
  static constexpr int kColdPowerIterations = 15;
  /// The keys degree, kind, lower_fraction, power_iterations, estimate and update_iterations.
  void visit(ParamVisitor& v);
};

/// One step of a Chebyshev smoother: d = c1 d + c2 D⁻¹ r, then x += weight d (c1 = 0 in the first
/// step: d is not read).
struct ChebyshevStep {
  double c1 = 0.0;      ///< weight of the previous direction
  double c2 = 0.0;      ///< weight of the preconditioned residual D⁻¹ r
  double weight = 1.0;  ///< x += weight d (Lottes' optimised weights; 1 otherwise)
};

/// The degree-many steps of the polynomial these parameters choose, for the bound λmax: the one
/// formula of the CPU smoother (Chebyshev) and the GPU V-cycle (gpu::VCycle). First kind (Saad, Alg.
/// 12.1): c1 = ρ_k ρ_(k-1), c2 = 2 ρ_k / δ on [f λmax, λmax] with θ, δ its centre and half-width;
/// the residual before each step is b - A x. Fourth kind (Phillips and Fischer, Alg. 3):
/// c1 = (2k-1)/(2k+3), c2 = (8k+4)/((2k+3) λmax), the residual updated by r -= A d with the
/// unweighted d. Throws InputError for an optimised fourth kind beyond its tabulated degrees.
std::vector<ChebyshevStep> chebyshev_steps(const ChebyshevParams& params, double lambda_max);

/// Step `step` of the recurrence over `blocks` 3x3 blocks, one pass on the threads:
/// d = c1 d + c2 z (first: d = c2 z), then x += weight d (assign_x: x = weight d, x's entries
/// not read), where z = D⁻¹ r is formed block by block from `inv` (the inverted diagonal blocks, 9
/// per block, row-major) or, with inv = nullptr, read from `z`. T: double or float (the float
/// cycle's levels).
template <class T>
void chebyshev_step(const ChebyshevStep& step, bool first, const T* inv, const T* r, const T* z, T* d, T* x,
                    index_t blocks, bool assign_x = false);

/// Damps the eigenvalues of D⁻¹A in [f λmax, λmax] with the Chebyshev polynomial of the given
/// degree (Saad, "Iterative Methods for Sparse Linear Systems", Alg. 12.1). The same polynomial
/// before and after keeps the cycle symmetric. Work vectors are allocated at setup().
class Chebyshev final : public Smoother {
 public:
  /// Not yet set up. Throws InputError when degree or power_iterations is below 1, lower_fraction
  /// lies outside (0, 1), or the optimised fourth kind is asked for beyond its tabulated degrees.
  explicit Chebyshev(const ChebyshevParams& params = {});
  /// Chebyshev in M⁻¹A instead of D⁻¹A: `preconditioner` (M⁻¹ as a Solver's apply, symmetric
  /// positive definite: PatchSchwarz, pmg/multigrid/patch.hpp) is set up on the smoother's A and
  /// updated with it; λmax is estimated for M⁻¹A. Throws InputError as above or for a null one.
  Chebyshev(const ChebyshevParams& params, std::unique_ptr<Solver> preconditioner);
  /// Constructs and sets up on A, which must outlive the smoother (see Solver::setup()).
  Chebyshev(const LinearOperator& A, const ChebyshevParams& params = {}) : Chebyshev(params) { setup(A); }
  std::string name() const override { return M_ ? "chebyshev(" + M_->name() + ")" : "chebyshev"; }
  /// The preconditioner M (nullptr: the inverted diagonal blocks D).
  const Solver* preconditioner() const { return M_.get(); }
  /// The preconditioner's description, where it has one.
  std::string describe() const override { return M_ ? M_->describe() : ""; }
  /// The parameters.
  const ChebyshevParams& params() const { return params_; }
  void pre_smooth(const Vector& b, Vector& x) const override { smooth(b, x, false); }
  void post_smooth(const Vector& b, Vector& x) const override { smooth(b, x, false); }
  /// From x = 0 the first residual is b: one product with A fewer.
  void pre_smooth_from_zero(const Vector& b, Vector& x) const override;
  /// The upper bound λmax of D⁻¹A's spectrum in use: the power-iteration estimate raised by 10%
  /// (0 before setup()).
  double lambda_max() const { return lambda_max_; }
  /// The steps of the polynomial for the current λmax (chebyshev_steps; empty before setup()).
  const std::vector<ChebyshevStep>& steps() const { return steps_; }
  /// D⁻¹: the inverted 3x3 diagonal blocks, 9 doubles each, row-major (as of the last update());
  /// empty with a preconditioner.
  const std::vector<double>& inverse_diagonal() const { return inv_diag_; }
  /// D⁻¹ rounded to float (9 floats per block, as of the last update()), where set_single_precision
  /// asked for it, the operator applies in float (LinearOperator::single_precision_source) and each
  /// block's largest entry lies in [kSingleLow, kSingleHigh]: the λmax estimate then runs in float,
  /// and a float cycle smooths with it. Empty otherwise.
  const std::vector<float>& inverse_diagonal_single() const { return inv_diag_single_; }
  /// Whether setup() and update() keep D⁻¹ in float and estimate λmax in float where they can
  /// (inverse_diagonal_single()); a multigrid cycle that runs its levels in float sets it before its
  /// setup(). Off by default: a smoother in double keeps no float copy, and its operator makes
  /// none for float products.
  void set_single_precision(bool on) { single_wanted_ = on; }
  /// The smallest block scale (largest entry of a 3x3 block) of D⁻¹ that float holds with margin
  /// (float's normal range is about [1.2e-38, 3.4e38]): below it a product in float would overflow
  /// (a Young's modulus of 1e45 Pa).
  static constexpr double kSingleLow = 1e-30;
  /// The largest block scale of D⁻¹ that float holds with margin: beyond it a product's data in
  /// float would lose its digits to subnormals (a Young's modulus of 1e-40 Pa).
  static constexpr double kSingleHigh = 1e30;
  /// Where the last setup() or update() found D⁻¹ outside that range (checked where
  /// set_single_precision asked for float and the operator applies in float; else 0): its largest
  /// block scale if above kSingleHigh (infinity for a NaN or an infinite entry), else its smallest
  /// nonzero one if below kSingleLow, else 0 (a zero block is a held node).
  double single_range_violation() const { return single_violation_; }

 private:
  void setup_impl(const LinearOperator& A) override;
  void update_impl() override;
  void smooth(const Vector& b, Vector& x, bool x_is_zero) const;
  void apply_inverse_diagonal(const Vector& r, Vector& z) const;
  /// inv_diag_single_ from inv_diag_ (see inverse_diagonal_single()).
  void refresh_single();
  /// λmax by Lanczos with power_iterations steps.
  void estimate_lanczos();
  /// λmax by `iterations` power iterations, from the last vector where warm (and one is kept).
  void estimate_power(int iterations, bool warm);
  const LinearOperator* A_ = nullptr;
  ChebyshevParams params_;
  std::unique_ptr<Solver> M_;  ///< M⁻¹ instead of D⁻¹ (nullptr: D⁻¹)
  std::vector<double> inv_diag_;
  std::vector<float> inv_diag_single_;
  bool single_wanted_ = false;    ///< set_single_precision
  double single_violation_ = 0.0;  ///< single_range_violation()
  double lambda_max_ = 0.0;
  std::vector<ChebyshevStep> steps_;  ///< chebyshev_steps(params_, lambda_max_), per estimate
  mutable Vector r_, d_, z_;
  Vector eigenvector_;  ///< the last power iteration's vector (the warm start of update())
};

}  // namespace pmg::mg
