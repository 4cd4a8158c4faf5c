#include "pmg/sim/system.hpp"

#include "pmg/fem/simulation.hpp"
#include "pmg/sparse/timer.hpp"

namespace pmg::sim {

const Bcsr& SceneSystem::matrix() const {
  if (!finest_assembled) throw Error("internal: the finest matrix of the scene's system was not assembled");
  return hierarchy().matrix(hierarchy().num_levels() - 1);
}

void SceneSystem::assemble_finest() {
  if (finest_assembled) return;
  const auto t0 = Clock::now();
  hierarchy().assemble_level(hierarchy().num_levels() - 1, nullptr, nullptr, mass_weight, stiffness_weight);
  finest_assembly = seconds_since(t0);
  finest_assembled = true;
}

void SceneSystem::assemble_lower_levels() {
  for (int l = 0; l + 1 < hierarchy().num_levels(); ++l)
    hierarchy().assemble_level(l, nullptr, nullptr, mass_weight, stiffness_weight);
}

std::vector<double> SceneSystem::free_coordinates() const {
  return hierarchy().node_coordinates(hierarchy().num_levels() - 1);
}

SceneSystem system_of(const Scene& scene, double dt, bool assemble_finest) {
  if (!(dt >= 0.0)) throw InputError("scene system: the time step must be >= 0 (0: the static system)");
  SceneSystem s;
  s.setup = set_up(scene, assemble_finest);
  Vector f = s.setup.f_ext;
  if (dt > 0) {
    fem::SimulationParams sp;  // the step system of an undamped implicit-Euler step
    sp.dt = dt;
    const fem::StepWeights w = fem::step_weights(sp);
    s.mass_weight = w.mass;
    s.stiffness_weight = w.stiffness;
    f *= dt;
  }
  s.b = s.setup.finest().restrict_to_free(f);
  if (assemble_finest) s.assemble_finest();
  return s;
}

}  // namespace pmg::sim
