// What the PETSc adapter's sources share (defined in petsc.cpp): PETSc's start, error checks that
// become exceptions carrying PETSc's own message, and the per-object options prefix.
#pragma once

#include <petscsys.h>

#include <string>

namespace pmg::petsc::detail {

/// Initialises PETSc once per process, after MPI (pmg::mpi), and finalises it before MPI.
void start();
/// Throws pmg::Error "PETSc: <what> failed: <PETSc's message>" when err is not 0.
void check(PetscErrorCode err, const char* what);
/// "-pc_gamg_threshold 0.02 -mg_levels_ksp_max_it 3" with every option name given the prefix.
std::string prefixed(const std::string& options, const std::string& prefix);
/// Forgets the message of the last error (after a failure that was handled).
void clear_error();

}  // namespace pmg::petsc::detail
