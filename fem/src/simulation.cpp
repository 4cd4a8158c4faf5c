#include "pmg/fem/simulation.hpp"
#include "pmg/fem/euler_step.hpp"
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

namespace {

/// One process's StepPart: the owned unknowns are the free ones, a sum is the value itself.
class SerialPart final : public StepPart {
 public:
  SerialPart(DegreeHierarchy& h, BoundSystem& system, Solver& solver) : h_(h), system_(system), solver_(solver) {}
  const ElasticityModel& finest() const override { return h_.finest(); }
  BoundSystem& system() const override { return system_; }
  void add_to_owners(const Vector& local, Vector& owned) const override { owned = local; }
  void to_local(const Vector& owned, Vector& local) const override { local = owned; }
  double sum(double mine) const override { return mine; }
  void together(const std::function<void()>& f) const override { f(); }
  void agree(const std::string& error, const std::string& what) const override {
    if (!error.empty()) throw Error(what + ": " + error);
  }
  double residual_norm(const Vector& b, const Vector& v) const override {
    system_.system().residual(b, v, residual_);  // reused: no per-step allocation
    return residual_.norm();
  }
  SolveResult solve(const Vector& b, Vector& v) override { return solver_.solve(b, v); }
  std::string solver_name() const override { return solver_.name(); }

 private:
  DegreeHierarchy& h_;
  BoundSystem& system_;
  Solver& solver_;
  mutable Vector residual_;
};

}  // namespace

ImplicitEuler::ImplicitEuler(DegreeHierarchy& h, Solver& solver, const Vector& f_ext, const SimulationParams& p)
    : h_(h), system_(h.bind(solver)) {
  const ElasticityModel& m = h_.finest();
  check_simulation(m, f_ext, p);
  part_ = std::make_unique<SerialPart>(h_, system_, solver);
  step_ = std::make_unique<EulerStep>(*part_, p, m.restrict_to_free(f_ext));
  v_ = Vector::Zero(m.num_dofs());
}

ImplicitEuler::~ImplicitEuler() = default;

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
  v_ = v;
  step_->set_state(u, m.restrict_to_free(v), m.restrict_to_free(u), m.restrict_to_free(v));
}

const Vector& ImplicitEuler::displacement() const { return step_->u_local(); }
double ImplicitEuler::time() const { return step_->time(); }
int ImplicitEuler::steps() const { return step_->steps(); }

StepStats ImplicitEuler::step() {
  const StepStats st = step_->step();
  v_ = h_.finest().expand(step_->v_local(), Vector());
  return st;
}

double ImplicitEuler::kinetic_energy() const { return step_->kinetic_energy(); }
double ImplicitEuler::elastic_energy() const { return step_->elastic_energy(); }
double ImplicitEuler::external_work() const { return step_->external_work(); }

}  // namespace pmg::fem
