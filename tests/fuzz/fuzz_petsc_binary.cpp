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
    fuzz::check_csr(read_petsc_binary_matrix(in, "fuzz.petsc"));
  });
  fuzz::expect_value_or_error([&] {
    std::istringstream in(bytes);
    if (!read_petsc_binary_vector(in, "fuzz.petsc").allFinite()) __builtin_trap();
  });
  return 0;
}
