// Memory-bandwidth probes measured in the same run as the kernels they are compared with.
// Call set_probe_mib() before registering BM_Triad / BM_ReadSum.
#pragma once

#include <benchmark/benchmark.h>

#include <cerrno>
#include <chrono>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace pmg::bench {

/// A whole decimal integer >= min from text, or exit code 2 naming `what` (no exception escapes
/// main as an abort).
inline long long parse_integer(const std::string& text, const std::string& what, long long min) {
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno == ERANGE || v < min) {
    std::fprintf(stderr, "%s: expected an integer >= %lld, got '%s'\n", what.c_str(), min, text.c_str());
    std::exit(2);
  }
  return v;
}

/// If arg is "--NAME=VALUE", parses VALUE into out (an integer >= min, else exit code 2) and
/// returns true; any other argument: false.
template <class Int>
bool integer_flag(const std::string& arg, const std::string& name, Int& out, long long min = 1) {
  const std::string prefix = "--" + name + "=";
  if (arg.rfind(prefix, 0) != 0) return false;
  out = static_cast<Int>(parse_integer(arg.substr(prefix.size()), "--" + name, min));
  return true;
}

inline size_t g_triad_elems = 0;  ///< elements per array; set_probe_mib() sets it
inline void set_probe_mib(size_t mib) { g_triad_elems = (mib << 20) / 8 / 3; }

// ---- STREAM triad: a = b + s c, 24 bytes per element (no write-allocate counted, as STREAM) ------
inline double triad_once(std::vector<double>& a, const std::vector<double>& b, const std::vector<double>& c) {
  const auto t0 = std::chrono::steady_clock::now();
  const long n = static_cast<long>(a.size());
  double* ap = a.data();
  const double* bp = b.data();
  const double* cp = c.data();
#pragma omp parallel for schedule(static)
  for (long i = 0; i < n; ++i) ap[i] = bp[i] + 3.0 * cp[i];
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

struct TriadArrays {
  std::vector<double> a, b, c;
  explicit TriadArrays(size_t n) : a(n), b(n), c(n) {
    // First touch in parallel, with the same static schedule as the kernel.
#pragma omp parallel for schedule(static)
    for (long i = 0; i < static_cast<long>(n); ++i) a[i] = 0.0, b[i] = 1.0, c[i] = 2.0;
  }
};

inline void BM_Triad(benchmark::State& state) {
  TriadArrays t(g_triad_elems);
  for (auto _ : state) {
    triad_once(t.a, t.b, t.c);
    benchmark::DoNotOptimize(t.a.data());
    benchmark::ClobberMemory();
  }
  state.counters["bytes"] = 24.0 * g_triad_elems;
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * 24.0 * g_triad_elems));
}

// Read-only probe: sum of the three triad arrays, 24 bytes per element. SpMV mostly reads, and a
// write costs a read for ownership besides, so this is the tighter ceiling for it.
inline void BM_ReadSum(benchmark::State& state) {
  TriadArrays t(g_triad_elems);
  const long n = static_cast<long>(g_triad_elems);
  const double *a = t.a.data(), *b = t.b.data(), *c = t.c.data();
  for (auto _ : state) {
    double s = 0.0;
    // simd: lets the compiler split the sum over vector lanes (a single add chain is latency bound).
#pragma omp parallel for simd schedule(static) reduction(+ : s)
    for (long i = 0; i < n; ++i) s += a[i] + b[i] + c[i];
    benchmark::DoNotOptimize(s);
  }
  state.counters["bytes"] = 24.0 * g_triad_elems;
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * 24.0 * g_triad_elems));
}

/// Google Benchmark initialised with the arguments the caller did not consume; repetitions default
/// to 5 with aggregates only (these machines are noisy; summaries use medians).
inline void initialize_benchmarks(std::vector<char*>& rest) {
  bool repetitions_given = false;
  for (const char* a : rest) repetitions_given |= std::string(a).rfind("--benchmark_repetitions", 0) == 0;
  static char reps[] = "--benchmark_repetitions=5";
  static char aggregates[] = "--benchmark_report_aggregates_only=true";
  if (!repetitions_given) {
    rest.push_back(reps);
    rest.push_back(aggregates);
  }
  int rest_argc = static_cast<int>(rest.size());
  benchmark::Initialize(&rest_argc, rest.data());
}

/// The run a summary should read: the median of repeated runs, or the single run.
inline bool summary_run(const benchmark::BenchmarkReporter::Run& r) {
  using Run = benchmark::BenchmarkReporter::Run;
  if (r.error_occurred) return false;
  return r.run_type == Run::RT_Aggregate ? r.aggregate_name == "median" : r.repetitions <= 1;
}

/// The common start of a pmgkit CPU benchmark: initialize_benchmarks(), then the probe arrays
/// sized and the two probes registered.
inline void start_benchmarks(std::vector<char*>& rest, size_t triad_mib) {
  initialize_benchmarks(rest);
  set_probe_mib(triad_mib);
  benchmark::RegisterBenchmark("BM_Triad", BM_Triad)->UseRealTime()->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("BM_ReadSum", BM_ReadSum)->UseRealTime()->Unit(benchmark::kMillisecond);
}

}  // namespace pmg::bench
