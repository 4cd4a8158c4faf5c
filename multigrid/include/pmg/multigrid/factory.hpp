// pmg/multigrid/factory.hpp — the multigrid component's methods in the solver factory
// (pmg/sparse/factory.hpp): pmg and mgpcg (cycles on any mg::LevelProvider), and the smoothers
// gauss-seidel, point-gauss-seidel, chebyshev, damped-jacobi, l1-jacobi and richardson.
//
//   pmg::mg::register_solvers();   // or pmg::register_all_solvers() (<pmg/solvers.hpp>)
//   auto solver = pmg::make_solver(pmg::Config::from_pairs({"method=mgpcg"}, "example"), {&levels});
//
// A cycle's lowest level defaults to CHOLMOD, so registering these also registers the CHOLMOD
// adapter's method (pmg::cholmod::register_solvers()).
#pragma once

#include "pmg/sparse/factory.hpp"

namespace pmg::mg {

/// Registers the multigrid methods and smoothers (idempotent; a name the user registered is kept).
void register_solvers();

}  // namespace pmg::mg
