// libFuzzer target: the Gmsh .msh reader (2.2 and 4.1 ASCII) and the mesh checks behind it.
#include "fuzz_input.hpp"

#include "pmg/fem/mesh_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace pmg;
  const std::string text = fuzz::text_of(data, size);
  fuzz::expect_value_or_error([&] {
    std::istringstream in(text);
    std::vector<std::string> warnings;
    const fem::TetMesh m = fem::read_gmsh(in, "fuzz.msh", &warnings);
    // What a reader returns has passed check_mesh: every element positively oriented.
    for (index_t e = 0; e < m.num_tets(); ++e)
      if (!(m.signed_volume(e) > 0)) __builtin_trap();
  });
  return 0;
}
