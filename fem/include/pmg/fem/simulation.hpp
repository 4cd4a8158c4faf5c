// pmg/fem/simulation.hpp — linearised implicit Euler for (corotational) elasticity, SPEC §5.
//
// Per step, with the rotations R of the current state (R = I for linear material):
//   (m M + s K_R) v⁺ = M v + Δt (f_ext + f_el(x)),   x⁺ = x + Δt v⁺,
//   m = 1 + Δt α,  s = Δt β + Δt²,   f_el = -Σ_e R K_e (Rᵀ x_e - X_e)
// (Rayleigh damping C = α M + β K_R; α = β = 0 by default), on the free nodes; clamped nodes keep
// zero velocity. Every level of the degree hierarchy gets the same m, s and R.
//
// A step only pays for what the scene uses: linear material computes no rotations and assembles
// the matrices once; a solver that needs no lower levels (CG, CHOLMOD) never assembles them.
#pragma once

#include "pmg/fem/hierarchy.hpp"
#include "pmg/sparse/cholmod_solver.hpp"
#include "pmg/sparse/krylov.hpp"
#include "pmg/sparse/preconditioners.hpp"

#include <algorithm>
#include <array>
#include <memory>
#include <string>

namespace pmg::fem {

/// Solves the step system A v = b on the finest level (A = the hierarchy's finest matrix).
class StepSolver {
 public:
  virtual ~StepSolver() = default;
  virtual std::string name() const = 0;
  /// Whether the hierarchy's lower levels must be assembled (multigrid).
  virtual bool needs_lower_levels() const { return false; }
  /// The matrices' values changed (patterns never do): refresh factorisations and smoothers.
  virtual void update(DegreeHierarchy& h) = 0;
  /// x holds the initial guess (the last velocity: a warm start) and receives the solution.
  /// Throws SolveError when the solve fails (divergence, breakdown, iteration limit).
  virtual SolveResult solve(const Bcsr& A, const Vector& b, Vector& x) = 0;
};

/// The step solvers' stopping rule: relative to the warm start's residual, with a floor at
/// 1e-12 ||b|| (a warm start can be so good that tol ||r_0|| lies below rounding).
inline KrylovParams with_rounding_floor(KrylovParams p, const Vector& b) {
  p.abs_tol = std::max(p.abs_tol, 1e-12 * b.norm());
  return p;
}

/// CG (fixed_iterations: the seed's "20 CG iterations" per step), block-Jacobi PCG or merged CG.
class KrylovStepSolver final : public StepSolver {
 public:
  enum class Kind { cg, block_jacobi_pcg, mcg };
  KrylovStepSolver(Kind kind, const KrylovParams& params) : kind_(kind), params_(params) {}
  std::string name() const override;
  void update(DegreeHierarchy& h) override;
  SolveResult solve(const Bcsr& A, const Vector& b, Vector& x) override;

 private:
  Kind kind_;
  KrylovParams params_;
  std::unique_ptr<BlockJacobiPreconditioner> jacobi_;
};

/// Sparse Cholesky: symbolic analysis once, numeric factorisation on each update.
class CholmodStepSolver final : public StepSolver {
 public:
  std::string name() const override { return "cholmod"; }
  void update(DegreeHierarchy& h) override;
  SolveResult solve(const Bcsr& A, const Vector& b, Vector& x) override;

 private:
  CholmodSolver chol_;
  bool analyzed_ = false;
};

struct SimulationParams {
  double dt = 0.01;
  double rayleigh_alpha = 0.0;  ///< C = α M + β K_R
  double rayleigh_beta = 0.0;
  bool corotational = true;
};

/// The stages of a step, timed separately.
enum Stage { kRotations, kAssembly, kHierarchy, kForces, kSolve, kNumStages };
const char* stage_name(int stage);

struct StepStats {
  int step = 0;
  double time = 0.0;                       ///< simulated time after the step
  std::array<double, kNumStages> seconds{};  ///< wall time per stage (0 when skipped)
  int iterations = 0;                      ///< iterations or cycles of the solve
  double rel_residual = 0.0;  ///< true residual of the solve relative to the warm start's
  double residual = 0.0;      ///< true residual ||b - A v|| / ||b||
};

class ImplicitEuler {
 public:
  /// f_ext: full external force vector (constant in time). The hierarchy is assembled here.
  ImplicitEuler(DegreeHierarchy& h, StepSolver& solver, const Vector& f_ext, const SimulationParams& p);

  /// Full displacement (3 per node) and velocity; fixed nodes must be zero in both.
  void set_state(const Vector& u, const Vector& v);
  const Vector& displacement() const { return u_; }
  const Vector& velocity() const { return v_; }
  double time() const { return t_; }
  int steps() const { return step_; }

  /// One step. Throws SolveError (with the step in the message) when the solve fails, and
  /// pmg::Error when the state turns non-finite.
  StepStats step();

  double kinetic_energy() const;  ///< ½ vᵀ M v (consistent mass)
  double elastic_energy() const;  ///< corotational (or linear) strain energy of the state
  double external_work() const;   ///< f_extᵀ u (the potential of the constant loads is -f_extᵀ u)
  double total_energy() const { return kinetic_energy() + elastic_energy() - external_work(); }

 private:
  void assemble_level(int level, const Rotations* R);

  DegreeHierarchy& h_;
  StepSolver& solver_;
  Vector f_ext_;
  SimulationParams p_;
  Vector u_, v_, v_free_;
  double t_ = 0.0;
  int step_ = 0;
  bool assembled_ = false;  ///< linear material: assembled once
};

}  // namespace pmg::fem
