// pmg/solvers.hpp — every solver of this build in the factory (pmg/sparse/factory.hpp):
//
//   pmg::register_all_solvers();
//   auto solver = pmg::make_solver(pmg::Config::from_pairs({"method=gamg-pcg"}, "example"));
//
// Registers the methods of the multigrid component (pmg, mgpcg, smoothers), the CHOLMOD, hypre
// and PETSc adapters, and the GPU module where it was built. A consumer that needs only some
// links those components and calls their own register_solvers() instead; the core's methods
// (cg, jacobi-pcg, block-jacobi-pcg, mcg, jacobi, block-jacobi) need no call.
#pragma once

#include "pmg/sparse/factory.hpp"

namespace pmg {

/// Registers every component's methods (idempotent; thread-safe).
void register_all_solvers();

}  // namespace pmg
