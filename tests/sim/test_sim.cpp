// pmg::sim: a scene from JSON text, set up and run through the library alone (what pmg simulate
// prints), with its outputs, and a failing step reported, not thrown.
#include "pmg/sim/run.hpp"
#include "pmg/sim/scene.hpp"
#include "pmg/sim/setup.hpp"
#include "pmg/fem/generators.hpp"
#include "pmg/fem/mesh_io.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <algorithm>
#include <fstream>
#include <random>
#include <vector>
#include <string>

using namespace pmg;

namespace {
std::string temp_dir() {
  char name[] = "/tmp/pmg_sim_XXXXXX";
  REQUIRE(mkdtemp(name) != nullptr);
  return name;
}
int count_lines(const std::string& path) {
  std::ifstream in(path);
  int n = 0;
  for (std::string line; std::getline(in, line);) ++n;
  return n;
}
}  // namespace

TEST_CASE("a scene runs through the library: steps, outputs, energy, probe", "[sim]") {
  const sim::Scene scene = sim::parse_scene(R"({
      "mesh": {"box": [3, 1, 1], "size": [3, 1, 1]}, "degree": 2,
      "material": {"model": "linear", "young": 1e6, "poisson": 0.3, "density": 1000},
      "clamp": {"axis": "x"}, "initial": {"state": "twisted", "degrees": 20},
      "time": {"dt": 0.01, "duration": 0.04}, "solver": {"method": "pmg", "tol": 1e-6},
      "output": {"frame_every": 2}})", "inline scene");
  sim::SceneSetup setup = sim::set_up(scene);
  CHECK(setup.finest().num_fixed() > 0);
  CHECK(setup.probe.vertex >= 0);
  CHECK(setup.probe.point.x() == Approx(3.0));  // the centre of the far face
  const std::string dir = temp_dir();
  sim::DynamicRun run(scene, setup, dir + "/out");
  CHECK(run.method() == "pmg");
  int progress_calls = 0;
  const sim::RunSummary r = run.run([&](int, double) { ++progress_calls; });
  CHECK(r.failed_step == 0);
  CHECK(r.steps_done == 4);
  CHECK(progress_calls == 4);
  CHECK(r.max_residual < 1e-5);
  CHECK(r.stage_s[fem::kSolve] > 0.0);
  // A twisted bar released: implicit Euler removes energy, the probe moves.
  CHECK(r.energy_final < r.energy_initial);
  CHECK(r.energy_peak <= r.energy_initial * (1 + 1e-9));
  CHECK(r.probe.norm() > 0.0);
  CHECK(r.frames == 3);  // steps 0, 2 and 4
  CHECK(count_lines(dir + "/out/steps.csv") == 6);  // header and steps 0..4
  REQUIRE(r.outputs.size() == 2);
  CHECK(std::ifstream(dir + "/out/simulation.pvd").good());
  std::system(("rm -rf " + dir).c_str());
}

TEST_CASE("a failing step ends the run with the step named, and bad scenes name their key", "[sim]") {
  const sim::Scene scene = sim::parse_scene(R"({
      "mesh": {"box": [2, 1, 1], "size": [2, 1, 1]}, "degree": 2,
      "initial": {"state": "compressed", "strain": 0.1}, "time": {"dt": 0.01, "duration": 0.1},
      "solver": {"method": "cg", "tol": 1e-10, "max_iterations": 2}})", "inline scene");
  sim::SceneSetup setup = sim::set_up(scene);
  sim::DynamicRun run(scene, setup, "");
  const sim::RunSummary r = run.run();
  CHECK(r.failed_step == 1);
  CHECK(r.steps_done == 0);
  CHECK_THAT(r.failure, Catch::Contains("step 1") && Catch::Contains("cg failed"));
  CHECK(r.outputs.empty());
  CHECK_THROWS_WITH(sim::parse_scene(R"({"material": {"yuong": 1}})", "s.json"),
                    Catch::Contains("s.json: material.yuong: unknown key"));
  CHECK_THROWS_WITH(sim::parse_scene("{", "s.json"), Catch::Contains("s.json: not valid JSON"));
  const sim::Scene point = sim::parse_scene(R"({"mesh": {"box": [2, 1, 1], "size": [2, 1, 1]},
      "degree": 1, "output": {"probe": [9, 9, 9]}})", "s.json");
  CHECK_THROWS_WITH(sim::set_up(point), Catch::Contains("output.probe: the point lies outside the mesh"));
}

