// pmg/fem/mixed.hpp — mixed displacement–pressure elasticity on Taylor–Hood Bernstein–Bézier
// tetrahedra: displacement of degree k (2 or 3), continuous pressure of degree k - 1, on one mesh.
//
// With p = λ div u the elastic energy μ|ε|² + (λ/2)(div u)² becomes the saddle-point problem
//
//   2μ (ε(u), ε(v)) + (p, div v)      = f(v)        [ A  Bᵀ ] [u]   [f]
//   (div u, q)      - (p, q) / λ      = 0           [ B  -C ] [p] = [0]
//
// whose displacement block A is the elasticity operator with λ = 0 (E' = 2μ, ν' = 0): independent of
// ν, the operator that pmgkit's p-multigrid solves well. ν = 1/2 is allowed (C = 0). The pressure
// Schur complement S = C + B A⁻¹ Bᵀ lies between (1/λ + c β²/μ) M_p and (1/λ + 3/(2μ)) M_p (β the
// discrete inf-sup constant, c from Korn's inequality; (div u)² = (tr ε)² <= 3|ε|²), so it is
// replaced by (1/μ + 1/λ) M_p in the preconditioner (pmg/sparse/saddle_point.hpp). In a step
// system the mass m M also enters S (towards B (mM)⁻¹ Bᵀ for small steps or heavy material, the
// regime of Cahouet–Chabard preconditioners); the approximation ignores it.
//
// The system of an implicit-Euler step (SystemWeights m, s: mass m M + stiffness s A) keeps the
// saddle-point form with p̃ = s p:  [m M + s A, Bᵀ; B, -C/s] [u; p̃] = [f; 0],  S ≈ (1/μ + 1/λ) M_p / s.
//
// Closed-form element blocks (element.hpp's integrals):
//   B_e(b, 3a+c) = ∫ B^{k-1}_b ∂_c B^k_a = 6V Σ_i (∇λ_i)_c D(b, a, i),
//   D(b, a, i)   = k ∫ B^{k-1}_b B^{k-1}_{a-e_i} / (6V)  (0 where a_i = 0),
//   M_p,e        = 6V ∫ B^{k-1}_b B^{k-1}_b' / (6V),    C_e = M_p,e / λ.
#pragma once

#include "pmg/fem/hierarchy.hpp"
#include "pmg/fem/static_solve.hpp"
#include "pmg/sparse/csr.hpp"
#include "pmg/sparse/saddle_point.hpp"

#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace pmg {
class Config;
}

namespace pmg::fem {

/// The per-degree table of the divergence block (see the file comment), and the bounds of the
/// spectrum of D⁻¹M_p for the pressure mass (the extreme eigenvalues of one element's D_e⁻¹M_e: a
/// constant of the degree, since M_e is 6V times a table).
struct MixedTables {
  int k = 0;               ///< displacement degree
  int nu = 0;              ///< displacement nodes per element
  int np = 0;              ///< pressure nodes per element
  std::vector<double> D;   ///< D[(b nu + a) 4 + i]
  double mass_lo = 0.0;    ///< smallest eigenvalue of D_e⁻¹ M_e (pressure degree k - 1)
  double mass_hi = 0.0;    ///< largest
};
/// The tables of displacement degree k (2 or 3; InputError otherwise), built once.
const MixedTables& mixed_tables(int k);

/// The element divergence block B_e (np x 3 nu, node-major columns 3a + c).
void element_divergence(const MixedTables& t, const ElementGeometry& g, Eigen::MatrixXd& Be);

/// B and Bᵀ without a matrix (SaddlePointCoupling), from the BB derivative: div u of a degree-k
/// BB field is the degree-(k-1) BB field with coefficients d_c = k Σ_i ∇λ_i · u_{c+e_i}, so per
/// element  B_e u = 6V M̂ d  and  Bᵀ_e p: u_{c+e_i} += k (6V M̂ p)_c ∇λ_i  (M̂ the pressure mass
/// table): about 2 np² + 12 np multiply-adds per element and product (440 for cubics), against the
/// 3 np nu entries of B_e.
/// Each thread runs a contiguous range of elements into its own accumulators (summed after), as
/// ElasticityOperator does. Held components read and write zero. Holds references to the model
/// and the pressure space.
class DivergenceCoupling final : public SaddlePointCoupling {
 public:
  /// The coupling of the model's free displacement unknowns with every node of `pressure` (the same
  /// mesh, degree one less).
  DivergenceCoupling(const ElasticityModel& u, const BBSpace& pressure);
  index_t rows() const override { return pressure_.num_nodes(); }
  /// The model's free unknowns.
  index_t cols() const override { return u_.num_free_dofs(); }
  void apply(const double* x_u, const double* x_p, double* y_u, double* y_p) const override;
  /// Corotational coupling: B_R,e = B_e R_eᵀ (the divergence of the element's displacement rotated
  /// back), which is B_e with each gradient ∇λ_i replaced by R_e ∇λ_i, as the stiffness of
  /// ElasticityModel::evaluate. nullptr: R = I. The rotations must outlive their use.
  void set_rotations(const Rotations* R) { R_ = R; }
  /// The rotations set (nullptr: none).
  const Rotations* rotations() const { return R_; }
  /// The divergence of a state at rotations R (one per element; nullptr: R = I, whatever
  /// set_rotations() gave): g = Σ_e B_e (R_eᵀ x_e - X_e) over every node of each element (fixed ones
  /// at their positions), x = X + u_full; with no rotations, Σ_e B_e u_e. One value per pressure
  /// node; the constraint of a state is g(u) = C p.
  void state_divergence(const Vector& u_full, const Rotations* R, Vector& g) const;

