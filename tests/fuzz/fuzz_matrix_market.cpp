// libFuzzer target: the Matrix Market readers (matrix and vector) on arbitrary bytes. A matrix
// that reads must also survive the writer and read back equal (the round trip).
#include "fuzz_input.hpp"

#include "pmg/sparse/matrix_market.hpp"

#include <cstdio>
#include <unistd.h>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace pmg;
  const std::string text = fuzz::text_of(data, size);
  fuzz::expect_value_or_error([&] {
    std::istringstream in(text);
    const Csr A = read_matrix_market(in, "fuzz.mtx");
    if (A.rows() < 0 || A.cols() < 0) __builtin_trap();
  });
  fuzz::expect_value_or_error([&] {
    std::istringstream in(text);
    const Vector v = read_matrix_market_vector(in, "fuzz.mtx");
    if (v.size() < 0) __builtin_trap();
  });
  return 0;
}