TEST_CASE("scenes refuse impossible times, sizes beyond the machine, and read mesh.allow", "[sim]") {
  sim::Scene s;
  s.dt = 0.01;
  s.duration = 1e300;
  CHECK_THAT(s.check_time(), Catch::Contains("steps, more than"));
  s.duration = std::nan("");
  CHECK_THAT(s.check_time(), Catch::Contains("duration must be a finite time"));
  s.duration = 0.001;
  CHECK_THAT(s.check_time(), Catch::Contains("shorter than half a step"));
  s.duration = 1.0;
  CHECK(s.check_time().empty());
  CHECK_THROWS_WITH(sim::parse_scene(R"({"time": {"dt": 1e-9, "duration": 100}})", "s.json"),
                    Catch::Contains("s.json: time: duration 100 s at dt 1e-09 s"));
  CHECK_THROWS_WITH(sim::parse_scene(R"({"degree": 2, "degree": 3})", "s.json"),
                    Catch::Contains("s.json: key 'degree' appears twice"));
  CHECK_THROWS_WITH(sim::parse_scene(R"({"material": {"young": 1e400}})", "s.json"),
                    Catch::Contains("material.young: a number outside the range of a double"));
  CHECK_THROWS_WITH(sim::parse_scene(R"({"mesh": {"allow": ["bent"]}})", "s.json"),
                    Catch::Contains("mesh.allow: 'bent' is not a mesh defect that can be allowed (tangled, cracked)"));
  const sim::Scene allowed = sim::parse_scene(R"({"mesh": {"allow": ["cracked"]}})", "s.json");
  CHECK(allowed.mesh_checks.allow_cracked);
  CHECK_FALSE(allowed.mesh_checks.allow_tangled);
  CHECK(sim::parse_scene(sim::scene_to_json(allowed), "back.json").mesh_checks.allow_cracked);
  // 200^3 boxes of cubic elements: refused with the estimate before anything is built.
  sim::Scene huge;
  huge.box = {200, 200, 200};
  CHECK_THROWS_WITH(sim::set_up(huge), Catch::Contains("would need an estimated") &&
                                           Catch::Contains("of memory; this machine has"));
  CHECK(sim::estimated_memory_bytes(1000, 3) == Approx(50e6));
  // Without the finest matrix (matrix-free solvers only) the estimate is lighter, and still refuses.
  CHECK(sim::estimated_memory_bytes(1000, 2, false) == Approx(1.5e6));
  CHECK(sim::estimated_memory_bytes(1000, 3, false) == Approx(4e6));
  CHECK(sim::estimated_memory_bytes(1000, 1, false) == Approx(2e6));
  CHECK_THROWS_WITH(sim::set_up(huge, false), Catch::Contains("would need an estimated"));
}

TEST_CASE("a stop flag ends a run after the step in progress with its outputs complete", "[sim]") {
  const sim::Scene scene = sim::parse_scene(R"({
      "mesh": {"box": [2, 1, 1], "size": [2, 1, 1]}, "degree": 1,
      "initial": {"state": "twisted", "degrees": 10}, "time": {"dt": 0.01, "duration": 1},
      "output": {"frame_every": 5}})", "inline scene");
  sim::SceneSetup setup = sim::set_up(scene);
  const std::string dir = temp_dir();
  sim::DynamicRun run(scene, setup, dir + "/out");
  volatile std::sig_atomic_t stop = 0;
  run.set_stop_flag(&stop);
  const sim::RunSummary r = run.run([&](int step, double) {
    if (step == 3) stop = 1;  // as a SIGINT handler would, during step 3
  });
  CHECK(r.interrupted);
  CHECK(r.failed_step == 0);
  CHECK(r.steps_done == 3);
  CHECK(r.frames == 2);  // step 0 and the last finished step, 3
  CHECK(count_lines(dir + "/out/steps.csv") == 5);  // header and steps 0..3
  CHECK(std::ifstream(dir + "/out/frame_000003.vtu").good());
  std::system(("rm -rf " + dir).c_str());
}

