// pmg/sparse/saddle_point.hpp — symmetric saddle-point systems and MINRES.
//
//   K = [ A  Bᵀ ]      A (n_u x n_u) symmetric positive definite, B (n_p x n_u), C (n_p x n_p)
//       [ B  -C ]      symmetric positive semidefinite (C = 0 allowed),
//
// the systems of mixed finite elements (displacement–pressure elasticity, Stokes). K is symmetric
// and indefinite, so CG does not apply; MINRES (Paige and Saunders, "Solution of sparse indefinite
// systems of linear equations", SIAM J. Numer. Anal. 1975) does, with a symmetric positive definite
// preconditioner. The block-diagonal one
//
//   P = diag(M_u, M_p),  M_u ≈ A⁻¹ (a multigrid cycle),  M_p ≈ S⁻¹,  S = C + B A⁻¹ Bᵀ,
//
// gives iteration counts bounded independently of the mesh and of the parameters when M_u and M_p
// are spectrally equivalent to A⁻¹ and S⁻¹ (Silvester and Wathen, "Fast iterative solution of
// stabilised Stokes systems part II", SIAM J. Numer. Anal. 1994; Elman, Silvester and Wathen,
// "Finite Elements and Fast Iterative Solvers", ch. 4). For elasticity S is spectrally equivalent
// to a multiple of the pressure mass matrix, whose inverse a few Chebyshev steps on D⁻¹M with
// element-derived bounds replace (Wathen and Rees, "Chebyshev semi-iteration in preconditioning for
// problems including the mass matrix", ETNA 2009).
//
// The block upper-triangular preconditioner
//
//   P = [ M_u⁻¹  Bᵀ   ]⁻¹,   P r:  z_p = -M_p r_p,  z_u = M_u (r_u - Bᵀ z_p),
//       [ 0     -M_p⁻¹ ]
//
// is not symmetric, so it pairs with GMRES; with exact blocks K P has the single eigenvalue 1 and a
// minimal polynomial of degree 2 (Murphy, Golub and Wathen, "A note on preconditioning for
// indefinite linear systems", SIAM J. Sci. Comput. 2000), and with approximate ones GMRES typically
// needs fewer iterations than MINRES with the block-diagonal P, for one more product with Bᵀ per
// iteration and the orthogonalisation (Elman, Silvester and Wathen, ch. 4 and 9).
#pragma once

#include "pmg/sparse/csr.hpp"
#include "pmg/sparse/krylov.hpp"
#include "pmg/sparse/operator.hpp"
#include "pmg/sparse/solver.hpp"

#include <memory>
#include <string>
#include <vector>

namespace pmg {

/// The off-diagonal blocks of a saddle point in one product: y_u += Bᵀ x_p and y_p = B x_u (a
/// matrix-free discretisation computes both in one pass over its elements).
class SaddlePointCoupling {
 public:
  virtual ~SaddlePointCoupling() = default;
  /// Rows of B: the second unknowns, n_p.
  virtual index_t rows() const = 0;
  /// Columns of B: the first unknowns, n_u.
  virtual index_t cols() const = 0;
  /// y_u += Bᵀ x_p and y_p = B x_u (sizes unchecked: n_u, n_p, n_u, n_p). x_u == nullptr: only
  /// y_u += Bᵀ x_p (y_p unused); x_p == nullptr: only y_p = B x_u (y_u unused).
  virtual void apply(const double* x_u, const double* x_p, double* y_u, double* y_p) const = 0;
};

/// The coupling of assembled B and Bᵀ (Bᵀ assembled: a row-wise product parallelises). Holds
/// references to both.
class CsrCoupling final : public SaddlePointCoupling {
 public:
  /// Throws InputError when Bt is not B's shape transposed.
  CsrCoupling(const Csr& B, const Csr& Bt);
  index_t rows() const override { return B_.rows(); }
  /// B's columns.
  index_t cols() const override { return B_.cols(); }
  void apply(const double* x_u, const double* x_p, double* y_u, double* y_p) const override;

