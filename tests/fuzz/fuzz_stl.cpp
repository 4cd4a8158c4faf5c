// libFuzzer target: the STL surface reader (ASCII and binary).
#include "fuzz_input.hpp"

#include "pmg/fem/mesh_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace pmg;
  const std::string text = fuzz::text_of(data, size);
  fuzz::expect_value_or_error([&] {
    std::istringstream in(text);
    const fem::Surface s = fem::read_stl(in, "fuzz.stl");
    for (const auto& t : s.triangles)
      for (index_t v : t)
        if (v < 0 || v >= static_cast<index_t>(s.vertices.size())) __builtin_trap();
  });
  return 0;
}
