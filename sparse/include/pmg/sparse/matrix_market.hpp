// pmg/sparse/matrix_market.hpp — Matrix Market (coordinate, real/integer/pattern, general/symmetric)
// reading and writing, with errors that name the file, the line and what is wrong.
//
// Why not Eigen's loadMarket or CHOLMOD's reader: neither reports where a malformed file went wrong
// (Eigen's silently skips unparsable lines), and a user handing us a system must be told exactly.
#pragma once

#include "pmg/sparse/csr.hpp"
#include "pmg/sparse/file_io.hpp"

#include <iosfwd>
#include <string>

namespace pmg {

/// Reads a sparse matrix. Symmetric files are expanded to both triangles; duplicates are summed.
/// Throws InputError("file:line: what") on any malformed or out-of-range content.
Csr read_matrix_market(const std::string& path);
/// The same from a stream; `name` stands for the file in messages.
Csr read_matrix_market(std::istream& in, const std::string& name = "<stream>");

/// Reads a dense vector: "array" format (one column) or a coordinate n x 1 matrix.
Vector read_matrix_market_vector(const std::string& path);
/// The same from a stream; `name` stands for the file in messages.
Vector read_matrix_market_vector(std::istream& in, const std::string& name = "<stream>");

/// Writes a matrix in coordinate format; symmetric=true writes the lower triangle of a symmetric
/// matrix (throws if it is not symmetric to 1e-12 of its largest entry). Written to "path.tmp" then renamed: a reader never sees half a file.
void write_matrix_market(const std::string& path, const Csr& A, bool symmetric = false);
/// Writes a dense vector in array format (atomically, as above).
void write_matrix_market_vector(const std::string& path, const Vector& v);

}  // namespace pmg
