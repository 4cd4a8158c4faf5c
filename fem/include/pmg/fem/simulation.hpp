// pmg/fem/simulation.hpp — linearised implicit Euler for (corotational) elasticity (docs/method.md §3).
//
// Per step, with the rotations R of the current state (R = I for linear material):
//   (m M + s K_R) v⁺ = M v + Δt (f_ext + f_el(x)),   x⁺ = x + Δt v⁺,
//   m = 1 + Δt α,  s = Δt β + Δt²,   f_el = -Σ_e R K_e (Rᵀ x_e - X_e)
// (Rayleigh damping C = α M + β K_R; α = β = 0 by default), on the free nodes; clamped nodes keep
// zero velocity. Every level of the degree hierarchy gets the same m, s and R.
//
// A step only pays for what the scene uses: linear material computes no rotations and assembles
// the matrices once; a solver that needs no lower levels (CG, CHOLMOD) never assembles them.
// Everything the state x contributes — its rotations, the finest matrix, the elastic force and the
// elastic energy — comes from one pass over the elements (ElasticityModel::evaluate), made once
// per state: by step(), or earlier by elastic_energy(), whose pass the next step then reuses. So
// recording the energy after every step costs nothing extra, and the finest matrix in the
// hierarchy may already be the next step's once the energy of the new state has been asked for.
//
// The hierarchy bound to the solver (BoundSystem, pmg/fem/bound_system.hpp) decides what a step
// prepares, from what the solver needs. With a matrix-free multigrid (operator=matrix-free) the levels of
// degree >= 2 are ElasticityOperators: a step rotates their stored gradients instead of
// assembling them, assembles the linear level only, and takes the force from the finest operator.
//
// The step system is solved by any Solver (pmg/sparse/solver.hpp; build one with
// pmg::make_solver, giving the hierarchy as its levels): set up on the first step, update()d when
// the matrices change. The solve is warm-started from the last velocity; give the solver a
// rounding floor (rhs_floor, e.g. 1e-12) so that a step whose warm start is already within
// rounding of the solution ends at once.
#pragma once

#include "pmg/fem/bound_system.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/sparse/solver.hpp"

#include <algorithm>
#include <array>
#include <memory>
#include <string>

