#include "pmg/fem/static_solve.hpp"
#include "pmg/sparse/threads.hpp"

#include "pmg/cholmod/cholmod_solver.hpp"
#include "pmg/sparse/factory.hpp"

#include <cmath>
#include <functional>
#include <sstream>
#include <string>

namespace pmg::fem {

namespace {

/// Brings the solver's operator to rotations R (nullptr: none) at displacement u, writes the
/// elastic force f_el(u) (full vector) and returns the operator of the free nodes.
using Evaluate = std::function<const LinearOperator&(const Vector& u, const Rotations* R, Vector& force)>;

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

/// The fixed point of the file comment of static_solve.hpp, from u0.
StaticResult fixed_point(const ElasticityModel& model, const Vector& f_ext, bool corotational, Solver& solver,
                         const StaticOptions& options, Vector u0, const Evaluate& evaluate) {
  StaticResult res;
  res.u = std::move(u0);
  Rotations R;
  Vector force, delta;
  double omega = options.relaxation, previous_change = INFINITY;
  for (int it = 1;; ++it) {
    if (corotational) R = model.rotations(res.u);
    const LinearOperator& K = evaluate(res.u, corotational ? &R : nullptr, force);
    try {
      if (it == 1) solver.setup(K);  // symbolic set-up once; later iterations are numeric only
      else solver.update();
    } catch (const InputError&) {
      throw;  // a solver that does not suit this system says so itself
    } catch (const Error& e) {
      throw Error(std::string("static solve: ") + e.what() + "; the constraints may not remove every rigid motion");
    }
    const Vector rhs = model.restrict_to_free(f_ext + force);
    delta = Vector::Zero(rhs.size());
    try {
      res.solver_iterations += solver.solve(rhs, delta).iterations;
    } catch (const SolveError& e) {
      SolveResult r = e.result;
      r.message = std::string("static solve: iteration ") + std::to_string(it) + ": " + e.what();
      throw SolveError(r);
    }
    const Vector step = model.expand(delta, Vector());
    const double change = step.norm() / std::max((res.u + step).norm(), 1e-300);
    if (corotational && it > 1 && change > previous_change) omega = std::max(omega / 2, 1.0 / 64);
    previous_change = change;
    res.u += (corotational && it > 1 ? omega : 1.0) * step;
    res.iterations = it;
    res.last_change = change;
    if (!corotational || change <= options.corotational_tol) return res;
    if (!std::isfinite(change) || it >= options.max_corotational_iterations) {
      std::ostringstream msg;
      msg << "static solve: corotational fixed point did not converge (relative change " << change
          << " after " << it << " iterations, tolerance " << options.corotational_tol << ")";
      throw Error(msg.str());
    }
  }
}

}  // namespace

StaticResult solve_static(const ElasticityModel& model, const Vector& f_ext, bool corotational,
                          const StaticOptions& options, const Vector& prescribed) {
  check_inputs(model, f_ext);
  const ThreadBudget budget;  // the cores free now (pmg/sparse/threads.hpp)
  cholmod::register_solvers();  // the default
  Config c = options.solver.clone();
  auto solver = make_solver(c, {}, "cholmod");
  Bcsr K = model.assembler().make_matrix();
  const Vector u0 = prescribed.size() ? prescribed : Vector::Zero(model.num_dofs());
  return fixed_point(model, f_ext, corotational, *solver, options, u0,
                     [&](const Vector& u, const Rotations* R, Vector& force) -> const LinearOperator& {
                       ElasticityModel::ElementPass pass;
                       pass.u = &u;
                       pass.R = R;
                       pass.stiffness = &K;
                       pass.force = &force;
                       model.evaluate(pass);
                       return K;
                     });
}

StaticResult solve_static(DegreeHierarchy& h, const Vector& f_ext, bool corotational, Solver& solver,
                          const StaticOptions& options) {
  const ElasticityModel& model = h.finest();
  check_inputs(model, f_ext);
  const ThreadBudget budget;  // the cores free now (pmg/sparse/threads.hpp)
  const SolverNeeds needs = solver.needs();
  const int L = h.num_levels();
  return fixed_point(model, f_ext, corotational, solver, options, Vector::Zero(model.num_dofs()),
                     [&](const Vector& u, const Rotations* R, Vector& force) -> const LinearOperator& {
                       // The finest level in the pass that gives the force, then the levels below.
                       if (needs.matrix_free) {
                         h.update_matrix_free(L - 1, R);
                         h.matrix_free(L - 1).element_force(u, R, force, nullptr);
                       } else {
                         h.assemble_level(L - 1, R, 0.0, 1.0, u, &force, nullptr);
                       }
                       return h.prepare(needs, R, 0.0, 1.0, /*finest=*/false);
                     });
}

}  // namespace pmg::fem
