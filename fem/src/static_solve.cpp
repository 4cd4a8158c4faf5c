#include "pmg/fem/static_solve.hpp"

#include "pmg/sparse/cholmod_solver.hpp"

#include <cmath>
#include <sstream>
#include <string>

namespace pmg::fem {

StaticResult solve_static(const ElasticityModel& model, const Vector& f_ext, bool corotational,
                          const StaticOptions& options, const Vector& prescribed) {
  if (model.num_fixed() == 0)
    throw InputError("static solve: no node is fixed, so the stiffness matrix is singular (rigid "
                     "motions); fix part of the boundary");
  if (f_ext.size() != model.num_dofs())
    throw InputError("static solve: force vector has " + std::to_string(f_ext.size()) +
                     " entries, model has " + std::to_string(model.num_dofs()) + " dofs");
  if (!f_ext.allFinite()) throw InputError("static solve: force vector has NaN/Inf");
  Bcsr K = model.assembler().make_matrix();
  const Vector f_free = model.restrict_to_free(f_ext);
  CholmodSolver chol;
  StaticResult res;
  res.u = prescribed.size() ? prescribed : Vector::Zero(model.num_dofs());
  Rotations R;
  double omega = options.relaxation, previous_change = INFINITY;
  for (int it = 1;; ++it) {
    if (corotational) R = model.rotations(res.u);
    Vector rhs = f_free;
    model.assemble(corotational ? &R : nullptr, prescribed, K, &rhs);
    try {
      if (it == 1) chol.setup(K);  // symbolic analysis once; later iterations refactorise only
      else chol.update();
    } catch (const Error& e) {
      throw Error(std::string("static solve: ") + e.what() +
                  "; the constraints may not remove every rigid motion");
    }
    Vector u_free;
    chol.apply(rhs, u_free);
    Vector u_new = model.expand(u_free, prescribed);
    const double change = (u_new - res.u).norm() / std::max(u_new.norm(), 1e-300);
    if (corotational && it > 1) {
      if (change > previous_change) omega = std::max(omega / 2, 1.0 / 64);
      u_new = res.u + omega * (u_new - res.u);
    }
    previous_change = change;
    res.u = std::move(u_new);
    res.iterations = it;
    res.last_change = change;
    if (!corotational || change <= options.corotational_tol) return res;
    if (!std::isfinite(change) || it >= options.max_corotational_iterations)
    {
      std::ostringstream msg;
      msg << "static solve: corotational fixed point did not converge (relative change " << change
          << " after " << it << " iterations, tolerance " << options.corotational_tol << ")";
      throw Error(msg.str());
    }
  }
}

}  // namespace pmg::fem