 private:
  const Csr &B_, &Bt_;
};

/// What a saddle-point solver reads besides the operator (SolverContext::saddle_point), filled by
/// the discretisation (fem::MixedElasticity): the off-diagonal blocks, C, the pressure mass M_p with
/// the bounds of the spectrum of D⁻¹M_p, and the scale s of the Schur complement S ≈ s M_p.
struct SaddlePointBlocks {
  const SaddlePointCoupling* coupling = nullptr;  ///< B and Bᵀ
  const Csr* C = nullptr;              ///< n_p x n_p, or nullptr for zero
  const Csr* pressure_mass = nullptr;  ///< M_p
  double mass_lo = 0.0;                ///< lower bound of the spectrum of diag(M_p)⁻¹ M_p
  double mass_hi = 0.0;                ///< its upper bound
  double schur_scale = 1.0;            ///< s in S ≈ s M_p
};

/// Preconditioned MINRES for a symmetric (possibly indefinite) operator K with a symmetric positive
/// definite preconditioner M (nullptr: none). x holds the initial guess and receives the answer.
/// Stopping as pcg(): on the 2-norm residual ||b - K x|| (KrylovParams), which MINRES updates by
/// the recurrence r -= φ K w alongside x += φ w (K w from the same three-term recurrence as w, so
/// one product with K and one application of M per iteration); when it meets the tolerance the
/// true residual is computed and, where it disagrees, MINRES restarts from the current x. A
/// preconditioner that is not positive definite (rᵀ M r <= 0) is a breakdown. Cost per iteration:
/// one K, one M, three inner products, about 10 vector updates.
SolveResult minres(const LinearOperator& K, const LinearOperator* M, const Vector& b, Vector& x,
                   const KrylovParams& params = {}, SolveMonitor* monitor = nullptr);

/// The options of gmres(), which are the keys of mixed-gmres beside MixedKrylovParams.
struct GmresParams {
  /// Krylov vectors kept before a restart (memory: 2 restart + 1 vectors of the system's size,
  /// restart of them in float where the preconditioned vectors are exact in float, and the basis
  /// vectors in float once the residual nears the target: float_basis).
  /// 50: the stress matrix's thin plate (4 x 1 x 0.01 m, ν = 0.499, 1e-5 per step) stagnated past
  /// 1,000 iterations in its third step with 20, and took at most 546 per step with 50 (702 with
  /// 40); on Homer P3 20 is 1.2x faster, for two more iterations.
  int restart = 50;
  /// Classical Gram–Schmidt once per iteration (false, PETSc's default for its GMRES), or repeated
  /// where the first pass lost more than 30% of the norm ("twice is enough": Giraud, Langou and
  /// Rozložník 2005). One pass gave the same iterations to 1e-8 on the bar and Homer P3 at ν = 0.3
  /// and 0.4999 (docs/robustness.md), where the criterion had repeated the pass in 40 of 41
  /// iterations; the true residual decides convergence either way.
  bool reorthogonalise = false;
  /// Krylov vectors v_i stored in float, the arithmetic in double, once the estimated residual is
  /// below the target / (100 u), u = 2⁻²⁴ float's rounding; before that, and in fixed-iteration
  /// mode, in double. A stored v_{i+1} is the rounded w/‖w‖, which perturbs the Arnoldi relation
  /// by about u times its column and the final residual by about u times the residual at the time
  /// (Ginkgo's compressed-basis GMRES stores the whole basis in lower precision: Aliaga, Anzt,
  /// Grützmacher, Quintana-Ortí and Tomás, "Compressed basis GMRES on high-performance graphics
  /// processing units", IJHPCA 2022; inexact Krylov methods relax a product's accuracy as the
  /// residual falls: Simoncini and Szyld, SIAM J. Sci. Comput. 2003). The later vectors then take
  /// half the memory and half the Gram–Schmidt passes' traffic. The true residual decides
  /// convergence either way.
  bool float_basis = true;
  /// The keys restart, reorthogonalise and float_basis.
  void visit(ParamVisitor& v);
};

/// The vectors of gmres(), kept between solves by a caller that solves many times (each solve
/// would otherwise allocate, and fault in, restart + 1 Krylov vectors of the system's size and
/// restart preconditioned ones, in float where the product is single_precision, beside a few work
/// vectors).
struct GmresWorkspace {
  std::vector<Vector> V;           ///< the Krylov basis
  std::vector<Eigen::VectorXf> Vf; ///< the same in float (GmresParams::float_basis)
  Vector v;                        ///< the newest v_i of a float basis in double, the product's input
  std::vector<Vector> Z;           ///< the preconditioned vectors M v_i
  std::vector<Eigen::VectorXf> Zf; ///< the same in float, where the product's z are exact in float
  Vector z;                        ///< the newest z_i in double, before it is stored in Zf
  Vector r;                        ///< the residual
  Vector w;                        ///< the new direction
};

/// Right-preconditioned restarted GMRES in its flexible form (Saad, "A flexible inner-outer
/// preconditioned GMRES algorithm", SIAM J. Sci. Comput. 1993; Algorithm 9.6 of his "Iterative
/// methods for sparse linear systems") for any operator K and preconditioner M (nullptr: none): the
/// vectors z_i = M v_i are kept and x = x0 + Z y minimises ‖b − K x‖ over their span, so the
/// residual it estimates (Givens rotations of the Hessenberg matrix) is the true residual of K up
/// to rounding even where M is applied in lower precision (a multigrid cycle with float levels).
/// Stopping as pcg() on ‖b − K x‖ (KrylovParams); when the estimate meets the tolerance x is formed
/// and the true residual computed and, where it disagrees, GMRES restarts from x. Memory: `restart`
/// (>= 1) vectors z_i (in float where the product is single_precision) and restart + 1 vectors v_i
/// of the system's size (in float once the residual nears the target: GmresParams::float_basis).
/// The orthogonalisation is classical Gram–Schmidt in fused passes (GmresParams::reorthogonalise),
/// its inner products over fixed blocks added in order: the same bits on any number of threads.
/// Cost per iteration: one K, one M, and 2 (4 where repeated) passes over the j + 1 Krylov vectors
/// of iteration j. x holds the initial guess and receives the answer.
SolveResult gmres(const LinearOperator& K, const LinearOperator* M, const Vector& b, Vector& x,
                  const KrylovParams& params = {}, const GmresParams& options = {}, SolveMonitor* monitor = nullptr,
                  GmresWorkspace* work = nullptr);

/// One step of right preconditioning, z = M v and w = K z, in one call: for a preconditioner whose
/// work the product with K can reuse (BlockTriangularOperator shares Bᵀ z_p).
class PreconditionedProduct {
 public:
  virtual ~PreconditionedProduct() = default;
  /// z = M v, then w = K z (z as stored: K is applied to exactly the z it returns).
  virtual void apply(const Vector& v, Vector& z, Vector& w) const = 0;
  /// True where every z that apply() returns is exactly representable in float (rounded before
  /// w = K z was formed): gmres() then keeps the z_i in float, half their memory, and the relation
  /// K Z = V H it relies on stays exact.
  virtual bool single_precision() const { return false; }
};

/// gmres() with M and its product with K given as one PreconditionedProduct; K still forms the
/// residuals. Throws InputError as gmres().
SolveResult gmres(const LinearOperator& K, const PreconditionedProduct& KM, const Vector& b, Vector& x,
                  const KrylovParams& params = {}, const GmresParams& options = {}, SolveMonitor* monitor = nullptr,
                  GmresWorkspace* work = nullptr);


/// gmres() as a Solver for any system, with any preconditioner (a Solver, set up and updated with
/// this one; nullptr: none): the outer iteration of a preconditioner that is not symmetric or not
/// positive definite (PETSc's fieldsplit on a saddle point: `fieldsplit-gmres`).
class Gmres final : public PreconditionedKrylov {
 public:
  /// Takes ownership of the preconditioner. Throws InputError for restart < 1.
  explicit Gmres(const KrylovParams& params = {}, std::unique_ptr<Solver> preconditioner = nullptr,
                 const GmresParams& options = {});
  std::string name() const override { return M_ ? "gmres(" + M_->name() + ")" : "gmres"; }
  std::string describe() const override;

