// The stages a static MGPCG solve pays before its first iteration, each on its own, on a cube
// made by refinement (the coarser mesh then carries the linear level's cycle: coarse_meshes):
//
//   BM_Refine            one uniform refinement with its record (fem::refine_uniform)
//   BM_Hierarchy         the degree hierarchy: spaces, numbering, geometry, element ranges, transfers,
//                        and the coarser mesh's levels (set_refinements)
//   BM_LinearPattern     the linear level's block pattern with each node's elements, from a fresh
//                        assembly plan (the first assembly's share that BM_AssembleLinear leaves
//                        out; the degree-1 matrix, assembled row by row, needs no slot map)
//   BM_AssembleLinear    the linear level's assembly into its matrix (values only)
//   BM_MatrixFreeSetup   the quadratic level's matrix-free operator from nothing
//   BM_ChebyshevSetup    the quadratic level's smoother set-up: diagonal blocks and its λmax
//                        estimate (opt-fourth, degree 3): /0 10 Lanczos steps in float, as the
//                        float cycle's smoothers (the matrix-free route's default), /1 15 power
//                        iterations (its default before), /2 10 Lanczos steps in double
//   BM_GalerkinSetup     the coarser mesh's Galerkin product P^T A P: pattern and values
//   BM_GalerkinUpdate    its values again (a time step's)
//   BM_BoomerAmgSetup    BoomerAMG's set-up on the coarser mesh's matrix (the default lowest level
//                        from 40,000 unknowns there)
//   BM_CoarseSolve       the coarser mesh's solve, set-up and one application apart (counters
//                        setup_ms, per application in the time): /0 CHOLMOD, /k BoomerAMG with k
//                        V-cycles per application (the default k = 3; docs/scaling.md)
//   BM_MgpcgSetup        the whole default solver's set-up on the assembled hierarchy
//
//   bench_setup [--pmg_boxes=9] [google benchmark flags]
//
// The system: a unit cube of n^3 boxes of 24 tetrahedra refined once, degree 2, clamped at z = 0
// (n = 9: 0.6M unknowns; n = 14: 2.2M). pmg compare prints the same stages of a whole run (its
// `load:` and `set-up` lines); this measures each one repeated, medians of 5 by default.
#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/multigrid/chebyshev.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/multigrid/transfer.hpp"
#include "pmg/solvers.hpp"

#include "../bandwidth.hpp"

#include <benchmark/benchmark.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

