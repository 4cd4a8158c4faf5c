// libFuzzer target: the Matrix Market readers (matrix and vector) on arbitrary bytes. A matrix that
// reads is a well-formed CSR: row pointers from 0 rising to nnz, columns sorted, unique and in range,
// values finite.
#include "fuzz_input.hpp"

#include "pmg/sparse/matrix_market.hpp"

#include <cmath>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace pmg;
  const std::string text = fuzz::text_of(data, size);
  fuzz::expect_value_or_error([&] {
    std::istringstream in(text);
    fuzz::check_csr(read_matrix_market(in, "fuzz.mtx"));
  });
  fuzz::expect_value_or_error([&] {
    std::istringstream in(text);
    if (!read_matrix_market_vector(in, "fuzz.mtx").allFinite()) __builtin_trap();
  });
  return 0;
}