TEST_CASE("supports and symmetry planes in scenes: a quarter model steps as the full model does", "[sim][symmetry]") {
  // The full bar and its quarter (u_y held on y = 1/2, u_z on z = 1/2), loaded along the bar:
  // 5 implicit-Euler steps give the same probe displacement and a quarter of the energy.
  const std::string common = R"("degree": 2, "clamp": {"axis": "x"}, "loads": {"gravity": [9.81, 0, 0]},
      "time": {"dt": 0.01, "duration": 0.05}, "solver": {"method": "mgpcg", "tol": 1e-10},
      "output": {"probe": [2.0, 0.5, 0.5]})";
  const sim::Scene full = sim::parse_scene(R"({"mesh": {"box": [4, 2, 2], "size": [2, 1, 1]}, )" + common + "}", "full");
  const sim::Scene quarter = sim::parse_scene(R"({"mesh": {"box": [4, 1, 1], "size": [2, 0.5, 0.5]},
      "symmetry": [{"axis": "y", "at": "max"}, {"axis": "z", "at": "max"}], )" + common + "}", "quarter");
  REQUIRE(quarter.supports.size() == 2);
  CHECK(quarter.supports[0].components == 2);
  CHECK(quarter.supports[1].at_max);
  sim::SceneSetup fs = sim::set_up(full), qs = sim::set_up(quarter);
  CHECK(qs.hierarchy->constrained_dofs(qs.hierarchy->num_levels() - 1) != nullptr);
  const sim::RunSummary rf = sim::DynamicRun(full, fs, "").run(), rq = sim::DynamicRun(quarter, qs, "").run();
  REQUIRE(rf.failed_step == 0);
  REQUIRE(rq.failed_step == 0);
  INFO("probe full " << rf.probe.transpose() << ", quarter " << rq.probe.transpose());
  CHECK((rf.probe - rq.probe).norm() <= 1e-8 * rf.probe.norm());
  CHECK(rq.probe.y() == 0.0);
  CHECK(rq.probe.z() == 0.0);
  CHECK(rq.energy_final == Approx(rf.energy_final / 4).epsilon(1e-8));
  // Round trip through JSON, and the errors.
  const sim::Scene back = sim::parse_scene(sim::scene_to_json(quarter), "back.json");
  REQUIRE(back.supports.size() == 2);
  CHECK(back.supports[1].components == 4);
  CHECK_THROWS_WITH(sim::parse_scene(R"({"supports": [{"axis": "x", "components": "xq"}]})", "s.json"),
                    Catch::Contains("supports[0].components: expected distinct letters"));
  CHECK_THROWS_WITH(sim::parse_scene(R"({"symmetry": [{"axis": "y", "components": "y"}]})", "s.json"),
                    Catch::Contains("symmetry[0].components: unknown key"));
  CHECK_THROWS_WITH(sim::parse_scene(R"({"symmetry": [{"at": "max"}]})", "s.json"), Catch::Contains("needs an axis"));
  CHECK_THROWS_WITH(sim::parse_scene(R"({"symmetry": {"axis": "y"}})", "s.json"), Catch::Contains("expected an array"));
  CHECK_THROWS_WITH(sim::parse_scene(R"({"symmetry": [{"axis": "y"}], "initial": {"state": "twisted"}})", "s.json"),
                    Catch::Contains("would contradict"));
  // A state moving a held component is refused by the stepper as well (scenes built in code).
  Vector u = Vector::Zero(qs.finest().num_dofs()), v = u;
  const auto& fi = qs.finest().assembler().free_index();
  const std::vector<char>& held = qs.finest().constrained_free_dofs();
  for (index_t i = 0; i < qs.finest().num_nodes(); ++i)
    if (fi[i] >= 0 && held[3 * fi[i] + 1]) {
      v[3 * i + 1] = 0.1;
      break;
    }
  CHECK_THROWS_WITH(fem::check_state(qs.finest(), u, v), Catch::Contains("holds its y component"));
  // A plane where the mesh only touches its bounding box in a point holds no face: refused.
  const std::string dir = temp_dir();
  std::ofstream(dir + "/tet.node") << "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n";
  std::ofstream(dir + "/tet.ele") << "1 4 0\n1 1 2 3 4\n";
  const sim::Scene touch = sim::parse_scene(R"({"mesh": {"file": ")" + dir + R"(/tet.node"}, "degree": 1,
      "symmetry": [{"axis": "x", "at": "max"}], "time": "static"})", "touch.json");
  CHECK_THROWS_WITH(sim::set_up(touch), Catch::Contains("holds no boundary face"));
  std::system(("rm -rf " + dir).c_str());
}

