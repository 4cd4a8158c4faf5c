#include "pmg/fem/simulation.hpp"
#include "pmg/sparse/threads.hpp"
#include "pmg/sparse/timer.hpp"

#include <cstdio>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

namespace pmg::fem {

StepWeights step_weights(const SimulationParams& p) {
  return {1.0 + p.dt * p.rayleigh_alpha, p.dt * p.rayleigh_beta + p.dt * p.dt};
}

double max_time_step(double young, double rayleigh_beta) {
  // dt^2 + beta dt = C with C = 1e300 / max(E, 1), the positive root.
  const double c = 1e300 / std::max(young, 1.0), beta = std::max(rayleigh_beta, 0.0);
  return 2.0 * c / (beta + std::hypot(beta, 2.0 * std::sqrt(c)));  // hypot: no overflow of beta^2
}

const char* stage_name(int stage) {
  static const char* names[kNumStages] = {"rotations", "finest matrix", "hierarchy update",
                                          "forces", "solve"};
  return names[stage];
}

void check_simulation(const ElasticityModel& m, const Vector& f_ext, const SimulationParams& p) {
  if (f_ext.size() != m.num_dofs())
    throw InputError("simulation: external force has " + std::to_string(f_ext.size()) +
                     " entries for " + std::to_string(m.num_dofs()) + " unknowns");
  if (!std::isfinite(p.dt) || !(p.dt > 0))
    throw InputError("simulation: the time step must be positive, got " + std::to_string(p.dt));
  if (!(p.rayleigh_alpha >= 0) || !(p.rayleigh_beta >= 0) || !std::isfinite(p.rayleigh_alpha) ||
      !std::isfinite(p.rayleigh_beta))
    throw InputError("simulation: Rayleigh damping coefficients must be >= 0");
  const auto& scale = m.stiffness_scale();
  const double young = m.material().young * (scale.empty() ? 1.0 : *std::max_element(scale.begin(), scale.end()));
  if (const double max_dt = max_time_step(young, p.rayleigh_beta); p.dt > max_dt) {
    char text[200];
    std::snprintf(text, sizeof text,
                  "simulation: the time step dt = %g s makes the step matrix M + dt^2 K overflow double "
                  "precision; use a time step below %g s", p.dt, max_dt);
    throw InputError(text);
  }
  if (m.num_fixed() == 0 && p.rayleigh_alpha == 0 && m.material().density == 0)
    throw InputError("simulation: no mass and nothing clamped: the step system is singular");
  if (m.material().density == 0) throw InputError("simulation: density must be > 0 for dynamics");
}

void record_solve(StepStats& st, const SolveResult& res, double b_norm) {
  st.iterations = res.iterations;
  st.rel_residual = res.true_rel_residual;
  // Fixed-iteration runs have no true residual: the last recursive one stands in.
  const double rel = std::isfinite(res.true_rel_residual) ? res.true_rel_residual : res.rel_residual;
  st.residual = b_norm > 0 ? rel * res.initial_residual / b_norm : 0.0;
}

void finish_step(StepStats& st, int& step, double& t, double dt, const SolveResult& res, double b_norm) {
  t += dt;
  ++step;
  st.step = step;
  st.time = t;
  record_solve(st, res, b_norm);
}

// ---- implicit Euler ------------------------------------------------------------------------------

ImplicitEuler::ImplicitEuler(DegreeHierarchy& h, Solver& solver, const Vector& f_ext,
                             const SimulationParams& p)
    : h_(h), solver_(solver), system_(h.bind(solver)), f_ext_(f_ext), p_(p) {
  const ElasticityModel& m = h_.finest();
  check_simulation(m, f_ext_, p_);
  u_ = Vector::Zero(m.num_dofs());
  v_ = Vector::Zero(m.num_dofs());
  v_free_ = Vector::Zero(m.num_free_dofs());
}

void check_state(const ElasticityModel& m, const Vector& u, const Vector& v) {
  if (u.size() != m.num_dofs() || v.size() != m.num_dofs())
    throw InputError("simulation: state vectors must have " + std::to_string(m.num_dofs()) + " entries");
  if (!u.allFinite() || !v.allFinite()) throw InputError("simulation: the initial state is not finite");
  for (index_t i = 0; i < m.num_nodes(); ++i)
    if (m.is_fixed(i) && (u.segment<3>(3 * i).norm() > 0 || v.segment<3>(3 * i).norm() > 0))
      throw InputError("simulation: clamped node " + std::to_string(i) + " must start at rest");
  const std::vector<char>& held = m.constrained_free_dofs();
  if (!held.empty()) {
    const auto& fi = m.assembler().free_index();
    for (index_t i = 0; i < m.num_nodes(); ++i)
      for (int c = 0; c < 3 && fi[i] >= 0; ++c)
        if (held[3 * fi[i] + c] && (u[3 * i + c] != 0.0 || v[3 * i + c] != 0.0))
          throw InputError("simulation: node " + std::to_string(i) + " holds its " + std::string(1, char('x' + c)) +
                           " component at zero (a support or symmetry plane) but starts with it moved");
  }
}

void ImplicitEuler::set_state(const Vector& u, const Vector& v) {
  const ElasticityModel& m = h_.finest();
  check_state(m, u, v);
  u_ = u;
  v_ = v;
  state_.valid = false;
  v_free_ = m.restrict_to_free(v);
}

void ImplicitEuler::evaluate_state() const {
  if (state_.valid) return;
  state_.seconds = {};
  auto t0 = Clock::now();
  if (p_.corotational) {
    state_.R = h_.finest().rotations(u_);
    state_.seconds[kRotations] = seconds_since(t0);
  }
  const Rotations* R = p_.corotational ? &state_.R : nullptr;
  // Linear material keeps its finest operator after the first pass: force and energy only.
  state_.matrix_assembled = p_.corotational || !assembled_;
  const EvaluateSeconds s =
      system_.evaluate(u_, R, weights(), &state_.force, &state_.energy, state_.matrix_assembled);
  assembled_ = true;
  state_.seconds[kAssembly] = s.finest;
  state_.seconds[kForces] = s.force;
  state_.valid = true;
}

StepStats ImplicitEuler::step() {
  const ThreadBudget budget;  // the cores free now, for the whole step (pmg/sparse/threads.hpp)
  const ElasticityModel& m = h_.finest();
  evaluate_state();
  StepStats st;
  st.seconds = state_.seconds;
  if (state_.matrix_assembled) {
    // The lower degrees get the same rotations and weights: (1 + Δt α) M + (Δt β + Δt²) K_R.
    const RefreshSeconds r = system_.refresh(p_.corotational ? &state_.R : nullptr, weights(), /*finest=*/false);
    st.seconds[kHierarchy] = r.prepare + r.setup;
  }
  // b = M v + Δt (f_ext + f_el(x)) on the free nodes.
  auto t0 = Clock::now();
  const Vector f = m.restrict_to_free(f_ext_ + state_.force);
  Vector b(v_free_.size());
  system_.mass().apply(v_free_, b);
  b += p_.dt * f;
  st.seconds[kForces] += seconds_since(t0);

  t0 = Clock::now();
  const double bn = b.norm();
  // The solvers' tolerance is relative to the initial residual ||b - A v_0||. The previous velocity
  // is kept as the start only where it beats zero (||b - A v_0|| <= ||b||): near the turning points
  // of an oscillation b is small and the old velocity a poor guess, and a step started from it would
  // be accepted with ||b - A v|| far above tol ||b||. So every accepted step has
  // ||b - A v|| <= tol ||b|| (up to the solvers' factor-2 allowance on the true residual).
  system_.system().residual(b, v_free_, start_residual_);
  if (start_residual_.norm() > bn) v_free_.setZero();
  SolveResult res;
  try {
    res = solver_.solve(b, v_free_);
  } catch (const SolveError& e) {
    SolveResult r = e.result;
    r.message = "step " + std::to_string(step_ + 1) + " (t = " + std::to_string(t_ + p_.dt) +
                " s): " + solver_.name() + " failed: " + e.what();
    throw SolveError(r);
  }
  st.seconds[kSolve] = seconds_since(t0);
  if (!v_free_.allFinite())
    throw Error("step " + std::to_string(step_ + 1) + ": the velocity is not finite");

  v_ = m.expand(v_free_, Vector());
  u_ += p_.dt * v_;
  state_.valid = false;
  finish_step(st, step_, t_, p_.dt, res, bn);
  return st;
}

double ImplicitEuler::kinetic_energy() const {
  Vector Mv(v_free_.size());
  system_.mass().apply(v_free_, Mv);
  return 0.5 * v_free_.dot(Mv);
}

double ImplicitEuler::elastic_energy() const {
  evaluate_state();
  return state_.energy;
}

double ImplicitEuler::external_work() const { return f_ext_.dot(u_); }

}  // namespace pmg::fem
