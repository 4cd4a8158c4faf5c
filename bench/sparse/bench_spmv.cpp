// SpMV in every format on the elasticity-like spring lattice (27-point 3x3-block stencil), against
// Eigen's CSR and the STREAM triad measured in the same run.
//
//   bench_spmv [--pmg_sizes=16,64] [--pmg_triad_mib=384] [google benchmark flags]
//
// Kernels run 5 times each unless --benchmark_repetitions is given; the summary uses the medians.
// Each kernel reports GB/s over the bytes it must move at least (values, indices, row pointers, x
// and y once; BIN-BCSR's padding included, since it is read). After the run a summary prints each
// kernel's fraction of the triad bandwidth and its speed-up over Eigen's CSR SpMV.
#include "pmg/sparse/bin_bcsr.hpp"
#include "pmg/sparse/generators.hpp"

#include "../bandwidth.hpp"

#include <benchmark/benchmark.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <unistd.h>
#include <vector>

namespace {

using namespace pmg;
using namespace pmg::bench;
using EigenCsr = Eigen::SparseMatrix<double, Eigen::RowMajor, int>;

struct Matrices {
  Bcsr bcsr;
  Csr csr;
  EigenCsr eigen;
  BinBcsr bin;
  Vector x, y;
};

std::map<int, std::unique_ptr<Matrices>>& cache() {
  static std::map<int, std::unique_ptr<Matrices>> c;
  return c;
}

Matrices& matrices(int n) {
  if (!cache().count(n)) {
    cache().clear();  // keep one size in memory at a time (n = 64 takes about 3 GB in all formats)
    auto& m = cache()[n];
    m = std::make_unique<Matrices>();
    m->bcsr = spring_lattice(n);
    m->csr = m->bcsr.to_csr();
    m->eigen = m->csr.to_eigen();
    m->bin = BinBcsr(m->bcsr);
    m->x = Vector::LinSpaced(m->csr.rows(), 0.0, 1.0);
    m->y = Vector::Zero(m->csr.rows());
  }
  return *cache()[n];
}

template <class Kernel>
void run_spmv(benchmark::State& state, double bytes, Kernel&& kernel) {
  for (auto _ : state) {
    kernel();
    benchmark::ClobberMemory();
  }
  state.counters["bytes"] = bytes;
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * bytes));
}

void BM_SpMV_EigenCSR(benchmark::State& state) {
  Matrices& m = matrices(static_cast<int>(state.range(0)));
  const double bytes = 12.0 * m.eigen.nonZeros() + 4.0 * (m.eigen.rows() + 1) + 16.0 * m.eigen.rows();
  run_spmv(state, bytes, [&] { m.y.noalias() = m.eigen * m.x; });
}

void BM_SpMV_CSR(benchmark::State& state) {
  Matrices& m = matrices(static_cast<int>(state.range(0)));
  const double bytes = 12.0 * m.csr.nnz() + 8.0 * (m.csr.rows() + 1) + 16.0 * m.csr.rows();
  run_spmv(state, bytes, [&] { m.csr.multiply(m.x.data(), m.y.data()); });
}

void BM_SpMV_BCSR(benchmark::State& state) {
  Matrices& m = matrices(static_cast<int>(state.range(0)));
  const double bytes =
      76.0 * m.bcsr.num_blocks() + 8.0 * (m.bcsr.block_rows() + 1) + 16.0 * m.bcsr.rows();
  run_spmv(state, bytes, [&] { m.bcsr.multiply(m.x.data(), m.y.data()); });
}

void BM_SpMV_BinBCSR(benchmark::State& state) {
  Matrices& m = matrices(static_cast<int>(state.range(0)));
  state.counters["padding"] = m.bin.padding_ratio();
  run_spmv(state, m.bin.bytes_per_spmv(), [&] { m.bin.multiply(m.x.data(), m.y.data()); });
}

// ---- summary: fraction of triad bandwidth and speed-up over Eigen, from the runs just made -------
class SummaryReporter : public benchmark::ConsoleReporter {
 public:
  using ConsoleReporter::ConsoleReporter;
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& r : runs) {
      // With repetitions (the default here) only the medians are used; otherwise the single run.
      if (!summary_run(r)) continue;
      const double seconds = r.real_accumulated_time / static_cast<double>(r.iterations);
      const auto it = r.counters.find("bytes");
      if (it == r.counters.end()) continue;
      results_.push_back({r.benchmark_name(), seconds, it->second.value / seconds / 1e9});
    }
  }
  void Finalize() override {
    ConsoleReporter::Finalize();
    double triad = 0.0, read = 0.0;
    for (const auto& r : results_) {
      if (r.name.rfind("BM_Triad", 0) == 0) triad = std::max(triad, r.gbs);
      if (r.name.rfind("BM_ReadSum", 0) == 0) read = std::max(read, r.gbs);
    }
    std::printf("\nSummary (%d threads; triad %.2f GB/s, read-only %.2f GB/s):\n",
                omp_get_max_threads(), triad, read);
    std::printf("%-22s %10s %9s %9s %9s %9s\n", "kernel", "time [ms]", "GB/s", "of triad",
                "of read", "vs Eigen");
    for (const auto& r : results_) {
      if (r.name.rfind("BM_SpMV_", 0) != 0) continue;
      const std::string name = r.name.substr(8, r.name.rfind('/') - 8);  // "BCSR/64"
      const std::string size = name.substr(name.find('/'));
      double eigen = 0.0;
      for (const auto& e : results_)
        if (e.name.rfind("BM_SpMV_EigenCSR" + size + "/", 0) == 0) eigen = e.seconds;
      std::printf("%-22s %10.3f %9.2f %8.0f%% %8.0f%% %8.2fx\n", name.c_str(), 1e3 * r.seconds,
                  r.gbs, triad > 0 ? 100.0 * r.gbs / triad : 0.0, read > 0 ? 100.0 * r.gbs / read : 0.0,
                  eigen > 0 ? eigen / r.seconds : 0.0);
    }
  }

 private:
  struct Result {
    std::string name;
    double seconds, gbs;
  };
  std::vector<Result> results_;
};

std::vector<int> parse_sizes(const std::string& s) {
  std::vector<int> out;
  std::stringstream ss(s);
  for (std::string tok; std::getline(ss, tok, ',');)
    out.push_back(static_cast<int>(parse_integer(tok, "--pmg_sizes", 1)));
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<int> sizes{16, 64};
  size_t triad_mib = 384;  // three arrays of 128 MiB each: 12x the 32 MiB last-level cache
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--pmg_sizes=", 0) == 0) sizes = parse_sizes(a.substr(12));
    else if (!integer_flag(a, "pmg_triad_mib", triad_mib)) rest.push_back(argv[i]);
  }
  start_benchmarks(rest, triad_mib);
  for (int n : sizes)
    for (auto [name, fn] : std::vector<std::pair<const char*, void (*)(benchmark::State&)>>{
             {"BM_SpMV_EigenCSR", BM_SpMV_EigenCSR},
             {"BM_SpMV_CSR", BM_SpMV_CSR},
             {"BM_SpMV_BCSR", BM_SpMV_BCSR},
             {"BM_SpMV_BinBCSR", BM_SpMV_BinBCSR}})
      benchmark::RegisterBenchmark(name, fn)->Arg(n)->UseRealTime()->Unit(benchmark::kMillisecond);
  // Colour only on a terminal: the output is also pasted into logs and the docs.
  SummaryReporter reporter(isatty(fileno(stdout)) ? benchmark::ConsoleReporter::OO_ColorTabular
                                                  : benchmark::ConsoleReporter::OO_Tabular);
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  return 0;
}