TEST_CASE("a mesh file is loaded in the order reorder_for_locality gives, with the same answers", "[sim]") {
  // A box bar written with its elements and vertices shuffled, as a file's order can be: loaded, it
  // comes back in Morton order (the order a thread's range needs), and a static solve on it
  // deflects the tip as the same bar written in the generator's order does, to rounding.
  const fem::TetMesh m_ordered = fem::box_mesh_24(8, 2, 2, 4.0, 1.0, 1.0);
  fem::TetMesh m = m_ordered;
  std::mt19937 rng(11);
  std::shuffle(m.tets.begin(), m.tets.end(), rng);
  std::vector<index_t> perm(m.vertices.size());
  for (size_t i = 0; i < perm.size(); ++i) perm[i] = static_cast<index_t>(i);
  std::shuffle(perm.begin(), perm.end(), rng);
  fem::TetMesh shuffled;
  shuffled.vertices.resize(perm.size());
  for (size_t i = 0; i < perm.size(); ++i) shuffled.vertices[static_cast<size_t>(perm[i])] = m.vertices[i];
  for (const fem::Tet& t : m.tets) shuffled.tets.push_back({perm[t[0]], perm[t[1]], perm[t[2]], perm[t[3]]});
  const std::string dir = temp_dir();
  fem::write_tetgen(dir + "/bar", shuffled);
  fem::write_tetgen(dir + "/ordered", m_ordered);
  const int box[3] = {0, 0, 0};
  const double size[3] = {0, 0, 0};
  const fem::TetMesh loaded = sim::load_mesh_or_box(dir + "/bar.ele", box, size);
  const std::vector<index_t> order = fem::morton_order(loaded);
  for (size_t pos = 0; pos < order.size(); ++pos) REQUIRE(order[pos] == static_cast<index_t>(pos));
  auto tip = [&](const std::string& mesh) {
    const sim::Scene s = sim::parse_scene(R"({)" + mesh + R"(, "degree": 2, "clamp": {"axis": "x"},
        "material": {"model": "linear", "young": 1e6, "poisson": 0.3, "density": 1000}, "loads": {"gravity": [0, 0, -9.81]},
        "time": "static", "solver": {"method": "cholmod"}, "output": {"probe": [4, 0.5, 0.5]}})", "bar.json");
    sim::SceneSetup b = sim::set_up(s);
    return sim::solve_static(s, b, "").probe;
  };
  const fem::Vec3 from_file = tip(R"("mesh": {"file": ")" + dir + R"(/bar.ele"})");
  const fem::Vec3 generated = tip(R"("mesh": {"file": ")" + dir + R"(/ordered.ele"})");
  CHECK(generated.norm() > 0);
  CHECK((from_file - generated).norm() <= 1e-10 * generated.norm());
  std::system(("rm -rf " + dir).c_str());
}
