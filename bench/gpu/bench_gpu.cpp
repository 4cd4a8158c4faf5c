// GPU benchmarks of pmg::gpu, each against a peer measured in the same run:
//   BM_Copy            device-to-device copy: the bandwidth every SpMV is a fraction of
//   BM_SpMV/<fmt>/<p>  BIN-BCSR, BCSR, cuSPARSE BSR and cuSPARSE CSR on the elasticity matrix of
//                      degree p = 1..3 (about the same number of unknowns for each p); every format
//                      is judged by the same minimal traffic (BCSR values, block columns and row
//                      pointers, x and y once), so GB/s compares times; a format's own count
//                      (padding, scalar indices) is printed beside it as a ratio
//   BM_MCG, BM_LibraryPCG  merged CG against block-Jacobi PCG from cuBLAS/cuSPARSE calls, cubic,
//                      fixed number of iterations (time per iteration)
//   BM_VCycle_GPU, BM_VCycle_CPU  one Chebyshev V-cycle, cubic: GPU (lowest level on the host)
//                      against the CPU cycle on all host cores
//   BM_MatrixFree/p<p> the device matrix-free operator (gpu::DeviceElasticityOperator), p = 2, 3,
//                      against BIN-BCSR's SpMV of the same matrix: time, and GB/s and GFLOP/s by
//                      the CPU operator's cost model (element data, x and y once)
//
//   bench_gpu [--pmg_nodes=36] [--pmg_iterations=100] [google benchmark flags]
//
// --pmg_nodes: BB nodes of the grid of box corners along each edge of the unit cube (p * boxes;
// box_mesh_24 adds face and box centres): 36 gives 0.6-0.7M unknowns for every degree, 48 gives
// 1.4-1.7M. Without a CUDA device the program says so and exits 77.
#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/multigrid/cycle.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/fem/matrix_free.hpp"
#include "pmg/gpu/matrix_free.hpp"
#include "pmg/gpu/solvers.hpp"

#include "../bandwidth.hpp"

#include <benchmark/benchmark.h>
#include <omp.h>

#include <chrono>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace {

using namespace pmg;
using Clock = std::chrono::steady_clock;

int g_nodes = 36, g_iterations = 100;
size_t g_copy_mib = 1024;
const char* const kFormats[] = {"bin-bcsr", "bcsr", "cusparse-bsr", "cusparse-csr"};

struct Problem {
  fem::TetMesh mesh;
  std::unique_ptr<fem::DegreeHierarchy> h;
  const Bcsr& A() const { return h->matrix(h->num_levels() - 1); }
};

Problem& problem(int p) {
  static std::map<int, std::unique_ptr<Problem>> cache;
  auto& s = cache[p];
  if (s) return *s;
  s = std::make_unique<Problem>();
  const index_t boxes = std::max(1, g_nodes / p);
  s->mesh = fem::box_mesh_24(boxes, boxes, boxes, 1.0, 1.0, 1.0);
  s->h = std::make_unique<fem::DegreeHierarchy>(s->mesh, p, fem::Material{1e6, 0.3, 1000.0},
                                                [](const fem::Vec3& X) { return X.z() < 1e-12; });
  s->h->assemble(nullptr);
  return *s;
}

/// Runs f() reps times per benchmark iteration and records the wall time after a device sync.
template <class F>
void timed(benchmark::State& state, int reps, F f) {
  f();  // warm-up (lazy buffers, first-touch)
  gpu::synchronize();
  for (auto _ : state) {
    const auto t0 = Clock::now();
    for (int i = 0; i < reps; ++i) f();
    gpu::synchronize();
    state.SetIterationTime(std::chrono::duration<double>(Clock::now() - t0).count() / reps);
  }
}

void BM_Copy(benchmark::State& state) {
  const size_t n = (g_copy_mib << 20) / 8;
  gpu::DeviceVector a(n), b(n);
  a.set_zero();
  timed(state, 10, [&] { b.assign(a); });
  state.counters["bytes"] = 16.0 * n;  // read + write
}

void BM_SpMV(benchmark::State& state, int format, int p) {
  const Bcsr& A = problem(p).A();
  const gpu::DeviceVector x(Vector(Vector::Ones(A.rows())));
  gpu::DeviceVector y(static_cast<size_t>(A.rows()));
  double bytes = 0;
  if (format == 0) {
    const BinBcsr bin(A);
    const gpu::DeviceBinBcsr d(bin);
    bytes = d.bytes_per_spmv();
    timed(state, 20, [&] { d.multiply(x, y); });
  } else if (format == 1) {
    const gpu::DeviceBcsr d(A);
    bytes = d.bytes_per_spmv();
    timed(state, 20, [&] { d.multiply(x, y); });
  } else if (format == 2) {
    const gpu::CusparseBsr d(A);
    bytes = d.bytes_per_spmv();
    timed(state, 20, [&] { d.multiply(x, y); });
  } else {
    const gpu::CusparseCsr d(A.to_csr());
    bytes = d.bytes_per_spmv();
    timed(state, 20, [&] { d.multiply(x, y); });
  }
  // The least any format must move: BCSR's (Bcsr::bytes_per_spmv).
  const double least = A.bytes_per_spmv();
  state.counters["bytes"] = least;
  state.counters["own_bytes"] = bytes;
  state.counters["unknowns"] = A.rows();
}

