#include "pmg/solvers.hpp"

#include "pmg/cholmod/cholmod_solver.hpp"
#include "pmg/hypre/boomeramg.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/petsc/petsc.hpp"
#ifdef PMG_HAVE_GPU
#include "pmg/gpu/factory.hpp"
#endif
#ifdef PMG_HAVE_DISTRIBUTED
#include "pmg/distributed/mgpcg.hpp"
#endif

#include <mutex>

namespace pmg {

void register_all_solvers() {
  static std::once_flag once;
  std::call_once(once, [] {
    mg::register_solvers();
    cholmod::register_solvers();
    hypre::register_solvers();
    petsc::register_solvers();
#ifdef PMG_HAVE_DISTRIBUTED
    dist::register_solvers();
#endif
#ifdef PMG_HAVE_GPU
    gpu::register_solvers();
#endif
  });
}

}  // namespace pmg
