// What the PETSc adapter's sources share (defined in petsc.cpp): PETSc's start, error checks that
// become exceptions carrying PETSc's own message, and the per-object options prefix.
#pragma once

#include <petscsys.h>

#include <string>
#include <vector>

namespace pmg::petsc::detail {

/// Initialises PETSc once per process, after MPI (pmg::mpi), and finalises it before MPI.
void start();
/// Throws pmg::Error "PETSc: <what> failed: <PETSc's message>" when err is not 0.
void check(PetscErrorCode err, const char* what);
/// "-pc_gamg_threshold 0.02 -mg_levels_ksp_max_it 3" with every option name given the prefix.
std::string prefixed(const std::string& options, const std::string& prefix);
/// The option names of "-name value ..." (without the dash), in order. Throws InputError for a
/// token that is neither an option ("-name") nor the one value after an option ("ksp_type cg"
/// without its dash, say), naming it.
std::vector<std::string> option_names(const std::string& options);
/// Throws InputError naming the options of `options` that PETSc has not read under `prefix`
/// (PetscOptionsUsed), unless `allow_unused`: a misspelt option or one of another type of solver
/// would otherwise change nothing without a word.
void refuse_unused(const std::string& options, const std::string& prefix, bool allow_unused, const std::string& who);
/// Forgets the message of the last error (after a failure that was handled).
void clear_error();

}  // namespace pmg::petsc::detail