KrylovParams fixed_iterations() {
  KrylovParams p;
  p.fixed_iterations = true;
  p.max_iterations = g_iterations;
  p.check_every = 10;
  p.stagnation_window = 0;
  return p;
}

void BM_MCG(benchmark::State& state) {
  const Bcsr& A = problem(3).A();
  const BlockJacobiPreconditioner M(A);
  const BinBcsr bin(A);
  const gpu::DeviceBinBcsr dA(bin);
  const gpu::DeviceBlockJacobi dM(M);
  const gpu::Mcg mcg(dA, dM);
  const gpu::DeviceVector b(Vector(Vector::Ones(A.rows())));
  gpu::DeviceVector x(static_cast<size_t>(A.rows()));
  timed(state, 1, [&] {
    x.set_zero();
    mcg.solve(b, x, fixed_iterations());
  });
  state.counters["iterations"] = g_iterations;
  state.counters["unknowns"] = A.rows();
}

void BM_LibraryPCG(benchmark::State& state) {
  const Bcsr& A = problem(3).A();
  const BlockJacobiPreconditioner M(A);
  const gpu::LibraryPcg pcg(A, M);
  const gpu::DeviceVector b(Vector(Vector::Ones(A.rows())));
  gpu::DeviceVector x(static_cast<size_t>(A.rows()));
  KrylovParams p = fixed_iterations();
  p.check_every = 1;
  timed(state, 1, [&] {
    x.set_zero();
    pcg.solve(b, x, p);
  });
  state.counters["iterations"] = g_iterations;
  state.counters["unknowns"] = A.rows();
}

struct Cycles {
  std::unique_ptr<mg::MultigridCycle> cpu;  ///< Chebyshev smoothing (mg::make_cycle)
  std::unique_ptr<gpu::VCycle> gpu;
};

Cycles& cycles() {
  static std::unique_ptr<Cycles> c;
  if (c) return *c;
  c = std::make_unique<Cycles>();
  const fem::DegreeHierarchy& h = *problem(3).h;
  SolverContext ctx;
  ctx.levels = &h;
  mg::register_solvers();
  c->cpu = mg::make_cycle(Config::from_pairs({"method=pmg", "smoother=chebyshev", "operator=assembled"}, "bench"), ctx);
  c->cpu->setup(h.matrix(h.num_levels() - 1));
  const mg::MultigridCycle& cycle = *c->cpu;
  std::vector<const Bcsr*> m;
  for (int l = 0; l < h.num_levels(); ++l) m.push_back(&h.matrix(l));
  std::vector<const mg::BlockTransfer*> t;
  for (int l = 1; l < h.num_levels(); ++l) t.push_back(&cycle.transfer(l));
  c->gpu = std::make_unique<gpu::VCycle>(m, t, mg::ChebyshevParams{});
  return *c;
}

void BM_MatrixFree(benchmark::State& state, int p) {
  Problem& pr = problem(p);
  const fem::ElasticityOperator op(pr.h->finest());
  const gpu::DeviceElasticityOperator d(op);
  const gpu::DeviceVector x(Vector(Vector::Ones(op.rows())));
  gpu::DeviceVector y;
  timed(state, 20, [&] { d.multiply(x, y); });
  state.counters["bytes"] = op.bytes_per_apply();
  state.counters["flops"] = op.flops_per_apply();
  state.counters["unknowns"] = op.rows();
}

void BM_VCycle_GPU(benchmark::State& state) {
  const gpu::VCycle& C = *cycles().gpu;
  const gpu::DeviceVector r(Vector(Vector::Ones(C.rows())));
  gpu::DeviceVector z;
  timed(state, 5, [&] { C.apply(r, z); });
  state.counters["unknowns"] = C.rows();
}

void BM_VCycle_CPU(benchmark::State& state) {
  const mg::MultigridCycle& C = *cycles().cpu;
  const Vector r = Vector::Ones(C.rows());
  Vector z;
  for (auto _ : state) {
    const auto t0 = Clock::now();
    C.apply(r, z);
    benchmark::DoNotOptimize(z.data());
    state.SetIterationTime(std::chrono::duration<double>(Clock::now() - t0).count());
  }
  state.counters["unknowns"] = C.rows();
}