 private:
  const ElasticityModel& u_;
  const Rotations* R_ = nullptr;
  const BBSpace& pressure_;
  std::vector<int> raise_;     ///< raise_[c 4 + i]: the degree-k local index of c + e_i
  std::vector<double> mass_;   ///< M̂, row-major
  const std::vector<index_t>* free_ = nullptr;                 ///< the model's free numbering
  const std::vector<char>* held_ = nullptr;                    ///< its held components
  std::vector<index_t> dofs_;  ///< per element and node: 3 x its free index, or -1 (fixed)
  std::vector<char> has_held_;  ///< per element: 1 where a node of it has a held component
  mutable std::vector<double> bufp_, bufu_;  ///< the accumulators of threads 1.. (n_p and n_u each)
  mutable std::mutex buffers_mutex_;
  /// element(e, yu, yp) for every element, each thread over a contiguous range into its own
  /// accumulators (thread 0 into y_u and y_p themselves), summed after: y_p is set, y_u added to;
  /// a null output is neither written nor passed on.
  template <class Element>
  void over_elements(double* y_u, double* y_p, const Element& element) const;
  template <int K>
  void element(index_t e, const double* x_u, const double* x_p, double* y_u, double* y_p) const;
  template <int K>
  void element_state(index_t e, const double* u_full, const Rotations* R, double* g) const;
  /// The element's gradients ∇λ_i, rotated to R_e ∇λ_i when rotations are set.
  void gradients(index_t e, double gr[4][3]) const;
  /// y_p += 6V M̂ d with d_c = k Σ_i gr_i · w_{c+e_i}: the divergence of the element's BB field w
  /// (its nodes' vectors) tested against its pressure nodes pn.
  template <int K>
  void add_divergence(const double gr[4][3], const double (*w)[3], double v6, const index_t* pn, double* y_p) const;
};

/// Checks a material for the mixed formulation: E > 0, ν in (0, 1/2] (1/2 allowed: C = 0; λ > 0),
/// ρ >= 0.
void check_mixed_material(const Material& m);

/// Mixed elasticity on one mesh (see the file comment): the displacement degree hierarchy on the
/// shear material (E' = 2μ, ν' = 0) with the clamp and held components, the pressure space of
/// degree k - 1 (every node free), C and M_p assembled, B and Bᵀ matrix-free (coupling()) and
/// assembled on first use (divergence()). A held displacement component has a zero column in B. Holds references to the mesh, which must outlive it.
class MixedElasticity {
 public:
  /// Throws InputError for a degree other than 2 or 3 and for a material out of range
  /// (check_mixed_material); MeshError for a degenerate element.
  MixedElasticity(const TetMesh& mesh, int degree, const Material& material, std::vector<char> clamped,
                  std::vector<char> components = {});
  /// The same on a displacement hierarchy built elsewhere (a scene's set-up) on shear_material(
  /// material), which it uses without a copy and which must outlive it. Throws InputError for a
  /// hierarchy of another degree or material.
  MixedElasticity(const Material& material, DegreeHierarchy& hierarchy);
  MixedElasticity(const MixedElasticity&) = delete;
  MixedElasticity& operator=(const MixedElasticity&) = delete;

