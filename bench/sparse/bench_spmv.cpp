// SpMV in every format on the elasticity-like spring lattice (27-point 3x3-block stencil) and on
// matrices read from files (e.g. FEM systems written by `pmg compare --export-petsc DIR`), against
// Eigen's CSR and the STREAM triad measured in the same run.
//
//   bench_spmv [--pmg_sizes=16,64] [--pmg_matrix=NAME=FILE ...] [--pmg_triad_mib=384]
//              [google benchmark flags]
//
// FILE is PETSc binary (.petsc) or Matrix Market (.mtx), square with a size divisible by 3 (read
// as 3x3 blocks). --pmg_sizes= (empty) runs no lattice. Before the timings a layout table lists,
// per matrix, BIN-BCSR's lanes, padding and bytes against BCSR's, also for the unsorted layout.
//
// Kernels run 5 times each unless --benchmark_repetitions is given; the summary uses the medians.
// Each kernel reports GB/s over the bytes it must move at least (values, indices, row pointers, x
// and y once; BIN-BCSR's padding included, since it is read). After the run a summary prints each
// kernel's fraction of the triad bandwidth and its speed-up over Eigen's CSR SpMV.
#include "pmg/sparse/bin_bcsr.hpp"
#include "pmg/sparse/generators.hpp"
#include "pmg/sparse/matrix_market.hpp"
#include "pmg/sparse/petsc_binary.hpp"

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

/// A matrix to benchmark: the lattice of size n, or a file.
struct Source {
  std::string name;  ///< "16" for the lattice, the given name for a file
  int lattice = 0;
  std::string path;
};

std::unique_ptr<Matrices> load(const Source& src) {
  auto m = std::make_unique<Matrices>();
  if (src.path.empty()) {
    m->bcsr = spring_lattice(src.lattice);
  } else {
    const bool mtx = src.path.size() > 4 && src.path.compare(src.path.size() - 4, 4, ".mtx") == 0;
    const Csr A = mtx ? read_matrix_market(src.path) : read_petsc_binary_matrix(src.path);
    if (A.rows() != A.cols() || A.rows() % 3 != 0)
      throw InputError(src.path + ": need a square matrix with a size divisible by 3, got " +
                       std::to_string(A.rows()) + " x " + std::to_string(A.cols()));
    m->bcsr = Bcsr::from_csr(A);
  }
  m->csr = m->bcsr.to_csr();
  m->eigen = m->csr.to_eigen();
  m->bin = BinBcsr(m->bcsr);
  m->x = Vector::LinSpaced(m->csr.rows(), 0.0, 1.0);
  m->y = Vector::Zero(m->csr.rows());
  return m;
}

