// One p-multigrid V-cycle on a cubic (or --pmg_degree) elasticity system, against the least bytes
// it must move and the memory bandwidth measured in the same run.
//
//   bench_vcycle [--pmg_boxes=8] [--pmg_degree=3] [--pmg_sweeps=5] [--pmg_triad_mib=384]
//                [google benchmark flags]
//
// The system: a unit cube of n^3 boxes of 24 tetrahedra, clamped at z = 0, static stiffness (cubic
// n = 8: 164k unknowns). The bytes model counts every stream once per pass and nothing twice:
//   Gauss-Seidel sweep  76 B per 3x3 block (values + column index) + per block row 8 B row pointer,
//                       72 B inverse diagonal block, 24 B b read, 48 B x read and written
//   residual            76 B per block + per block row 8 + 24 (x) + 24 (b) + 24 (r written)
//   restriction (Pᵀ)    12 B per nonzero of the scalar P + 24 B per fine and per coarse node
//   prolongation        12 B per nonzero of P + 48 B per fine node (read and write) + 24 per coarse
//   lowest level        CHOLMOD's L read twice (forward and backward: 12 B per nonzero)
// The bound is bytes / read-only bandwidth (a cycle mostly reads); the summary prints the measured
// cycle time as a multiple of it (target: within 2x).
#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/cholmod/cholmod_solver.hpp"

#include "../bandwidth.hpp"
#include "cube.hpp"

#include <benchmark/benchmark.h>
#include <omp.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

namespace {

using namespace pmg;
using namespace pmg::bench;

int g_boxes = 8, g_degree = 3, g_sweeps = 5;

struct Scene {
  std::unique_ptr<ClampedCube> cube;
  fem::DegreeHierarchy* h = nullptr;  // the cube's
  std::unique_ptr<Solver> pmg;  ///< one V-cycle per apply
  Vector b, x;
  double bytes = 0.0;
  std::vector<std::pair<std::string, double>> parts;  // bytes per part of the cycle
};

Scene& scene() {
  static std::unique_ptr<Scene> s;
  if (s) return *s;
  s = std::make_unique<Scene>();
  s->cube = std::make_unique<ClampedCube>(g_boxes, g_degree);
  s->h = s->cube->h.get();
  SolverContext ctx;
  ctx.levels = s->h;
  mg::register_solvers();
  s->pmg = make_solver(
      Config::from_pairs({"method=pmg", "smoother.sweeps=" + std::to_string(g_sweeps)}, "bench"), ctx);
  s->pmg->setup(s->h->matrix(s->h->num_levels() - 1));
  const index_t n = s->h->matrix(s->h->num_levels() - 1).rows();
  s->b = Vector::Ones(n);
  s->x = Vector::Zero(n);

  double smooth = 0, residual = 0, transfer = 0;
  for (int l = 1; l < s->h->num_levels(); ++l) {
    const Bcsr& A = s->h->matrix(l);
    const double nb = static_cast<double>(A.num_blocks()), rows = A.block_rows();
    smooth += 2.0 * g_sweeps * (76.0 * nb + (8.0 + 72.0 + 24.0 + 48.0) * rows);
    residual += 76.0 * nb + (8.0 + 72.0) * rows;
    const Csr& P = s->h->prolongation(l);
    const double pnz = static_cast<double>(P.nnz()), fine = P.rows(), coarse = P.cols();
    transfer += (12.0 * pnz + 8.0 * fine + 24.0 * (fine + coarse)) +
                (12.0 * pnz + 8.0 * fine + 48.0 * fine + 24.0 * coarse);
  }
  CholmodSolver chol;
  chol.setup(s->h->matrix(0));
  const double coarse = 2.0 * 12.0 * chol.factor_nnz() + 4.0 * 8.0 * s->h->matrix(0).rows();
  s->parts = {{"smoothing", smooth}, {"residuals", residual}, {"transfers", transfer}, {"lowest level", coarse}};
  for (const auto& [name, b] : s->parts) s->bytes += b;
  return *s;
}

void BM_VCycle(benchmark::State& state) {
  Scene& s = scene();
  for (auto _ : state) {
    s.pmg->apply(s.b, s.x);
    benchmark::DoNotOptimize(s.x.data());
  }
  state.counters["bytes"] = s.bytes;
  state.counters["unknowns"] = static_cast<double>(s.b.size());
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * s.bytes));
}

class SummaryReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& r : runs) {
      const auto it = r.counters.find("bytes");
      if (!summary_run(r) || it == r.counters.end()) continue;
      const double seconds = r.real_accumulated_time / static_cast<double>(r.iterations);
      const double gbs = it->second.value / seconds / 1e9;
      if (r.benchmark_name().rfind("BM_Triad", 0) == 0) triad_ = std::max(triad_, gbs);
      else if (r.benchmark_name().rfind("BM_ReadSum", 0) == 0) read_ = std::max(read_, gbs);
      else cycle_ = seconds;
    }
  }
  void Finalize() override {
    ConsoleReporter::Finalize();
    const Scene& s = scene();
    std::printf("\nSummary (%d threads; degree %d, %ld unknowns, %d sweeps; triad %.2f GB/s, read-only %.2f GB/s)\n",
                omp_get_max_threads(), g_degree, static_cast<long>(s.b.size()), g_sweeps, triad_, read_);
    for (const auto& [name, b] : s.parts)
      std::printf("  %-13s %9.1f MB  (%4.1f%%)\n", name.c_str(), b / 1e6, 100.0 * b / s.bytes);
    const double bound = read_ > 0 ? s.bytes / (read_ * 1e9) : 0.0;
    std::printf("V-cycle: %.2f ms measured, %.1f MB moved at least, bound %.2f ms at the read-only "
                "bandwidth: %.2fx the bound\n",
                1e3 * cycle_, s.bytes / 1e6, 1e3 * bound, bound > 0 ? cycle_ / bound : 0.0);
  }

 private:
  double triad_ = 0, read_ = 0, cycle_ = 0;
};

}  // namespace

int main(int argc, char** argv) {
  size_t triad_mib = 384;
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    if (!integer_flag(a, "pmg_boxes", g_boxes) && !integer_flag(a, "pmg_degree", g_degree, 2) &&
        !integer_flag(a, "pmg_sweeps", g_sweeps) && !integer_flag(a, "pmg_triad_mib", triad_mib))
      rest.push_back(argv[i]);
  }
  if (g_degree > 3) {
    std::fprintf(stderr, "bench_vcycle: --pmg_degree must be 2 or 3\n");
    return 2;
  }
  start_benchmarks(rest, triad_mib);
  benchmark::RegisterBenchmark("BM_VCycle", BM_VCycle)->UseRealTime()->Unit(benchmark::kMillisecond);
  SummaryReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  return 0;
}
