// pmg/fem/mixed_euler.hpp — implicit Euler for the mixed displacement–pressure elasticity of
// pmg/fem/mixed.hpp (linear material): the velocity v⁺ and the pressure p⁺ of the new state solve
// one saddle point per step,
//
//   M (v⁺ - v) / Δt = f_ext - A u⁺ - Bᵀ p⁺ - α M v⁺,     B u⁺ - C p⁺ = 0,     u⁺ = u + Δt v⁺,
//
// that is, with m = 1 + Δt α, s = Δt² and p̃ = Δt p⁺ (MixedElasticity::set_weights(m, s)):
//
//   [ m M + s A   Bᵀ  ] [v⁺]   [ M v + Δt (f_ext - A u) ]
//   [ B         -C/s  ] [p̃ ] = [ -B u / Δt              ].
//
// A is the deviatoric operator (λ = 0) on the displacement hierarchy, so the displacement block is
// the one the p-multigrid solves for the displacement-only step; the constraint is imposed on the
// new state itself, so B u⁺ = C p⁺ holds to the solve's tolerance at every step (no drift of the
// volume). The elastic energy of a state is ½ uᵀ A u + ½ pᵀ C p (p = λ div u in the discrete
// sense; at ν = 1/2 only the first term). Stiffness-proportional Rayleigh damping (β) would need a
// viscous pressure and is refused; mass-proportional damping (α) is allowed.
//
// Corotational material (SimulationParams::corotational): with the rotations R of the current state
// (one per element, ElasticityModel::rotations) A becomes K_R, B becomes B_R = B_e R_eᵀ per element,
// the force is the corotated deviatoric one and the constraint is on the corotated state:
//
//   [ m M + s K_R   B_Rᵀ ] [v⁺]   [ M v + Δt (f_ext + f_el(u)) ]
//   [ B_R         -C/s  ] [p̃ ] = [ -g(u) / Δt                 ],
//
// f_el(u) = -Σ_e R K_e (Rᵀ x_e - X_e) (deviatoric), g(u) = Σ_e B_e (R_eᵀ x_e - X_e): the linearised
// step of pmg/fem/simulation.hpp with the pressure's incompressibility on the rotated-back strain.
// Per step the finest level is brought to R in the pass that gives f_el and the energy, the lower
// levels and the coupling follow, and the solver is updated (the operator route, mixed-gmres or mixed-minres,
// only). Linear material: the solver is set up once; each step's solve is warm-started from the
// last velocity and pressure.
#pragma once

#include "pmg/fem/mixed.hpp"
#include "pmg/fem/simulation.hpp"

#include <memory>

namespace pmg {
class Config;
}

namespace pmg::fem {

/// Implicit Euler on the mixed formulation (see the file comment). Holds references to the mixed
/// system, which must outlive it; it sets the system's weights to the step's (and its coupling's
/// rotations to each state's) while it lives, and restores the weights and clears its rotations
/// when it dies.
class MixedEuler {
 public:
  /// f_ext: full external force (constant in time). The step solver is the one the config names
  /// (mixed-gmres by default; a rounding floor rhs_floor = 1e-12 is added for warm starts where
  /// the method reads it), set up here. Throws InputError for the checks of check_simulation(),
  /// stiffness-proportional damping (not built), corotational material with a direct solver
  /// (before any factorisation), and what the solver's set-up throws.
  MixedEuler(MixedElasticity& m, const Config& solver, const Vector& f_ext, const SimulationParams& p);
  ~MixedEuler();
  MixedEuler(const MixedEuler&) = delete;
  MixedEuler& operator=(const MixedEuler&) = delete;

  /// The state: full displacement and velocity (check_state()), and the pressure of u (one value
  /// per pressure node; empty: the pressure of u, C p = g(u) at u's rotations, zero for a state at
  /// rest). The pressure only enters the elastic energy of this state and the first solve's guess:
  /// every step imposes the constraint. Throws InputError (the state unchanged) for a bad state,
  /// and for a deformed u without a pressure at ν = 1/2.
  void set_state(const Vector& u, const Vector& v, const Vector& p = {});
  /// Current full displacement (3 per node, zero on clamped nodes).
  const Vector& displacement() const { return u_; }
  /// Current full velocity.
  const Vector& velocity() const { return v_; }
  /// Current pressure, one value per pressure node (Pa).
  const Vector& pressure() const { return pressure_; }
  double time() const { return t_; }   ///< simulated time, seconds
  int steps() const { return step_; }  ///< steps done

  /// One step. Throws SolveError (naming the step) when the solve fails, and pmg::Error when the
  /// state turns non-finite.
  StepStats step();

  double kinetic_energy() const;  ///< ½ vᵀ M v
  /// ½ uᵀ A u + ½ pᵀ C p (see the file comment).
  double elastic_energy() const;
  double external_work() const;   ///< f_extᵀ u
  /// Seconds of the solver's set-up (once).
  double setup_seconds() const;
  /// The step solver ("name: description").
  std::string description() const;

 private:
  MixedElasticity& m_;
  SimulationParams params_;
  SystemWeights weights_before_;  ///< the system's weights before: restored by the destructor
  std::unique_ptr<MixedSolver> solver_;
  Vector f_ext_, f_free_;  ///< full, and on the free unknowns (held components zero)
  Vector u_, v_, pressure_;  ///< full displacement and velocity, pressure
  Vector x_;               ///< the last solution (v⁺, p̃): the next guess
  double t_ = 0.0;
  int step_ = 0;
  mutable bool energy_valid_ = false;  ///< force_, energy_ (and R_) are the current u's
  mutable bool levels_current_ = true; ///< lower levels, coupling and solver at R_ (corotational)
  mutable Rotations R_;                ///< the current state's rotations (corotational)
  mutable double rotations_s_ = 0.0, finest_s_ = 0.0, force_s_ = 0.0;  ///< the last evaluate()'s stages
  mutable double energy_ = 0.0;
  mutable Vector force_;               ///< -A u (full) of the current u
  void evaluate() const;
};

}  // namespace pmg::fem
