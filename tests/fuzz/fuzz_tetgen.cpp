// libFuzzer target: the TetGen reader (.node and .ele) and the mesh checks behind it. The input is
// the .node text, a line "@@", then the .ele text (the seeds are built that way).
#include "fuzz_input.hpp"

#include "pmg/fem/mesh_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace pmg;
  const std::string text = fuzz::text_of(data, size);
  const auto cut = text.find("\n@@\n");
  const std::string node = cut == std::string::npos ? text : text.substr(0, cut + 1);
  const std::string ele = cut == std::string::npos ? std::string() : text.substr(cut + 4);
  fuzz::expect_value_or_error([&] {
    std::istringstream node_in(node), ele_in(ele);
    const fem::TetMesh m = fem::read_tetgen(node_in, "fuzz.node", ele_in, "fuzz.ele");
    for (index_t e = 0; e < m.num_tets(); ++e)
      if (!(m.signed_volume(e) > 0)) __builtin_trap();
  });
  return 0;
}
