// pmg/fem/static_solve.hpp — static equilibrium, linear and corotational, with any solver of the
// factory (pmg/sparse/factory.hpp).
//
// A fixed point on the rotations in residual form. With R_k from u_k (R = I for linear material):
//   K_R δ = (f_ext + f_el(u_k))|free,   f_el(u) = -Σ_e R K_e (Rᵀ x_e - X_e),
//   u_{k+1} = u_k + ω δ,
// until ‖δ‖ <= tol ‖u_k + δ‖ (linear material: one step, exact up to the solver's tolerance). The
// solver is set up once and update()d per iteration (a direct solver refactorises numerically
// only). Whenever the relative change grows from one iteration to the next, ω is halved (down to
// 1/64): large rotations make the plain iteration oscillate.
#pragma once

#include "pmg/fem/elasticity.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/sparse/config.hpp"
#include "pmg/sparse/solver.hpp"

namespace pmg::fem {

/// Options of solve_static().
struct StaticOptions {
  /// The fixed point stops when ‖δ‖ <= corotational_tol ‖u_k + δ‖ (see the file comment).
  double corotational_tol = 1e-8;
  /// Fixed-point iterations at most; reaching it unconverged throws pmg::Error.
  int max_corotational_iterations = 200;
  /// Initial under-relaxation ω of the fixed point (see the file comment).
  double relaxation = 1.0;
  /// The model overload's solver, built by the factory (empty: kDefaultDirectMethod, CHOLMOD,
  /// which must be registered: pmg::register_all_solvers() or pmg::cholmod::register_solvers()).
  Config solver;
};

/// The solution of solve_static() and how it was reached.
struct StaticResult {
  Vector u;                ///< full displacement (3 per node)
  int iterations = 0;      ///< corotational fixed-point iterations (1 for linear)
  double last_change = 0;  ///< relative change of the last corotational iteration
  int solver_iterations = 0;  ///< iterations of the linear solves, summed
};

/// One part's share of the static fixed point of the file comment: the whole model in one process
/// (solve_static()) or a rank's owned unknowns (dist::DistributedEuler::set_static_state()), so
/// that the iteration, its relaxation and its stopping rule exist once.
class StaticPart {
 public:
  virtual ~StaticPart() = default;
  /// The correction δ at state u (the part's vector): the rotations of u, the operator the solver
  /// reads brought to them (set up at iteration 1, updated after), K_R δ = f_ext + f_el(u) solved.
  /// Throws (a SolveError naming the iteration) where the solve fails.
  virtual Vector correction(const Vector& u, int iteration) = 0;
  /// ‖v‖₂ of a vector of the part's kind, over every part.
  virtual double norm(const Vector& v) const = 0;
};

/// How corotational_fixed_point() ended.
struct FixedPointStats {
  int iterations = 0;       ///< fixed-point iterations (1 for linear material)
  double last_change = 0;   ///< the last relative change ‖δ‖ / ‖u + δ‖
};

/// The fixed point of the file comment on `part` from u (updated in place): one correction for
/// linear material; for corotational material until the relative change falls to
/// options.corotational_tol, ω halved whenever the change grows. Throws pmg::Error, prefixed with
/// `what`, when the change is not finite or the iterations run out.
FixedPointStats corotational_fixed_point(StaticPart& part, Vector& u, bool corotational, const StaticOptions& options,
                                         const std::string& what);

/// On one model with options.solver (a single-level method of the factory: kDefaultDirectMethod,
/// CHOLMOD, by default; fem links no solver library, so the caller registers the method). `prescribed`
/// (full vector, may be empty) gives the clamped nodes' displacements. Throws InputError when no
/// node is fixed (the static problem is singular) and pmg::Error when the system is not positive
/// definite or the fixed point does not converge.
StaticResult solve_static(const ElasticityModel& model, const Vector& f_ext, bool corotational,
                          const StaticOptions& options = {}, const Vector& prescribed = Vector());

/// On the finest level of a degree hierarchy with any solver (multigrid methods built with `h` as
/// their levels included): each iteration brings the levels the solver reads to the rotations
/// through the hierarchy's binding (fem::BoundSystem) and sets the solver up (first iteration) or
/// updates it.
StaticResult solve_static(DegreeHierarchy& h, const Vector& f_ext, bool corotational, Solver& solver,
                          const StaticOptions& options = {});

}  // namespace pmg::fem
