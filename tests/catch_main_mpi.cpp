// The test main of suites that run on several MPI ranks: every method registered, MPI started
// before Catch2 runs, and the report written by rank 0 only (every rank's failures still count:
// mpirun exits non-zero when any rank does).
#define CATCH_CONFIG_RUNNER
#include <catch2/catch.hpp>

#include "pmg/mpi/session.hpp"
#include "pmg/petsc/petsc.hpp"
#include "pmg/solvers.hpp"

#include <vector>

int main(int argc, char** argv) {
  pmg::register_all_solvers();
  pmg::mg::start_petsc();
  std::vector<char*> args(argv, argv + argc);
  static char out[] = "--out", null[] = "/dev/null";
  if (pmg::mpi::rank() != 0) {
    args.push_back(out);
    args.push_back(null);
  }
  return Catch::Session().run(static_cast<int>(args.size()), args.data());
}
