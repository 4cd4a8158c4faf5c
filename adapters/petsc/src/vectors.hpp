// What the PETSc adapter's sources share beside common.hpp: whether the libraries still run,
// scope-owned PETSc objects, and copies between pmg vectors and PETSc vectors of the same layout.
#pragma once

#include "common.hpp"
#include "pmg/sparse/types.hpp"

#include <petscvec.h>

#include <algorithm>

namespace pmg::petsc {

/// MPI and PETSc are both still running (objects held past PetscFinalize() are left alone).
inline bool libraries_running() {
  int finalized = 0;
  MPI_Finalized(&finalized);
  PetscBool petsc_finalized = PETSC_FALSE;
  PetscFinalized(&petsc_finalized);
  return !finalized && !petsc_finalized;
}

/// Destroys a PETSc object at the end of a scope (an error path included).
template <class T, PetscErrorCode (*Destroy)(T*)>
struct Owned {
  T object = nullptr;
  Owned() = default;
  Owned(const Owned&) = delete;
  Owned& operator=(const Owned&) = delete;
  ~Owned() {
    if (object) Destroy(&object);
  }
};
using OwnedVec = Owned<Vec, VecDestroy>;
using OwnedIS = Owned<IS, ISDestroy>;

/// Copies an owned vector into a PETSc vector of the same layout.
inline void copy_in(const Vector& from, Vec to) {
  PetscScalar* v = nullptr;
  detail::check(VecGetArray(to, &v), "VecGetArray");
  std::copy(from.data(), from.data() + from.size(), v);
  VecRestoreArray(to, &v);
}

/// Copies a PETSc vector's local part into a pmg vector (resized).
inline void copy_out(Vec from, Vector& to) {
  PetscInt n = 0;
  detail::check(VecGetLocalSize(from, &n), "VecGetLocalSize");
  to.resize(n);
  const PetscScalar* v = nullptr;
  detail::check(VecGetArrayRead(from, &v), "VecGetArrayRead");
  std::copy(v, v + n, to.data());
  VecRestoreArrayRead(from, &v);
}

}  // namespace pmg::petsc