namespace {

using namespace pmg;
using namespace pmg::bench;

int g_boxes = 9;

bool clamped(const fem::Vec3& X) { return X.z() < 1e-12; }
const fem::Material kMaterial{1e6, 0.3, 1000.0};

struct Scene {
  fem::TetMesh base, mesh;
  std::vector<fem::Refinement> record;
  std::unique_ptr<fem::DegreeHierarchy> h;
  std::shared_ptr<const LevelProvider> below;  ///< the coarser mesh under the linear level, and it
  std::unique_ptr<mg::BlockTransfer> T;        ///< the transfer between them
  std::unique_ptr<mg::GalerkinProduct> C;      ///< the coarser mesh's matrix
};

Scene& scene() {
  static std::unique_ptr<Scene> s;
  if (s) return *s;
  s = std::make_unique<Scene>();
  s->base = fem::box_mesh_24(g_boxes, g_boxes, g_boxes, 1.0, 1.0, 1.0);
  s->mesh = fem::refine_uniform(s->base, 1, &s->record);
  s->h = std::make_unique<fem::DegreeHierarchy>(s->mesh, 2, kMaterial, clamped);
  s->h->set_refinements(s->record);
  s->h->assemble_level(0, nullptr);
  s->h->update_matrix_free(1, nullptr);
  s->below = s->h->levels_below();
  s->T = std::make_unique<mg::BlockTransfer>(s->below->prolongation(1));
  s->C = std::make_unique<mg::GalerkinProduct>(*s->T, s->below->matrix(1));
  register_all_solvers();  // BoomerAMG, where hypre was built in
  return *s;
}

void count(benchmark::State& state, const Scene& s) {
  state.counters["unknowns"] = static_cast<double>(s.h->finest().num_free_dofs());
  state.counters["elements"] = static_cast<double>(s.mesh.num_tets());
}

void BM_Refine(benchmark::State& state) {
  Scene& s = scene();
  for (auto _ : state) {
    std::vector<fem::Refinement> record;
    fem::TetMesh fine = fem::refine_uniform(s.base, 1, &record);
    benchmark::DoNotOptimize(fine.tets.data());
  }
  count(state, s);
}

void BM_Hierarchy(benchmark::State& state) {
  Scene& s = scene();
  for (auto _ : state) {
    fem::DegreeHierarchy h(s.mesh, 2, kMaterial, clamped);
    h.set_refinements(s.record);
    benchmark::DoNotOptimize(h.levels_below().get());
  }
  count(state, s);
}

void BM_LinearPattern(benchmark::State& state) {
  Scene& s = scene();
  const fem::ElasticityModel& linear = s.h->model(0);
  for (auto _ : state) {
    fem::BlockAssembler plan(linear.space(), linear.assembler().free_index());
    plan.build_pattern();
    benchmark::DoNotOptimize(plan.pattern().get());
  }
  count(state, s);
}

void BM_AssembleLinear(benchmark::State& state) {
  Scene& s = scene();
  for (auto _ : state) s.h->assemble_level(0, nullptr);
  count(state, s);
}

void BM_MatrixFreeSetup(benchmark::State& state) {
  Scene& s = scene();
  for (auto _ : state) {
    fem::ElasticityOperator op(s.h->model(1));
    benchmark::DoNotOptimize(op.rows());
  }
  count(state, s);
}

void BM_ChebyshevSetup(benchmark::State& state) {
  Scene& s = scene();
  mg::ChebyshevParams p;
  p.kind = mg::ChebyshevKind::optimal_fourth;
  p.degree = 3;
  p.lanczos = state.range(0) != 1;
  p.power_iterations = p.lanczos ? 10 : 15;
  const bool single = state.range(0) == 0;
  state.SetLabel(!p.lanczos ? "15 power iterations" : single ? "10 Lanczos steps in float" : "10 Lanczos steps in double");
  for (auto _ : state) {
    mg::Chebyshev smoother(p);
    smoother.set_single_precision(single);
    smoother.setup(s.h->matrix_free(1));
    benchmark::DoNotOptimize(smoother.lambda_max());
  }
  count(state, s);
}

void BM_GalerkinSetup(benchmark::State& state) {
  Scene& s = scene();
  for (auto _ : state) {
    mg::GalerkinProduct C(*s.T, s.below->matrix(1));
    benchmark::DoNotOptimize(C.matrix().values().data());
  }
  count(state, s);
}

void BM_GalerkinUpdate(benchmark::State& state) {
  Scene& s = scene();
  for (auto _ : state) s.C->update(s.below->matrix(1));
  count(state, s);
}

/// Whether a method of that name is registered (hypre and CHOLMOD are optional in a build).
bool registered(const std::string& name) {
  for (const SolverInfo& info : registered_solvers())
    if (info.name == name) return true;
  return false;
}

void BM_BoomerAmgSetup(benchmark::State& state) {
  Scene& s = scene();
  if (!registered("boomeramg")) {
    state.SkipWithError("built without hypre");
    return;
  }
  for (auto _ : state) {
    auto amg = make_solver(Config::from_pairs({"method=boomeramg", "relax_type=16"}, "bench"), {});
    amg->setup(s.C->matrix());
    benchmark::DoNotOptimize(amg.get());
  }
  count(state, s);
}

void BM_CoarseSolve(benchmark::State& state) {
  Scene& s = scene();
  const int k = static_cast<int>(state.range(0));
  const std::vector<std::string> options =
      k == 0 ? std::vector<std::string>{"method=cholmod", "blas_threads=1", "factor_threads=0"}
             : std::vector<std::string>{"method=boomeramg", "relax_type=16", "cycles=" + std::to_string(k)};
  if (!registered(k == 0 ? "cholmod" : "boomeramg")) {
    state.SkipWithError("built without the lowest level's library");
    return;
  }
  state.SetLabel(k == 0 ? "CHOLMOD" : "BoomerAMG, " + std::to_string(k) + " V-cycle(s)");
  const Bcsr& A = s.C->matrix();
  const auto start = std::chrono::steady_clock::now();
  auto solver = make_solver(Config::from_pairs(options, "bench"), {});
  solver->setup(A);
  state.counters["setup_ms"] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  Vector b = Vector::Ones(A.rows()), x = Vector::Zero(A.rows());
  for (auto _ : state) {
    solver->apply(b, x);
    benchmark::DoNotOptimize(x.data());
  }
  state.counters["coarse_unknowns"] = static_cast<double>(A.rows());
  count(state, s);
}

void BM_MgpcgSetup(benchmark::State& state) {
  Scene& s = scene();
  SolverContext ctx;
  ctx.levels = s.h.get();
  for (auto _ : state) {
    auto solver = make_solver(Config::from_pairs({"method=mgpcg"}, "bench"), ctx);
    solver->setup(s.h->matrix_free(1));
    benchmark::DoNotOptimize(solver.get());
  }
  count(state, s);
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    if (!integer_flag(a, "pmg_boxes", g_boxes)) rest.push_back(argv[i]);
  }
  initialize_benchmarks(rest);  // 5 repetitions, medians, unless told otherwise
  for (auto [name, fn] : std::vector<std::pair<const char*, void (*)(benchmark::State&)>>{
           {"BM_Refine", BM_Refine}, {"BM_Hierarchy", BM_Hierarchy}, {"BM_LinearPattern", BM_LinearPattern},
           {"BM_AssembleLinear", BM_AssembleLinear},
           {"BM_MatrixFreeSetup", BM_MatrixFreeSetup}, {"BM_ChebyshevSetup", BM_ChebyshevSetup},
           {"BM_GalerkinSetup", BM_GalerkinSetup}, {"BM_GalerkinUpdate", BM_GalerkinUpdate},
           {"BM_BoomerAmgSetup", BM_BoomerAmgSetup}, {"BM_CoarseSolve", BM_CoarseSolve},
           {"BM_MgpcgSetup", BM_MgpcgSetup}}) {
    auto* b = benchmark::RegisterBenchmark(name, fn)->UseRealTime()->Unit(benchmark::kMillisecond);
    if (fn == BM_ChebyshevSetup) b->Arg(0)->Arg(1)->Arg(2);
    if (fn == BM_CoarseSolve) b->Arg(0)->Arg(1)->Arg(3);
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
