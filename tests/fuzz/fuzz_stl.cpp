// libFuzzer target: the STL surface reader (ASCII and binary).
#include "fuzz_input.hpp"

#include "pmg/fem/mesh_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream in(pmg::fuzz::text_of(data, size));
  pmg::fuzz::expect_value_or_error([&] { pmg::fuzz::check_surface(pmg::fem::read_stl(in, "fuzz.stl")); });
  return 0;
}