namespace pmg::fem {

/// Parameters of ImplicitEuler (the step equation is in the file comment).
struct SimulationParams {
  /// Time step Δt in seconds (> 0, else the ImplicitEuler constructor throws InputError).
  double dt = 0.01;
  double rayleigh_alpha = 0.0;  ///< mass-proportional damping α in C = α M + β K_R (>= 0, 1/s)
  /// Rayleigh stiffness-proportional damping β in C = α M + β K_R (>= 0, seconds).
  double rayleigh_beta = 0.0;
  /// Corotational material (rotations per state); false: linear material, matrices assembled once.
  bool corotational = true;
};

/// The weights of the implicit-Euler step matrix  mass M + stiffness K_R.
struct StepWeights {
  double mass = 1.0;       ///< 1 + Δt α
  double stiffness = 0.0;  ///< Δt β + Δt²
};
/// The step matrix's weights for these parameters (the one formula, for steps and for tools that
/// build the system of one step).
StepWeights step_weights(const SimulationParams& p);
/// The largest time step whose step matrix M + (Δt β + Δt²) K stays far inside double range for
/// stiffness entries that scale with Young's modulus `young` (the largest of the model's): the Δt
/// with (Δt β + Δt²) max(E, 1) = 1e300. Scenes and the ImplicitEuler constructor refuse larger ones.
double max_time_step(double young, double rayleigh_beta = 0.0);

/// The checks of a time-stepping set-up, for ImplicitEuler and any other stepper of the same
/// equation: f_ext has the model's full size, Δt > 0 and below max_time_step(), damping >= 0 and
/// finite, density > 0. Throws InputError naming what is wrong.
void check_simulation(const ElasticityModel& m, const Vector& f_ext, const SimulationParams& p);
/// The checks of an initial state: full vectors of the model's size, finite, clamped nodes at
/// rest. Throws InputError naming what is wrong.
void check_state(const ElasticityModel& m, const Vector& u, const Vector& v);
/// The stages of a step, timed separately.
enum Stage { kRotations, kAssembly, kHierarchy, kForces, kSolve, kNumStages };
/// Display name of a Stage ("rotations", "finest matrix", ...); stage must be below kNumStages.
const char* stage_name(int stage);

/// What one ImplicitEuler::step() did: where the state is now and what the solve cost.
struct StepStats {
  int step = 0;  ///< number of the step just done (1 for the first)
  double time = 0.0;                       ///< simulated time after the step
  std::array<double, kNumStages> seconds{};  ///< wall time per stage (0 when skipped)
  int iterations = 0;                      ///< iterations or cycles of the solve
  double rel_residual = 0.0;  ///< true residual of the solve relative to its start (warm or zero)
  double residual = 0.0;      ///< true residual ||b - A v|| / ||b|| (<= 2 tol: see step())
};

/// A step's solve into its StepStats: iterations, rel_residual and residual = ‖b − A v‖ / ‖b‖ (from
/// the true residual relative to the initial one; the recursive one for fixed-iteration runs).
void record_solve(StepStats& st, const SolveResult& res, double b_norm);
/// Closes a step of any stepper: the clock t advanced by dt, the step counted, and the step's
/// StepStats given its number, time and solve (record_solve).
void finish_step(StepStats& st, int& step, double& t, double dt, const SolveResult& res, double b_norm);
class StepPart;
class EulerStep;

/// Linearised implicit Euler time stepping of (corotational) elasticity on a degree hierarchy
/// (see the file comment): the step of pmg/fem/euler_step.hpp on one process. Holds references to
/// the hierarchy and the solver, which must outlive it.
class ImplicitEuler {
 public:
  /// f_ext: full external force vector (constant in time). The hierarchy is assembled here.
  /// The solver is set up on the finest matrix at the first step (its levels, if it uses any,
  /// must be h).
  ImplicitEuler(DegreeHierarchy& h, Solver& solver, const Vector& f_ext, const SimulationParams& p);
  ~ImplicitEuler();
  ImplicitEuler(const ImplicitEuler&) = delete;
  ImplicitEuler& operator=(const ImplicitEuler&) = delete;

  /// Full displacement (3 per node) and velocity; fixed nodes must be zero in both.
  void set_state(const Vector& u, const Vector& v);
  /// Current full displacement u (3 per node, zero on clamped nodes).
  const Vector& displacement() const;
  /// Current full velocity v (3 per node, zero on clamped nodes).
  const Vector& velocity() const { return v_; }
  /// Simulated time in seconds (dt per step done).
  double time() const;
  /// Number of steps done since construction.
  int steps() const;

  /// One step. Throws SolveError (with the step in the message) when the solve fails, and
  /// pmg::Error when the state turns non-finite.
  StepStats step();

  double kinetic_energy() const;  ///< ½ vᵀ M v (consistent mass)
  /// Corotational (or linear) strain energy of the state, from the pass the next step uses.
  double elastic_energy() const;
  double external_work() const;   ///< f_extᵀ u (the potential of the constant loads is -f_extᵀ u)
  /// Total energy of the state: kinetic_energy() + elastic_energy() - external_work().
  double total_energy() const { return kinetic_energy() + elastic_energy() - external_work(); }
  /// The hierarchy bound to the step's solver (what a step prepares; its notes for reports).
  const BoundSystem& bound_system() const { return system_; }

 private:
  DegreeHierarchy& h_;
  mutable BoundSystem system_;  ///< the seam: what the solver reads of the hierarchy, kept current
  std::unique_ptr<StepPart> part_;  ///< one process: owned = free vectors, sums are values
  std::unique_ptr<EulerStep> step_;
  Vector v_;  ///< the full velocity
};

}  // namespace pmg::fem