 private:
  SolveResult solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const override;
  GmresParams options_;
  mutable GmresWorkspace work_;
};

/// K = [A Bᵀ; B -C] on (u; p), u first (see the file comment). Holds references to A, the coupling
/// (B and Bᵀ) and C, which must outlive it. C may be nullptr (zero).
class SaddlePointOperator final : public LinearOperator {
 public:
  /// Throws InputError when the sizes do not fit together.
  SaddlePointOperator(const LinearOperator& A, const SaddlePointCoupling& B, const Csr* C);
  index_t rows() const override { return n_u_ + n_p_; }
  index_t cols() const override { return rows(); }
  /// Rows of the first block (u).
  index_t first_rows() const { return n_u_; }
  /// The block A.
  const LinearOperator& first_block() const { return A_; }
  /// B and Bᵀ.
  const SaddlePointCoupling& coupling() const { return B_; }
  /// C (nullptr: zero).
  const Csr* second_block() const { return C_; }
  const SaddlePointOperator* saddle_point_operator() const override { return this; }

 protected:
  void apply_impl(const Vector& x, Vector& y) const override;

 private:
  const LinearOperator& A_;
  const SaddlePointCoupling& B_;
  const Csr* C_;
  index_t n_u_, n_p_;
  mutable Vector xu_, yu_, cp_;
};

/// diag(M_u, M_p) on (u; p): each block applied to its part. Holds references to both.
class BlockDiagonalOperator final : public LinearOperator {
 public:
  /// Throws InputError when a block is not square.
  BlockDiagonalOperator(const LinearOperator& first, const LinearOperator& second);
  index_t rows() const override { return first_.rows() + second_.rows(); }
  index_t cols() const override { return rows(); }

