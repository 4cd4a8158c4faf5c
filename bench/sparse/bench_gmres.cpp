// GMRES's own work (pmg/sparse/saddle_point.hpp) against the memory bandwidth measured in the same
// run: the Gram–Schmidt passes with the Krylov basis in double and with float_basis, and ops::dot.
//
//   bench_gmres [--pmg_n=118000] [--pmg_triad_mib=384] [google benchmark flags]
//
// BM_Gmres/<float_basis>/<fresh>: unpreconditioned GMRES(50) to 1e-6 on a shifted 1-D Laplacian of
// n unknowns (tridiagonal 2 + 0.3, -1: about 30 iterations, so the orthogonalisation, not the
// product, is most of the time; n defaults to the size of Homer P3's mixed system). fresh = 0 keeps
// one GmresWorkspace across solves (the vectors are faulted in once, as in a time-stepped scene);
// fresh = 1 allocates and faults in the basis in every solve (a single solve, as `pmg compare`).
// Counters: iterations, and for the basis in double the bytes its passes must move at least (each
// of the 2 passes of iteration j reads its j + 1 vectors) per second.
// BM_Dot/<n>: ops::dot, 16 bytes per entry.
#include "pmg/sparse/csr.hpp"
#include "pmg/sparse/saddle_point.hpp"
#include "pmg/sparse/vector_ops.hpp"

#include "../bandwidth.hpp"

#include <benchmark/benchmark.h>

#include <cstdio>
#include <exception>
#include <string>
#include <unistd.h>
#include <vector>

namespace {

using namespace pmg;
using namespace pmg::bench;

index_t g_n = 118000;

Csr shifted_laplacian(index_t n) {
  std::vector<Triplet> t;
  t.reserve(static_cast<size_t>(3 * n));
  for (index_t i = 0; i < n; ++i) {
    t.emplace_back(i, i, 2.3);
    if (i + 1 < n) t.emplace_back(i, i + 1, -1.0), t.emplace_back(i + 1, i, -1.0);
  }
  return Csr::from_triplets(n, n, t);
}

void BM_Gmres(benchmark::State& state) {
  const bool float_basis = state.range(0) != 0, fresh = state.range(1) != 0;
  const Csr A = shifted_laplacian(g_n);
  Vector b(g_n);
  for (index_t i = 0; i < g_n; ++i) b[i] = 1.0 + 0.5 * ((i * 7919) % 13) / 13.0;
  KrylovParams p;
  p.rel_tol = 1e-6;
  GmresParams g;
  g.float_basis = float_basis;
  GmresWorkspace kept;
  SolveResult r;
  for (auto _ : state) {
    Vector x = Vector::Zero(g_n);
    GmresWorkspace own;
    r = gmres(A, nullptr, b, x, p, g, nullptr, fresh ? &own : &kept);
    if (!r.ok()) {
      state.SkipWithError(("GMRES did not converge: " + r.message).c_str());
      return;
    }
    benchmark::DoNotOptimize(x.data());
  }
  state.counters["iterations"] = r.iterations;
  // With the basis in double: the bytes of its passes, 2 passes over j + 1 vectors in iteration j
  // (a lower bound: w's own traffic is left out), as a rate.
  if (!float_basis) {
    double bytes = 0.0;
    for (int j = 0; j < r.iterations; ++j) bytes += 2.0 * (j + 1) * 8.0 * g_n;
    state.counters["basis_bytes"] = benchmark::Counter(bytes, benchmark::Counter::kIsIterationInvariantRate);
  }
}

void BM_Dot(benchmark::State& state) {
  const auto n = static_cast<Eigen::Index>(state.range(0));
  Vector x = Vector::Constant(n, 1.25), y = Vector::Constant(n, 0.5);
  for (auto _ : state) benchmark::DoNotOptimize(ops::dot(x, y));
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * 16 * n);
}

}  // namespace

int main(int argc, char** argv) {
  size_t triad_mib = 384;  // three arrays of 128 MiB each: 12x the 32 MiB last-level cache
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    if (!integer_flag(a, "pmg_n", g_n, 16) && !integer_flag(a, "pmg_triad_mib", triad_mib)) rest.push_back(argv[i]);
  }
  start_benchmarks(rest, triad_mib);
  for (int fb : {0, 1})
    for (int fresh : {0, 1})
      benchmark::RegisterBenchmark("BM_Gmres", BM_Gmres)
          ->Args({fb, fresh})
          ->UseRealTime()
          ->Unit(benchmark::kMillisecond);
  for (long n : {static_cast<long>(g_n), 10000000L})
    benchmark::RegisterBenchmark("BM_Dot", BM_Dot)
        ->Arg(n)
        ->UseRealTime()
        ->Unit(benchmark::kMicrosecond);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
