#include "pmg/fem/static_solve.hpp"
#include "pmg/sparse/defaults.hpp"
#include "pmg/sparse/threads.hpp"

#include "pmg/sparse/factory.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <sstream>
#include <string>

namespace pmg::fem {

namespace {

/// Brings the solver's operator to rotations R (nullptr: none) at displacement u and writes the
/// elastic force f_el(u) (full vector).
using Evaluate = std::function<void(const Vector& u, const Rotations* R, Vector& force)>;
/// Sets the solver up on the operator of the last evaluation (first: the first iteration) or
/// updates it.
using Refresh = std::function<void(const Rotations* R, bool first)>;

void check_inputs(const ElasticityModel& model, const Vector& f_ext) {
  if (model.num_fixed() == 0)
    throw InputError("static solve: no node is fixed, so the stiffness matrix is singular (rigid "
                     "motions); fix part of the boundary");
  if (model.num_free_dofs() == 0)
    throw InputError("static solve: every node is fixed (no free degree of freedom): nothing to solve; "
                     "fix part of the boundary, not all of it");
  if (f_ext.size() != model.num_dofs())
    throw InputError("static solve: force vector has " + std::to_string(f_ext.size()) +
                     " entries, model has " + std::to_string(model.num_dofs()) + " dofs");
  if (!f_ext.allFinite()) throw InputError("static solve: force vector has NaN/Inf");
}

/// The whole model in this process: corrections on the free unknowns, the state full (3 per node).
class SerialStaticPart final : public StaticPart {
 public:
  SerialStaticPart(const ElasticityModel& model, const Vector& f_ext, bool corotational, Solver& solver,
                   const Evaluate& evaluate, const Refresh& refresh, int& solver_iterations)
      : model_(model), f_ext_(f_ext), corotational_(corotational), solver_(solver), evaluate_(evaluate),
        refresh_(refresh), solver_iterations_(solver_iterations) {}

  Vector correction(const Vector& u, int iteration) override {
    Rotations R;
    if (corotational_) R = model_.rotations(u);
    Vector force;
    evaluate_(u, corotational_ ? &R : nullptr, force);
    try {
      refresh_(corotational_ ? &R : nullptr, iteration == 1);  // symbolic set-up once, then numeric only
    } catch (const InputError&) {
      throw;  // a solver that does not suit this system says so itself
    } catch (const Error& e) {
      throw Error(std::string("static solve: ") + e.what() + "; the constraints may not remove every rigid motion");
    }
    const Vector rhs = model_.restrict_to_free(f_ext_ + force);
    Vector delta = Vector::Zero(rhs.size());
    SolveResult res;
    try {
      res = solver_.solve(rhs, delta);
    } catch (const SolveError& e) {
      res = e.result;
      res.message = e.what();
    }
    solver_iterations_ += res.iterations;
    if (!res.ok()) {  // a solver that does not throw on failure (throw_on_failure=false) included
      res.message = std::string("static solve: iteration ") + std::to_string(iteration) + ": " +
                    (res.message.empty() ? std::string("the solver ended with ") + to_string(res.status) : res.message);
      throw SolveError(res);
    }
    return model_.expand(delta, Vector());
  }
  double norm(const Vector& v) const override { return v.norm(); }

 private:
  const ElasticityModel& model_;
  const Vector& f_ext_;
  bool corotational_;
  Solver& solver_;
  const Evaluate& evaluate_;
  const Refresh& refresh_;
  int& solver_iterations_;
};

/// The fixed point of the file comment of static_solve.hpp on the whole model, from u0.
StaticResult fixed_point(const ElasticityModel& model, const Vector& f_ext, bool corotational, Solver& solver,
                         const StaticOptions& options, Vector u0, const Evaluate& evaluate,
                         const Refresh& refresh) {
  StaticResult res;
  res.u = std::move(u0);
  SerialStaticPart part(model, f_ext, corotational, solver, evaluate, refresh, res.solver_iterations);
  const FixedPointStats stats = corotational_fixed_point(part, res.u, corotational, options, "static solve");
  res.iterations = stats.iterations;
  res.last_change = stats.last_change;
  return res;
}

}  // namespace

FixedPointStats corotational_fixed_point(StaticPart& part, Vector& u, bool corotational, const StaticOptions& options,
                                         const std::string& what) {
  FixedPointStats stats;
  double omega = options.relaxation, previous_change = INFINITY;
  for (int it = 1;; ++it) {
    const Vector step = part.correction(u, it);
    const double change = part.norm(step) / std::max(part.norm(u + step), 1e-300);
    if (corotational && it > 1 && change > previous_change) omega = std::max(omega / 2, 1.0 / 64);
    previous_change = change;
    u += (corotational && it > 1 ? omega : 1.0) * step;
    stats.iterations = it;
    stats.last_change = change;
    if (!corotational || change <= options.corotational_tol) return stats;
    if (!std::isfinite(change) || it >= options.max_corotational_iterations) {
      std::ostringstream msg;
      msg << what << ": the corotational fixed point did not converge (relative change " << change << " after " << it
          << " iterations, tolerance " << options.corotational_tol << ")";
      throw Error(msg.str());
    }
  }
}

StaticResult solve_static(const ElasticityModel& model, const Vector& f_ext, bool corotational,
                          const StaticOptions& options, const Vector& prescribed) {
  check_inputs(model, f_ext);
  const ThreadBudget budget;  // the cores free now (pmg/sparse/threads.hpp)
  Config c = options.solver.clone();
  auto solver = make_solver(c, {}, kDefaultDirectMethod);
  Bcsr K = model.assembler().make_matrix();
  const Vector u0 = prescribed.size() ? prescribed : Vector::Zero(model.num_dofs());
  return fixed_point(
      model, f_ext, corotational, *solver, options, u0,
      [&](const Vector& u, const Rotations* R, Vector& force) {
        ElasticityModel::ElementPass pass;
        pass.u = &u;
        pass.R = R;
        pass.stiffness = &K;
        pass.force = &force;
        model.evaluate(pass);
      },
      [&](const Rotations*, bool first) {
        if (first) solver->setup(K);
        else solver->update();
      });
}

StaticResult solve_static(DegreeHierarchy& h, const Vector& f_ext, bool corotational, Solver& solver,
                          const StaticOptions& options) {
  const ElasticityModel& model = h.finest();
  check_inputs(model, f_ext);
  const ThreadBudget budget;  // the cores free now (pmg/sparse/threads.hpp)
  BoundSystem system = h.bind(solver);
  return fixed_point(
      model, f_ext, corotational, solver, options, Vector::Zero(model.num_dofs()),
      [&](const Vector& u, const Rotations* R, Vector& force) {
        system.evaluate(u, R, {}, &force, nullptr);  // the finest level, in the pass that gives the force
        system.prepare(R, {}, /*finest=*/false);      // the levels below it that the solver reads
      },
      [&](const Rotations*, bool) { system.set_up_solver(); });
}

}  // namespace pmg::fem
