// pmg/sparse/petsc_binary.hpp — PETSc's binary format for a sparse matrix and a vector, read and
// written without PETSc: the fast way to hand a system to (or take one from) PETSc, MatLoad /
// VecLoad and petsc4py's PETSc.Viewer().createBinary read these files directly.
//
// Layout (big-endian; 32-bit integers, the default PetscInt, and 64-bit reals):
//   matrix: 1211216, rows, cols, nnz, nnz per row [rows], column indices [nnz], values [nnz]
//   vector: 1211214, n, values [n]
// A matrix file is read at disk speed (one pass, no text parsing); every count is checked against
// the file's size before anything is allocated, so a damaged header is an InputError naming the
// file, never an allocation of its claimed size.
#pragma once

#include "pmg/sparse/csr.hpp"
#include "pmg/sparse/file_io.hpp"

#include <iosfwd>
#include <string>

namespace pmg {

/// Reads a matrix (AIJ/CSR); rows may list columns in any order (sorted on reading); a repeated
/// column in a row is an error.
Csr read_petsc_binary_matrix(const std::string& path);
/// The same from a stream; `name` stands for the file in messages.
Csr read_petsc_binary_matrix(std::istream& in, const std::string& name = "<stream>");
/// Reads a vector.
Vector read_petsc_binary_vector(const std::string& path);
/// The same from a stream; `name` stands for the file in messages.
Vector read_petsc_binary_vector(std::istream& in, const std::string& name = "<stream>");

/// Writes a matrix through write_file_atomically() (a reader never sees half a file).
void write_petsc_binary(const std::string& path, const Csr& A);
/// Writes a vector through write_file_atomically(); InputError for NaN or Inf entries (which the
/// reader refuses).
void write_petsc_binary(const std::string& path, const Vector& v);

}  // namespace pmg