 protected:
  void apply_impl(const Vector& x, Vector& y) const override;

 private:
  const LinearOperator &first_, &second_;
  mutable Vector x1_, x2_, y1_, y2_;  // contiguous copies of the parts (the blocks take Vectors)
};

/// The block upper-triangular preconditioner of the file comment on (u; p): z_p = -M_p r_p, then
/// z_u = M_u (r_u - Bᵀ z_p). Linear and fixed when M_u and M_p are; not symmetric (for GMRES).
/// Holds references to M_u, M_p and the coupling, which must outlive it.
class BlockTriangularOperator final : public LinearOperator {
 public:
  /// Throws InputError when a block is not square or the coupling's shape does not fit.
  BlockTriangularOperator(const LinearOperator& M_u, const LinearOperator& M_p, const SaddlePointCoupling& B);
  index_t rows() const override { return M_u_.rows() + M_p_.rows(); }
  index_t cols() const override { return rows(); }
  /// z = P v, then w = K z with K's Bᵀ z_p taken from P's own (w_u = A z_u + Bᵀ z_p, w_p = B z_u −
  /// C z_p): one pass of Bᵀ and one of B, where P then K make two of Bᵀ. With round_to_float, z_p
  /// is rounded to float before Bᵀ z_p is formed and z_u after M_u, so z is exact in float and w is
  /// K applied to it (a preconditioner perturbed by float rounding, for GMRES's flexible form).
  /// Throws InputError when K's coupling is not this operator's or the sizes differ.
  void apply_and_multiply(const SaddlePointOperator& K, const Vector& v, Vector& z, Vector& w,
                          bool round_to_float = false) const;

 protected:
  void apply_impl(const Vector& x, Vector& y) const override;

 private:
  const LinearOperator &M_u_, &M_p_;
  const SaddlePointCoupling& B_;
  mutable Vector ru_, rp_, zu_, zp_, bt_, wu_, cp_;
  /// zp_ = M_p r_p (= −z_p), bt_ = Bᵀ zp_ (= −Bᵀ z_p), zu_ = M_u (r_u + bt_); zp_ and zu_
  /// rounded to float with round_to_float.
  void precondition(const Vector& v, bool round_to_float) const;
};

/// A BlockTriangularOperator and the saddle point it preconditions as one PreconditionedProduct
/// (BlockTriangularOperator::apply_and_multiply). With single_precision its z are rounded to float,
/// and gmres() keeps them in float. Holds references to both.
class BlockTriangularProduct final : public PreconditionedProduct {
 public:
  /// Throws InputError when K's coupling is not P's or the sizes differ.
  BlockTriangularProduct(const BlockTriangularOperator& P, const SaddlePointOperator& K, bool single_precision = false);
  void apply(const Vector& v, Vector& z, Vector& w) const override {
    P_.apply_and_multiply(K_, v, z, w, single_);
  }
  bool single_precision() const override { return single_; }

 private:
  const BlockTriangularOperator& P_;
  const SaddlePointOperator& K_;
  bool single_;
};

/// A fixed number of Chebyshev semi-iteration steps for M z = r from z = 0, preconditioned by the
/// diagonal D of M (Golub and Varga; Wathen and Rees 2009), scaled by `scale`: z = scale p(D⁻¹M) D⁻¹ r.
/// With bounds [lo, hi] that contain the spectrum of D⁻¹M (for a finite element mass matrix, the
/// extreme eigenvalues of one element's D_e⁻¹M_e: Wathen 1987) it is a fixed symmetric positive
/// definite operator, an approximation of scale M⁻¹ whose error in the M-norm drops by the
/// Chebyshev factor 2 ρᵏ/(1 + ρ²ᵏ), ρ = (√κ - 1)/(√κ + 1), κ = hi/lo, after k steps. The products
/// with M use its values rounded to float (a mass matrix perturbed by 6e-8 relative: still fixed,
/// SPD and within the bounds to that accuracy), copied at construction; the vectors are double,
/// and each step is one pass over the rows. M must outlive this and keep its pattern (a new
/// matrix needs a new ChebyshevMassInverse).
class ChebyshevMassInverse final : public LinearOperator {
 public:
  /// Throws InputError for steps < 1, bounds not 0 < lo < hi, scale <= 0, or a non-positive diagonal.
  ChebyshevMassInverse(const Csr& M, double lo, double hi, int steps, double scale = 1.0);
  index_t rows() const override { return M_.rows(); }
  index_t cols() const override { return M_.cols(); }
  /// The factor scale (S ≈ M / scale: the pressure Schur complement's multiple of the mass).
  double scale() const { return scale_; }
  /// The number of Chebyshev steps.
  int steps() const { return steps_; }

