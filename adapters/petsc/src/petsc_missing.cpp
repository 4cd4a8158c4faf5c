// The PETSc adapter when pmgkit is built without PETSc: the methods exist and say what is missing.
#include "pmg/petsc/petsc.hpp"

namespace pmg::petsc {

namespace {
[[noreturn]] void missing() {
  throw InputError("PETSc solvers (gamg, gamg-pcg, mumps, petsc-cholmod, fieldsplit-gmres) need PETSc, and this pmgkit "
                   "was built without it: install Debian's libpetsc-real-dev (scripts/setup.sh does) "
                   "and configure again");
}
}  // namespace

bool petsc_available() { return false; }
void start_petsc() {}

struct PetscPreconditioner::Impl {};

PetscPreconditioner::PetscPreconditioner(const PetscParams& params) : params_(params) { missing(); }
PetscPreconditioner::~PetscPreconditioner() = default;
void PetscPreconditioner::setup_impl(const LinearOperator&) { missing(); }
void PetscPreconditioner::update_impl() { missing(); }
void PetscPreconditioner::set_up_fieldsplit(index_t) { missing(); }
void PetscPreconditioner::scale_schur() { missing(); }
void PetscPreconditioner::apply_impl(const Vector&, Vector&) const { missing(); }
std::string PetscPreconditioner::describe() const { return ""; }

}  // namespace pmg::petsc
