// libFuzzer target: the scene reader (JSON, every key checked) and the solver options inside it. A
// scene that reads must print (scene_to_json) as a scene that reads back.
#include "fuzz_input.hpp"

#include "pmg/sim/scene.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace pmg;
  const std::string text = fuzz::text_of(data, size);
  fuzz::expect_value_or_error([&] {
    const sim::Scene s = sim::parse_scene(text, "fuzz.json");
    const sim::Scene back = sim::parse_scene(sim::scene_to_json(s), "fuzz.json");
    if (back.degree != s.degree || back.dt != s.dt || back.young != s.young) __builtin_trap();
  });
  return 0;
}
