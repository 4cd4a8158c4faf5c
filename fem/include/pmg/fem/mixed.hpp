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
/// Element colours (BlockAssembler) keep the scatters race-free. Held components read and write
/// zero. Holds references to the model and the pressure space.
class DivergenceCoupling final : public SaddlePointCoupling {
 public:
  /// The coupling of the model's free displacement unknowns with every node of `pressure` (the same
  /// mesh, degree one less).
  DivergenceCoupling(const ElasticityModel& u, const BBSpace& pressure);
  index_t rows() const override { return pressure_.num_nodes(); }
  /// The model's free unknowns.
  index_t cols() const override { return u_.num_free_dofs(); }
  void apply(const double* x_u, const double* x_p, double* y_u, double* y_p) const override;

 private:
  const ElasticityModel& u_;
  const BBSpace& pressure_;
  std::vector<int> raise_;     ///< raise_[c 4 + i]: the degree-k local index of c + e_i
  std::vector<double> mass_;   ///< M̂, row-major
  const std::vector<index_t>* free_ = nullptr;                 ///< the model's free numbering
  const std::vector<char>* held_ = nullptr;                    ///< its held components
  const std::vector<std::vector<index_t>>* colors_ = nullptr;  ///< its element colours
  template <int K>
  void element(index_t e, const double* x_u, const double* x_p, double* y_u, double* y_p) const;
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
  /// B and Bᵀ matrix-free (DivergenceCoupling).
  const SaddlePointCoupling& coupling() const { return *coupling_; }
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
  Csr C_, Mp_;
  std::unique_ptr<DivergenceCoupling> coupling_;
  SaddlePointBlocks blocks_;
  void assemble_divergence() const;
  void assemble_pressure_mass();
};

/// What a mixed static solve reports.
struct MixedResult {
  Vector u;                ///< full displacement (3 per node, zero on the fixed nodes)
  Vector p;                ///< pressure, one per pressure node (p̃ / s: the pressure itself)
  SolveResult solve;       ///< iterations and residuals of the whole system's solve
  double setup_seconds = 0.0;  ///< the levels prepared and the solver set up
  double solve_seconds = 0.0;  ///< the solve
  std::string description; ///< the solver's name and description
};

/// The linear solve of the mixed system at its weights (static, or one implicit-Euler step's
/// system) for the full load f_full with the solver the config names (the factory; `mixed-minres`
/// by default, or a direct method such as mumps on the assembled system). Throws InputError for a
/// load of the wrong size or with NaN/Inf, no free unknown, or a static system with nothing fixed,
/// and what the solver throws (SolveError on failure). At ν = 1/2 with every boundary node fixed the
/// pressure is defined up to a constant: MINRES still returns a solution of the singular system.
MixedResult solve_mixed_static(MixedElasticity& m, const Vector& f_full, const Config& solver,
                               SolveMonitor* monitor = nullptr);

}  // namespace pmg::fem