/// Medians per benchmark, then the ratios the issue asks for.
class SummaryReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& r : runs) {
      if (!bench::summary_run(r)) continue;
      const double seconds = r.real_accumulated_time / static_cast<double>(r.iterations);
      const std::string name = r.run_name.function_name + (r.run_name.args.empty() ? "" : "/" + r.run_name.args);
      seconds_[name] = seconds;
      const auto it = r.counters.find("bytes");
      if (it != r.counters.end()) gbs_[name] = it->second.value / seconds / 1e9;
      const auto own = r.counters.find("own_bytes");
      if (own != r.counters.end() && it != r.counters.end()) own_ratio_[name] = own->second.value / it->second.value;
      const auto fl = r.counters.find("flops");
      if (fl != r.counters.end()) gflops_[name] = fl->second.value / seconds / 1e9;
    }
  }
  void Finalize() override {
    ConsoleReporter::Finalize();
    const gpu::DeviceInfo info = gpu::device_info();
    const double copy = gbs_["BM_Copy"];
    std::printf("\nSummary: %s (sm_%d%d); device copy %.0f GB/s (peak from clocks %.0f GB/s)\n",
                info.name.c_str(), info.major, info.minor, copy, info.peak_bandwidth_gbs);
    std::printf("GB/s: the least traffic of an SpMV (BCSR's) over its time; own: the format's own count / that\n");
    std::printf("%-3s %-13s %10s %9s %9s %11s %6s\n", "p", "format", "unknowns", "us", "GB/s", "of copy", "own");
    for (int p = 1; p <= 3; ++p)
      for (const char* f : kFormats) {
        const std::string name = std::string("BM_SpMV/") + f + "/p" + std::to_string(p);
        if (!seconds_.count(name)) continue;
        std::printf("%-3d %-13s %10d %9.1f %9.1f %10.1f%% %6.2f\n", p, f, problem(p).A().rows(),
                    1e6 * seconds_[name], gbs_[name], copy > 0 ? 100.0 * gbs_[name] / copy : 0.0, own_ratio_[name]);
      }
    for (int p = 2; p <= 3; ++p) {
      const std::string mf = "BM_MatrixFree/p" + std::to_string(p), bin = "BM_SpMV/bin-bcsr/p" + std::to_string(p);
      if (!seconds_.count(mf)) continue;
      std::printf("matrix-free p = %d: %.1f us (%.1f GB/s, %.0f GFLOP/s by the CPU cost model)", p, 1e6 * seconds_[mf],
                  gbs_[mf], gflops_[mf]);
      if (seconds_.count(bin)) std::printf(", BIN-BCSR %.1f us: matrix-free %.2fx faster", 1e6 * seconds_[bin],
                                           seconds_[bin] / seconds_[mf]);
      std::printf("\n");
    }
    if (seconds_.count("BM_MCG") && seconds_.count("BM_LibraryPCG"))
      std::printf("MCG %.3f ms/iteration, library PCG %.3f ms/iteration: MCG %.2fx faster\n",
                  1e3 * seconds_["BM_MCG"] / g_iterations, 1e3 * seconds_["BM_LibraryPCG"] / g_iterations,
                  seconds_["BM_LibraryPCG"] / seconds_["BM_MCG"]);
    if (seconds_.count("BM_VCycle_GPU") && seconds_.count("BM_VCycle_CPU"))
      std::printf("V-cycle (cubic, Chebyshev): GPU %.2f ms, CPU %.2f ms on %d threads: GPU %.1fx faster\n",
                  1e3 * seconds_["BM_VCycle_GPU"], 1e3 * seconds_["BM_VCycle_CPU"], omp_get_max_threads(),
                  seconds_["BM_VCycle_CPU"] / seconds_["BM_VCycle_GPU"]);
  }

 private:
  std::map<std::string, double> seconds_, gbs_, own_ratio_, gflops_;
};

}  // namespace

int main(int argc, char** argv) {
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    if (!bench::integer_flag(a, "pmg_nodes", g_nodes, 3) &&
        !bench::integer_flag(a, "pmg_iterations", g_iterations) &&
        !bench::integer_flag(a, "pmg_copy_mib", g_copy_mib))
      rest.push_back(argv[i]);
  }
  if (gpu::device_count() == 0) {
    std::puts("bench_gpu: no CUDA device or driver; nothing to measure");
    return 77;
  }
  bench::initialize_benchmarks(rest);
  auto reg = [](const std::string& name, auto fn) {
    benchmark::RegisterBenchmark(name.c_str(), fn)->UseManualTime()->Unit(benchmark::kMicrosecond);
  };
  reg("BM_Copy", BM_Copy);
  for (int p = 1; p <= 3; ++p)
    for (int f = 0; f < 4; ++f)
      reg(std::string("BM_SpMV/") + kFormats[f] + "/p" + std::to_string(p),
          [f, p](benchmark::State& s) { BM_SpMV(s, f, p); });
  reg("BM_MCG", BM_MCG);
  reg("BM_LibraryPCG", BM_LibraryPCG);
  for (int p = 2; p <= 3; ++p)
    reg("BM_MatrixFree/p" + std::to_string(p), [p](benchmark::State& s) { BM_MatrixFree(s, p); });
  reg("BM_VCycle_GPU", BM_VCycle_GPU);
  reg("BM_VCycle_CPU", BM_VCycle_CPU);
  SummaryReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  return 0;
}
