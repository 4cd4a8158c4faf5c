#include "pmg/fem/mixed_euler.hpp"

#include "pmg/sparse/config.hpp"
#include "pmg/sparse/factory.hpp"
#include "pmg/sparse/threads.hpp"
#include "pmg/sparse/timer.hpp"

#include <cmath>
#include <string>

namespace pmg::fem {

namespace {

/// The step solver's options: the config's, with a rounding floor for warm starts where the method
/// reads one (a step whose guess is already within rounding of the solution ends at once). The
/// methods are registered by the caller (pmg::register_all_solvers), as for make_solver.
Config step_config(const Config& c) {
  Config out = c.clone();
  if (method_accepts_key(out.get_string("method", "mixed-gmres"), "rhs_floor")) out.set_default("rhs_floor", "1e-12");
  return out;
}

/// The system's weights set to the step's: m = 1 + Δt α, s = Δt² (no stiffness damping).
void set_step_weights(MixedElasticity& m, const SimulationParams& p, const Vector& f_ext) {
  check_simulation(m.hierarchy().finest(), f_ext, p);
  if (p.rayleigh_beta != 0)
    throw InputError("mixed time step: stiffness-proportional Rayleigh damping (beta) is not built for the mixed "
                     "formulation (it needs a viscous pressure); use rayleigh_alpha");
  const StepWeights w = step_weights(p);
  m.set_weights({w.mass, w.stiffness});
}

}  // namespace

MixedEuler::MixedEuler(MixedElasticity& m, const Config& solver, const Vector& f_ext, const SimulationParams& p)
    : m_(m), params_(p), weights_before_(m.weights()), f_ext_(f_ext) {
  const ElasticityModel& model = m_.hierarchy().finest();
  if (m_.num_displacement() == 0)
    throw InputError("mixed time step: every displacement node is fixed: nothing moves");
  set_step_weights(m_, p, f_ext);
  try {
    solver_ = std::make_unique<MixedSolver>(m_, step_config(solver), p.corotational);
  } catch (...) {
    m_.set_weights(weights_before_);
    throw;
  }
  f_free_ = model.restrict_to_free(f_ext);
  u_ = v_ = Vector::Zero(model.num_dofs());
  pressure_ = Vector::Zero(m_.num_pressure());
  x_ = Vector::Zero(m_.num_unknowns());
}

MixedEuler::~MixedEuler() {
  // The system as it was lent: its weights, and no rotations pointing into R_, which dies here.
  if (m_.coupling_rotations() == &R_) m_.set_rotations(nullptr);
  m_.set_weights(weights_before_);
}

void MixedEuler::set_state(const Vector& u, const Vector& v, const Vector& p) {
  const ElasticityModel& model = m_.hierarchy().finest();
  check_state(model, u, v);
  if (p.size() != 0 && p.size() != m_.num_pressure())
    throw InputError("mixed time step: the pressure has " + std::to_string(p.size()) + " values for " +
                     std::to_string(m_.num_pressure()) + " pressure nodes");
  if (!p.allFinite()) throw InputError("mixed time step: the initial pressure is not finite");
  const bool deformed = !u.isZero(0.0);
  Vector pressure = p;  // from the state where not given (pressure_of refuses nu = 0.5)
  if (pressure.size() == 0) {
    if (!deformed) pressure = Vector::Zero(m_.num_pressure());
    else if (!params_.corotational) pressure = m_.pressure_of(u);
    else {
      const Rotations R = model.rotations(u);  // g(u) at u's own rotations
      pressure = m_.pressure_of(u, &R);
    }
  }
  u_ = u;
  v_ = v;
  pressure_ = std::move(pressure);
  energy_valid_ = false;
  x_.head(m_.num_displacement()) = model.restrict_to_free(v);
  x_.tail(m_.num_pressure()) = params_.dt * pressure_;
}

void MixedEuler::evaluate() const {
  if (energy_valid_) return;
  force_.resize(u_.size());
  if (params_.corotational) {
    // The state's rotations; the finest operator brought to them in the pass that gives the force
    // and the energy (the next step's operator, as in ImplicitEuler).
    const auto t0 = Clock::now();
    R_ = m_.hierarchy().finest().rotations(u_);
    rotations_s_ = seconds_since(t0);
    const EvaluateSeconds es = solver_->bound().evaluate(u_, &R_, m_.weights(), &force_, &energy_, true);
    finest_s_ = es.finest;
    force_s_ = es.force;
    levels_current_ = false;
  } else {
    // -A u and ½ uᵀ A u in one pass over the elements; the operator itself is current (linear).
    const EvaluateSeconds es = solver_->bound().evaluate(u_, nullptr, m_.weights(), &force_, &energy_, false);
    rotations_s_ = 0.0;
    finest_s_ = 0.0;
    force_s_ = es.force;
  }
  energy_valid_ = true;
}

StepStats MixedEuler::step() {
  const ThreadBudget budget;
  const ElasticityModel& model = m_.hierarchy().finest();
  const index_t nu = m_.num_displacement(), np = m_.num_pressure();
  const double dt = params_.dt;
  const std::string name = "step " + std::to_string(step_ + 1);
  StepStats st;
  // The state's force and energy (and rotations: the finest operator with them), then the lower
  // levels, the coupling and the solver at the same rotations.
  evaluate();  // (or elastic_energy() did, after the last step: its seconds are this step's)
  st.seconds[kRotations] = rotations_s_;
  st.seconds[kAssembly] = finest_s_;
  st.seconds[kForces] = force_s_;
  if (!levels_current_) {
    const auto t0 = Clock::now();
    solver_->rotate(&R_, false);
    levels_current_ = true;
    st.seconds[kHierarchy] = seconds_since(t0);
  }
  // b = (M v + Δt (f_ext + f_el(u)), -g(u) / Δt) on the free unknowns (held components zero).
  auto t0 = Clock::now();
  const Vector v_free = model.restrict_to_free(v_);
  Vector b(nu + np), mv(nu);
  solver_->bound().mass().apply(v_free, mv);
  b.head(nu) = mv + dt * (f_free_ + model.restrict_to_free(force_));
  b.tail(np) = -m_.state_divergence(u_, params_.corotational ? &R_ : nullptr) / dt;
  st.seconds[kForces] += seconds_since(t0);

  t0 = Clock::now();
  const double bn = b.norm();
  // As the displacement-only step (euler_step.cpp): the last solution is the guess only where it
  // beats zero, so every accepted step has ‖b − K x‖ <= tol ‖b‖.
  if (!(solver_->residual_norm(b, x_) <= bn)) x_.setZero();  // NaN included
  SolveResult res;
  try {
    res = solver_->solve(b, x_);
  } catch (const SolveError& e) {
    SolveResult r = e.result;
    r.message = name + " (t = " + std::to_string(t_ + dt) + " s): " + solver_->description() + " failed: " + e.what();
    throw SolveError(r);
  }
  st.seconds[kSolve] = seconds_since(t0);
  if (!x_.allFinite()) throw Error(name + ": the velocity or the pressure is not finite");
  v_ = model.expand(x_.head(nu), Vector::Zero(model.num_dofs()));
  u_ += dt * v_;
  pressure_ = x_.tail(np) / dt;
  energy_valid_ = false;
  finish_step(st, step_, t_, dt, res, bn);
  return st;
}

double MixedEuler::kinetic_energy() const {
  const ElasticityModel& model = m_.hierarchy().finest();
  const Vector v_free = model.restrict_to_free(v_);
  Vector mv(v_free.size());
  solver_->bound().mass().apply(v_free, mv);
  return 0.5 * v_free.dot(mv);
}

double MixedEuler::elastic_energy() const {
  evaluate();
  double pressure_term = 0.0;
  if (const Csr* C = m_.compressibility()) {
    // C = M_p / (λ s) at the step's weights: ½ pᵀ (M_p / λ) p = ½ s pᵀ C p.
    Vector cp(pressure_.size());
    C->multiply(pressure_.data(), cp.data());
    pressure_term = 0.5 * m_.weights().stiffness * pressure_.dot(cp);
  }
  return energy_ + pressure_term;
}

double MixedEuler::external_work() const { return f_ext_.dot(u_); }

double MixedEuler::setup_seconds() const { return solver_->setup_seconds(); }

std::string MixedEuler::description() const { return solver_->description(); }

}  // namespace pmg::fem