  /// The material (ν up to 1/2).
  const Material& material() const { return material_; }
  /// The material of the displacement block: E' = 2μ, ν' = 0, the same density.
  static Material shear_material(const Material& m);
  /// The displacement levels (degree k down to 1) on the shear material.
  DegreeHierarchy& hierarchy() { return *hierarchy_; }
  /// The displacement levels.
  const DegreeHierarchy& hierarchy() const { return *hierarchy_; }
  /// The pressure's BB space (degree k - 1).
  const BBSpace& pressure_space() const { return pressure_; }
  /// Unknowns of the displacement block (3 per free node).
  index_t num_displacement() const { return hierarchy_->finest().num_free_dofs(); }
  /// Unknowns of the pressure (one per node).
  index_t num_pressure() const { return pressure_.num_nodes(); }
  /// Both.
  index_t num_unknowns() const { return num_displacement() + num_pressure(); }
  /// B (pressure x displacement) and Bᵀ assembled (on first use: direct solvers and tests; the
  /// iterative solve multiplies with coupling()), C = M_p / λ (nullptr at ν = 1/2) and M_p.
  const Csr& divergence() const;
  /// Bᵀ assembled (on first use).
  const Csr& divergence_transpose() const;
  /// B and Bᵀ matrix-free (DivergenceCoupling), rotated where set_rotations() gave rotations.
  const SaddlePointCoupling& coupling() const { return *coupling_; }
  /// Corotational coupling (DivergenceCoupling::set_rotations): coupling() becomes B_R; the
  /// assembled divergence() stays the linear B. nullptr: linear. The rotations must outlive their
  /// use.
  void set_rotations(const Rotations* R) { coupling_->set_rotations(R); }
  /// The rotations set_rotations() gave (nullptr: none).
  const Rotations* coupling_rotations() const { return coupling_->rotations(); }
  /// g(u) = Σ_e B_e (R_eᵀ x_e - X_e) of a full displacement at rotations R (nullptr: B u), one
  /// value per pressure node (DivergenceCoupling::state_divergence); the constraint of a state is
  /// g(u) = C p.
  Vector state_divergence(const Vector& u_full, const Rotations* R = nullptr) const;
  /// The pressure of a displacement at rotations R (nullptr: linear): p with C p = g(u) (M_p p =
  /// λ g(u), solved by CG to 1e-12 with the Chebyshev mass preconditioner). Throws InputError at
  /// ν = 1/2 (the pressure is not a function of the state there).
  Vector pressure_of(const Vector& u_full, const Rotations* R = nullptr) const;
  /// p with C p = g for a divergence g (one value per pressure node): pressure_of()'s solve.
  Vector pressure_from_divergence(const Vector& g) const;
  /// C = M_p / (λ s) at the weights' stiffness s (nullptr at ν = 1/2).
  const Csr* compressibility() const { return lambda_inverse_ > 0 ? &C_ : nullptr; }
  /// The pressure mass M_p.
  const Csr& pressure_mass() const { return Mp_; }
  /// The weights of the displacement block m M + s A (static: (0, 1)); C and the Schur scale follow
  /// (the file comment). Throws InputError for s <= 0 or m < 0.
  void set_weights(SystemWeights w);
  /// The weights of the last set_weights() ((0, 1) before).
  SystemWeights weights() const { return weights_; }
  /// What a saddle-point solver reads (SolverContext::saddle_point): the blocks, the mass bounds
  /// and the Schur complement's scale 1/μ + 1/λ.
  const SaddlePointBlocks& blocks() const { return blocks_; }
  /// The right-hand side (f|free with held components zero; 0 for the pressure) of a full load.
  Vector rhs(const Vector& f_full) const;
  /// The whole system K assembled as one scalar matrix (displacement first), for direct solvers:
  /// the finest displacement matrix is assembled for it (linear elasticity).
  Csr assembled_system();
  /// The pressure p (one value per pressure node) raised to the displacement's degree: one BB
  /// coefficient per displacement node, the same polynomial (degree elevation is exact), for VTK.
  Vector pressure_on_displacement_nodes(const Vector& p) const;
  /// The pressure (one value per pressure node) at barycentric point l of element e.
  double pressure_at(const Vector& p, index_t e, const Eigen::Vector4d& l) const;