// One matrix in memory at a time (the n = 64 lattice takes about 3 GB in all formats).
Matrices& matrices(const Source& src) {
  static std::string current;
  static std::unique_ptr<Matrices> m;
  if (!m || current != src.name) {
    m.reset();
    m = load(src);
    current = src.name;
  }
  return *m;
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

void BM_SpMV_EigenCSR(benchmark::State& state, const Source& src) {
  Matrices& m = matrices(src);
  const double bytes = 12.0 * m.eigen.nonZeros() + 4.0 * (m.eigen.rows() + 1) + 16.0 * m.eigen.rows();
  run_spmv(state, bytes, [&] { m.y.noalias() = m.eigen * m.x; });
}

void BM_SpMV_CSR(benchmark::State& state, const Source& src) {
  Matrices& m = matrices(src);
  const double bytes = 12.0 * m.csr.nnz() + 8.0 * (m.csr.rows() + 1) + 16.0 * m.csr.rows();
  run_spmv(state, bytes, [&] { m.csr.multiply(m.x.data(), m.y.data()); });
}

void BM_SpMV_BCSR(benchmark::State& state, const Source& src) {
  Matrices& m = matrices(src);
  run_spmv(state, m.bcsr.bytes_per_spmv(), [&] { m.bcsr.multiply(m.x.data(), m.y.data()); });
}

void BM_SpMV_BinBCSR(benchmark::State& state, const Source& src) {
  Matrices& m = matrices(src);
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

// BIN-BCSR's layout per matrix: the chosen lanes and window against the unsorted one-lane layout.
void print_layouts(const std::vector<Source>& sources) {
  std::printf("BIN-BCSR layout (bytes per SpMV against BCSR's: values, columns, row data, x, y once)\n");
  std::printf("%-12s %10s %12s %6s %7s %9s %9s %16s\n", "matrix", "rows", "blocks/row", "lanes", "window",
              "padding", "bytes", "unsorted 1 lane");
  for (const Source& src : sources) {
    const Matrices& m = matrices(src);
    const BinBcsr unsorted(m.bcsr, {1, 1});
    std::printf("%-12s %10d %12.1f %6d %7d %8.3fx %8.3fx %15.3fx\n", src.name.c_str(), m.bcsr.rows(),
                static_cast<double>(m.bcsr.num_blocks()) / m.bcsr.block_rows(), m.bin.lanes(),
                m.bin.sort_window(), m.bin.padding_ratio(),
                m.bin.bytes_per_spmv() / m.bcsr.bytes_per_spmv(), unsorted.bytes_per_spmv() / m.bcsr.bytes_per_spmv());
  }
  std::printf("\n");
}

std::vector<int> parse_sizes(const std::string& s) {
  std::vector<int> out;
  if (s.empty()) return out;
  std::stringstream ss(s);
  for (std::string tok; std::getline(ss, tok, ',');)
    out.push_back(static_cast<int>(parse_integer(tok, "--pmg_sizes", 1)));
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<int> sizes{16, 64};
  std::vector<Source> files;
  size_t triad_mib = 384;  // three arrays of 128 MiB each: 12x the 32 MiB last-level cache
  std::vector<char*> rest;
  try {
    for (int i = 0; i < argc; ++i) {
      const std::string a = argv[i];
      if (a.rfind("--pmg_sizes=", 0) == 0) {
        sizes = parse_sizes(a.substr(12));
      } else if (a.rfind("--pmg_matrix=", 0) == 0) {
        const std::string v = a.substr(13);
        const auto eq = v.find('=');
        if (eq == std::string::npos || eq == 0 || eq + 1 == v.size())
          throw InputError("--pmg_matrix: expected NAME=FILE, got '" + v + "'");
        const std::string name = v.substr(0, eq);
        if (name.find('/') != std::string::npos || name.find_first_not_of("0123456789") == std::string::npos)
          throw InputError("--pmg_matrix: NAME may not contain '/' or be a number (the lattice sizes' names), got '" +
                           name + "'");
        files.push_back({v.substr(0, eq), 0, v.substr(eq + 1)});
      } else if (!integer_flag(a, "pmg_triad_mib", triad_mib)) {
        rest.push_back(argv[i]);
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_spmv: %s\n", e.what());
    return 2;
  }
  std::vector<Source> sources;
  for (int n : sizes) sources.push_back({std::to_string(n), n, ""});
  sources.insert(sources.end(), files.begin(), files.end());
  try {
    print_layouts(sources);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_spmv: %s\n", e.what());
    return 1;
  }
  start_benchmarks(rest, triad_mib);
  for (const Source& src : sources)
    for (auto [name, fn] : std::vector<std::pair<const char*, void (*)(benchmark::State&, const Source&)>>{
             {"BM_SpMV_EigenCSR", BM_SpMV_EigenCSR},
             {"BM_SpMV_CSR", BM_SpMV_CSR},
             {"BM_SpMV_BCSR", BM_SpMV_BCSR},
             {"BM_SpMV_BinBCSR", BM_SpMV_BinBCSR}})
      benchmark::RegisterBenchmark((std::string(name) + "/" + src.name).c_str(), fn, src)
          ->UseRealTime()
          ->Unit(benchmark::kMillisecond);
  // Colour only on a terminal: the output is also pasted into logs and the docs.
  SummaryReporter reporter(isatty(fileno(stdout)) ? benchmark::ConsoleReporter::OO_ColorTabular
                                                  : benchmark::ConsoleReporter::OO_Tabular);
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  return 0;
}
