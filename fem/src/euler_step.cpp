// The one implicit-Euler step (pmg/fem/euler_step.hpp).
#include "pmg/fem/euler_step.hpp"

#include "pmg/sparse/threads.hpp"
#include "pmg/sparse/timer.hpp"

#include <cmath>
#include <utility>

namespace pmg::fem {

EulerStep::EulerStep(StepPart& part, const SimulationParams& p, Vector f_ext_owned)
    : part_(part), p_(p), f_ext_owned_(std::move(f_ext_owned)) {
  const ElasticityModel& m = part_.finest();
  u_local_ = Vector::Zero(m.num_dofs());
  v_local_ = Vector::Zero(m.num_free_dofs());
  u_owned_ = v_owned_ = Vector::Zero(f_ext_owned_.size());
}

void EulerStep::set_state(Vector u_local, Vector v_local, Vector u_owned, Vector v_owned) {
  u_local_ = std::move(u_local);
  v_local_ = std::move(v_local);
  u_owned_ = std::move(u_owned);
  v_owned_ = std::move(v_owned);
  state_.valid = false;
}

void EulerStep::set_state_owned(Vector u_owned, Vector v_owned) {
  u_owned_ = std::move(u_owned);
  v_owned_ = std::move(v_owned);
  Vector u_free;
  part_.to_local(u_owned_, u_free);
  u_local_ = part_.finest().expand(u_free, Vector());
  part_.to_local(v_owned_, v_local_);
  state_.valid = false;
}

void EulerStep::evaluate_state() const {
  if (state_.valid) return;
  state_.seconds = {};
  const StepWeights w = step_weights(p_);
  const Rotations* R = p_.corotational ? &state_.R : nullptr;
  // Linear material keeps its operators once they carry the step: force and energy only.
  state_.prepare = p_.corotational || !levels_current_;
  Vector force;
  double energy = 0.0;
  EvaluateSeconds s;
  part_.together(
      [&] {
        const auto t0 = Clock::now();
        if (p_.corotational) {
          state_.R = part_.finest().rotations(u_local_);
          state_.seconds[kRotations] = seconds_since(t0);
        }
        s = part_.system().evaluate(u_local_, R, {w.mass, w.stiffness}, &force, &energy, state_.prepare);
      });
  state_.seconds[kAssembly] = s.finest;
  const auto t0 = Clock::now();
  part_.add_to_owners(part_.finest().restrict_to_free(force), state_.force_owned);
  state_.energy = part_.sum(energy);
  state_.seconds[kForces] = s.force + seconds_since(t0);
  state_.valid = true;
}

StepStats EulerStep::step() {
  const ThreadBudget budget;  // the cores free now, for the whole step (pmg/sparse/threads.hpp)
  evaluate_state();
  StepStats st;
  st.seconds = state_.seconds;
  const std::string name = "step " + std::to_string(step_ + 1);
  if (state_.prepare) {
    // The lower degrees get the same rotations and weights: (1 + Δt α) M + (Δt β + Δt²) K_R. Each
    // part's own preparation is agreed on before the solver's (collective) set-up.
    const auto t0 = Clock::now();
    const StepWeights w = step_weights(p_);
    part_.together([&] { part_.system().prepare(p_.corotational ? &state_.R : nullptr, {w.mass, w.stiffness}, false); });
    part_.system().set_up_solver();
    levels_current_ = true;
    st.seconds[kHierarchy] = seconds_since(t0);
  }
  // b = M v + Δt (f_ext + f_el(x)) on the owned unknowns.
  auto t0 = Clock::now();
  Vector mv(v_local_.size()), b;
  part_.system().mass().apply(v_local_, mv);
  part_.add_to_owners(mv, b);
  b += p_.dt * (f_ext_owned_ + state_.force_owned);
  st.seconds[kForces] += seconds_since(t0);

  t0 = Clock::now();
  const double bn = std::sqrt(part_.sum(b.squaredNorm()));
  // The solvers' tolerance is relative to the initial residual ||b - A v_0||. The previous velocity
  // is kept as the start only where it beats zero (||b - A v_0|| <= ||b||): near the turning points
  // of an oscillation b is small and the old velocity a poor guess, and a step started from it would
  // be accepted with ||b - A v|| far above tol ||b||. So every accepted step has
  // ||b - A v|| <= tol ||b|| (up to the solvers' factor-2 allowance on the true residual).
  if (part_.residual_norm(b, v_owned_) > bn) v_owned_.setZero();
  SolveResult res;
  try {
    res = part_.solve(b, v_owned_);
  } catch (const SolveError& e) {
    SolveResult r = e.result;
    r.message = name + " (t = " + std::to_string(t_ + p_.dt) + " s): " + part_.solver_name() + " failed: " + e.what();
    throw SolveError(r);
  }
  st.seconds[kSolve] = seconds_since(t0);
  part_.agree(v_owned_.allFinite() ? "" : "the velocity is not finite", name);

  part_.to_local(v_owned_, v_local_);
  u_local_ += p_.dt * part_.finest().expand(v_local_, Vector());
  u_owned_ += p_.dt * v_owned_;
  state_.valid = false;
  finish_step(st, step_, t_, p_.dt, res, bn);
  return st;
}

double EulerStep::kinetic_energy() const {
  Vector mv(v_local_.size());
  part_.system().mass().apply(v_local_, mv);
  return part_.sum(0.5 * v_local_.dot(mv));
}

double EulerStep::elastic_energy() const {
  evaluate_state();
  return state_.energy;
}

double EulerStep::external_work() const { return part_.sum(f_ext_owned_.dot(u_owned_)); }

}  // namespace pmg::fem