 private:
  Material material_;
  std::unique_ptr<DegreeHierarchy> owned_;  ///< the first constructor's hierarchy
  DegreeHierarchy* hierarchy_;              ///< owned_ or the caller's
  BBSpace pressure_;
  double lambda_inverse_ = 0.0;
  SystemWeights weights_;
  mutable std::once_flag divergence_once_;
  mutable Csr B_, Bt_;
  mutable std::once_flag elevation_once_;
  mutable Csr elevation_;  ///< pressure -> displacement degree (pressure_on_displacement_nodes)
  Csr C_, Mp_;
  std::unique_ptr<DivergenceCoupling> coupling_;
  SaddlePointBlocks blocks_;
  void assemble_divergence() const;
  void assemble_pressure_mass();
};

/// A saddle-point solver set up on a MixedElasticity's system at its weights, through the factory
/// (`mixed-gmres` by default): a method on the levels (registry: uses_levels) multiplies with the
/// operator [A, Bᵀ; B, -C] (A matrix-free where the method reads operators), any other (a direct
/// solver) factorises the assembled saddle point. The binding of the displacement hierarchy is kept
/// for the finest mass and the elastic force of a state (the time step of pmg/fem/mixed_euler.hpp).
/// Holds a reference to the mixed system, which must outlive it; call set_weights() before.
class MixedSolver {
 public:
  /// Makes and sets up the solver the config names; `corotational`: it will be rotate()d. Throws
  /// InputError for a method that cannot solve a saddle point, and, before any factorisation, for a
  /// direct method with `corotational` (it factorises the linear saddle point once); and what the
  /// set-up throws.
  MixedSolver(MixedElasticity& m, const Config& config, bool corotational = false);
  ~MixedSolver();
  MixedSolver(const MixedSolver&) = delete;
  MixedSolver& operator=(const MixedSolver&) = delete;
  /// Brings the system to the rotations R (nullptr: linear): the coupling rotated, the displacement
  /// levels the solver reads prepared at R and the system's weights (the finest too unless `finest`
  /// is false: a caller whose BoundSystem::evaluate() brought it there), the solver updated.
  /// Throws InputError for a solver not made `corotational`.
  void rotate(const Rotations* R, bool finest = true);
  /// Solves K x = b from the guess x (displacement first, then p̃ = s p).
  SolveResult solve(const Vector& b, Vector& x, SolveMonitor* monitor = nullptr);
  /// ‖b − K x‖ with K the system the solver was set up on.
  double residual_norm(const Vector& b, const Vector& x) const;
  /// The solver ("name: description").
  std::string description() const;
  /// Seconds of the levels' preparation and the solver's set-up.
  double setup_seconds() const { return setup_seconds_; }
  /// The displacement hierarchy bound to the solver (its mass, a state's force and energy).
  BoundSystem& bound() { return *bound_; }
  /// The solver.
  Solver& solver() { return *solver_; }

 private:
  MixedElasticity& m_;
  std::unique_ptr<Solver> solver_;
  std::unique_ptr<BoundSystem> bound_;
  std::unique_ptr<SaddlePointOperator> K_;
  Csr assembled_;
  double setup_seconds_ = 0.0;
};

/// What a mixed static solve reports.
struct MixedResult {
  Vector u;                ///< full displacement (3 per node, zero on the fixed nodes)
  Vector p;                ///< pressure, one per pressure node (p̃ / s: the pressure itself)
  SolveResult solve;       ///< iterations and residuals of the whole system's (last) solve
  int fixed_point_iterations = 1;  ///< corotational fixed-point iterations (1: linear)
  long solver_iterations = 0;      ///< the solver's iterations summed over them
  double setup_seconds = 0.0;  ///< the levels prepared and the solver set up
  double solve_seconds = 0.0;  ///< the solve
  std::string description; ///< the solver's name and description
};

/// The solve of the mixed system at its weights (static, or one implicit-Euler step's system) for
/// the full load f_full with the solver the config names (the factory; `mixed-gmres` by default,
/// or a direct method such as mumps on the assembled system). Linear: one solve. Corotational
/// (`corotational` true, the operator route only): the fixed point of pmg/fem/static_solve.hpp on
/// (u, p) — with R from u_k, the system at R solved for the correction of
///   [K_R  B_Rᵀ] [δu]   [ (f_ext + f_el(u_k))|free - B_Rᵀ p_k ]
///   [B_R  -C  ] [δp] = [ C p_k - g(u_k)                     ],
/// f_el the deviatoric force -Σ_e R K_e (Rᵀ x_e - X_e), g(u) = Σ_e B_e (R_eᵀ x_e - X_e), until
/// ‖δu‖ <= fixed_point.corotational_tol ‖u‖ (relaxed as there). Throws InputError for a load of the
/// wrong size or with NaN/Inf, no free unknown, or a static system with nothing fixed; what the
/// solver throws (SolveError on failure); pmg::Error when the fixed point does not converge. At
/// ν = 1/2 with every boundary node fixed the pressure is defined up to a constant: MINRES still
/// returns a solution of the singular system.
MixedResult solve_mixed_static(MixedElasticity& m, const Vector& f_full, const Config& solver,
                               SolveMonitor* monitor = nullptr, bool corotational = false,
                               const StaticOptions& fixed_point = {});

}  // namespace pmg::fem
