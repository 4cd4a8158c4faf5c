// Shared by the fuzz targets: the input as a seekable stream, and the one outcome a reader may have
// besides success. A reader given any bytes either returns or throws pmg::Error (InputError,
// MeshError) with a message; anything else — another exception, a crash, a sanitizer report, an
// allocation beyond libFuzzer's -malloc_limit_mb, a hang beyond -timeout — is a finding.
#pragma once

#include "pmg/sparse/types.hpp"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

namespace pmg::fuzz {

inline std::string text_of(const std::uint8_t* data, std::size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

/// Runs read(); an Error with a non-empty message is the expected way to refuse input.
template <class Read>
void expect_value_or_error(Read&& read) {
  try {
    read();
  } catch (const pmg::Error& e) {
    if (std::string(e.what()).empty()) __builtin_trap();  // an error must say what is wrong
  }
}

/// What a surface reader returns: every triangle's vertex indices in range.
template <class Surface>
void check_surface(const Surface& s) {
  for (const auto& t : s.triangles)
    for (auto v : t)
      if (v < 0 || static_cast<std::size_t>(v) >= s.vertices.size()) __builtin_trap();
}

/// What a matrix reader returns: a well-formed CSR — row pointers from 0 rising to nnz, columns
/// sorted, unique and in range, values finite. (A template, so that targets that do not read
/// matrices need not include csr.hpp.)
template <class Matrix>
void check_csr(const Matrix& A) {
  const auto& p = A.pattern();
  if (p.row_ptr.size() != static_cast<std::size_t>(p.rows) + 1 || p.row_ptr.front() != 0 ||
      p.nnz() != static_cast<offset_t>(p.col_idx.size()))
    __builtin_trap();
  for (index_t i = 0; i < p.rows; ++i)
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k)
      if (p.col_idx[k] < 0 || p.col_idx[k] >= p.cols || (k > p.row_ptr[i] && p.col_idx[k] <= p.col_idx[k - 1]) ||
          !std::isfinite(A.values()[k]))
        __builtin_trap();
}

}  // namespace pmg::fuzz
