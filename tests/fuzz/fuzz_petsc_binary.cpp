// libFuzzer target: the PETSc binary readers (matrix and vector) on arbitrary bytes. A matrix that
// reads is a well-formed CSR (as for Matrix Market); a vector is finite.
#include "fuzz_input.hpp"

#include "pmg/sparse/petsc_binary.hpp"

#include <cmath>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace pmg;
  const std::string bytes = fuzz::text_of(data, size);
  fuzz::expect_value_or_error([&] {
    std::istringstream in(bytes);
    const Csr A = read_petsc_binary_matrix(in, "fuzz.petsc");
    const CsrPattern& p = A.pattern();
    if (p.row_ptr.size() != static_cast<std::size_t>(p.rows) + 1 || p.row_ptr.front() != 0 ||
        p.nnz() != static_cast<offset_t>(p.col_idx.size()))
      __builtin_trap();
    for (index_t i = 0; i < p.rows; ++i)
      for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k)
        if (p.col_idx[k] < 0 || p.col_idx[k] >= p.cols || (k > p.row_ptr[i] && p.col_idx[k] <= p.col_idx[k - 1]) ||
            !std::isfinite(A.values()[k]))
          __builtin_trap();
  });
  fuzz::expect_value_or_error([&] {
    std::istringstream in(bytes);
    if (!read_petsc_binary_vector(in, "fuzz.petsc").allFinite()) __builtin_trap();
  });
  return 0;
}