 protected:
  void apply_impl(const Vector& r, Vector& z) const override;

 private:
  const Csr& M_;
  std::vector<float> values_;  // M's values in float
  Vector inv_diag_;
  double lo_, hi_, scale_;
  int steps_;
  mutable Vector res_, d_, d_next_;
};

/// The keys of mixed-minres and mixed-gmres beside their stopping rule and the displacement cycle's
/// keys.
struct MixedKrylovParams {
  /// Chebyshev steps of the pressure mass solve: 8 (MINRES took 55 iterations with 8 and 12, 69
  /// with 4, on the cubic bar of tests/multigrid/test_mixed.cpp at ν = 0.3).
  int pressure_steps = 8;
  /// Factor of the Schur complement's approximation S ≈ pressure_scale s M_p.
  double pressure_scale = 1.0;
  /// The keys pressure_steps and pressure_scale.
  void visit(ParamVisitor& v);
};

/// A Krylov method on a saddle point with a block preconditioner (the file comment), as a Solver set
/// up on a SaddlePointOperator: MINRES with diag(M_u, M_p) (`mixed-minres`), or GMRES with the block
/// upper-triangular P (`mixed-gmres`). M_u is a solver of the displacement block A (a multigrid
/// cycle: linear and symmetric, else InputError), set up and updated with this one; M_p is
/// `pressure_steps` Chebyshev steps on the pressure mass scaled by 1 / schur_scale. Registered by
/// the multigrid component, which builds M_u as mgpcg's cycle on the displacement levels.
class MixedKrylov final : public Solver {
 public:
  /// MINRES with the block-diagonal preconditioner, or GMRES with the block-triangular one.
  enum class Kind { minres, gmres };
  /// Takes ownership of the displacement block's solver and keeps a reference to the blocks, which
  /// must outlive it (their scale is read at each set-up and update). Throws InputError for a
  /// missing, nonlinear or nonsymmetric solver, blocks without a coupling or M_p, pressure_steps
  /// < 1 or restart < 1.
  MixedKrylov(Kind kind, const KrylovParams& params, std::unique_ptr<Solver> displacement,
              const SaddlePointBlocks& blocks, const MixedKrylovParams& mixed, const GmresParams& gmres = {});
  std::string name() const override { return kind_ == Kind::minres ? "mixed-minres" : "mixed-gmres"; }
  bool is_linear() const override { return false; }
  bool is_symmetric() const override { return false; }
  SolverNeeds needs() const override { return M_u_->needs(); }
  TimingBreakdown timings() const override { return M_u_->timings(); }
  TimingBreakdown setup_timings() const override { return M_u_->setup_timings(); }
  void reset_timings() const override { M_u_->reset_timings(); }
  std::string describe() const override;
  /// The stopping rules (read at each solve).
  KrylovParams& params() { return params_; }
  /// The displacement block's solver.
  const Solver& displacement_solver() const { return *M_u_; }

 protected:
  void setup_impl(const LinearOperator& K) override;
  void update_impl() override;
  void apply_impl(const Vector& b, Vector& x) const override;
  SolveResult solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const override;

 private:
  Kind kind_;
  KrylovParams params_;
  std::unique_ptr<Solver> M_u_;
  const SaddlePointBlocks* blocks_;  // the discretisation's: read at set-up and update
  MixedKrylovParams mixed_;
  GmresParams gmres_;
  std::unique_ptr<ChebyshevMassInverse> M_p_;
  std::unique_ptr<LinearOperator> P_;
  const BlockTriangularOperator* triangular_ = nullptr;  // P_ for GMRES
  mutable GmresWorkspace work_;  // kept between solves (time steps)
  void set_up_pressure();
};

}  // namespace pmg
