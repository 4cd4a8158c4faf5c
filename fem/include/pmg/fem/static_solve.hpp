// pmg/fem/static_solve.hpp — static equilibrium, linear and corotational.
//
// Linear: K_ff u_f = f_f - K_fd u_d, solved by CHOLMOD.
// Corotational: fixed point on the rotations. With R_k from u_k, solve
//   K_R u_{k+1} = f_ext - Σ_e R K_e (Rᵀ X_e - X_e)
// (the linearisation of f_e = -R K_e (Rᵀ x_e - X_e) at fixed R) until
// ‖u_{k+1} - u_k‖ <= tol ‖u_{k+1}‖. The symbolic factorisation is done once; each iteration only
// refactorises numerically.
#pragma once

#include "pmg/fem/elasticity.hpp"

namespace pmg::fem {

struct StaticOptions {
  double corotational_tol = 1e-8;
  int max_corotational_iterations = 200;
  /// Initial under-relaxation ω of the fixed point, u <- u + ω (u_new - u). Whenever the relative
  /// change grows from one iteration to the next, ω is halved (down to 1/64): large rotations make
  /// the plain iteration oscillate.
  double relaxation = 1.0;
};

struct StaticResult {
  Vector u;                ///< full displacement (3 per node)
  int iterations = 0;      ///< corotational fixed-point iterations (1 for linear)
  double last_change = 0;  ///< relative change of the last corotational iteration
};

/// Throws InputError when no node is fixed (the static problem is singular) and pmg::Error when the
/// system is not positive definite or the fixed point does not converge.
StaticResult solve_static(const ElasticityModel& model, const Vector& f_ext, bool corotational,
                          const StaticOptions& options = {}, const Vector& prescribed = Vector());

}  // namespace pmg::fem
