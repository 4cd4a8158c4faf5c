// The matrix-free BB elasticity operator (pmg/fem/matrix_free.hpp) on a roofline measured in the
// same run: this machine's FMA peak (independent FMA chains on the vectors of each instruction set,
// double and float, 1 and all threads) and memory bandwidth (STREAM triad, read-only sum), beside
// BCSR SpMV of the same assembled matrix.
//
//   bench_operator [--pmg_boxes=8] [--pmg_triad_mib=384] [google benchmark flags]
//
// The system: a unit cube of n^3 boxes of 24 tetrahedra, clamped at z = 0, degrees 2 and 3 (cubic
// n = 8: 177k unknowns). BM_MatrixFree/p/kernel/precision/threads/dynamic applies y = K x
// (dynamic 0) or y = M x + dt^2 K_R x (1, the implicit-Euler matrix) with one element kernel
// (0 reference, 1 generic, 2 avx2, 3 avx512) in double (8) or float (4); BM_Bcsr is y = K x with
// the assembled matrix; BM_MatrixFreeUpdate a corotational step's update(R); BM_ElementForce/p/kernel
// a step's elastic force and energy (kernel 0: the scalar element loop, -1: the batched kernel
// the CPU runs); BM_Assemble/p a
// level's assembly into its matrix, BM_AssembleFirst/p the same from nothing (pattern, slots,
// colouring, zeroed values: the set-up's first), p = 1 and 2.
// Bytes per unknown are each kernel's least traffic:
//   BCSR          76 B per 3x3 block (values + column index), 8 B per block row (row pointer),
//                 24 B x read and 24 B y written per block row
//   matrix-free   128 B element data + 4 B per element node (indices), x read once, y zeroed and
//                 accumulated (read and written once more); float halves all but the indices
// The summary prints the roofline, then per kernel its time, GFLOP/s, the fraction of the FMA peak
// of its precision and thread count, bytes per unknown and its time over the bandwidth bound.
#include "pmg/fem/generators.hpp"
#include "pmg/fem/matrix_free.hpp"

#include "../bandwidth.hpp"

#include <benchmark/benchmark.h>
#include <omp.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace {

using namespace pmg;
using namespace pmg::bench;

int g_boxes = 8;

struct System {
  fem::TetMesh mesh;
  std::unique_ptr<fem::ElasticityModel> model;
  Bcsr K;
  std::unique_ptr<fem::ElasticityOperator> op;
  fem::Rotations R;
  Vector x, y;
  double bcsr_bytes = 0;
};

System& system_of(int p) {
  static std::map<int, std::unique_ptr<System>> systems;
  auto& s = systems[p];
  if (s) return *s;
  s = std::make_unique<System>();
  s->mesh = fem::box_mesh_24(g_boxes, g_boxes, g_boxes, 1.0, 1.0, 1.0);
  s->model = std::make_unique<fem::ElasticityModel>(s->mesh, p, fem::Material{1e6, 0.3, 1000.0});
  s->model->fix_where([](const fem::Vec3& X) { return X.z() < 1e-12; });
  s->K = s->model->assembler().make_matrix();
  s->model->assemble(nullptr, Vector(), s->K, nullptr);
  s->op = std::make_unique<fem::ElasticityOperator>(*s->model);
  const index_t n = s->K.rows();
  s->x = Vector::Zero(n);
  for (index_t i = 0; i < n; ++i) s->x[i] = std::sin(0.1 * i);
  s->y = Vector::Zero(n);
  s->R.assign(s->mesh.num_tets(), Eigen::AngleAxisd(0.3, fem::Vec3(1, 2, 3).normalized()).toRotationMatrix());
  s->bcsr_bytes = 76.0 * s->K.num_blocks() + (8.0 + 48.0) * s->K.block_rows();
  return *s;
}

void report(benchmark::State& state, const System& s, double bytes, double flops) {
  state.counters["bytes"] = bytes;
  state.counters["flops"] = flops;
  state.counters["bytes_per_unknown"] = bytes / static_cast<double>(s.x.size());
  state.counters["unknowns"] = static_cast<double>(s.x.size());
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * bytes));
}

void BM_Bcsr(benchmark::State& state) {
  System& s = system_of(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    s.K.multiply(s.x.data(), s.y.data());
    benchmark::DoNotOptimize(s.y.data());
  }
  report(state, s, s.bcsr_bytes, 18.0 * s.K.num_blocks());
}

// ---- The arithmetic peak: independent FMA chains on vectors of each instruction set ------------
// Twelve chains a = a * m + c (two FMA pipes of four cycles' latency need eight), in each thread.
template <class T, int Bytes>
struct Vec {
  typedef T type __attribute__((vector_size(Bytes)));
};

template <class T, int Bytes>
inline T fma_chains(long iterations) {
  using V = typename Vec<T, Bytes>::type;
  constexpr int kChains = 12;
  V a[kChains];
  for (int k = 0; k < kChains; ++k) a[k] = V{} + static_cast<T>(1 + k) * T(1e-3);
  V m = V{} + T(0.999999), c = V{} + T(1e-7);
  for (long i = 0; i < iterations; ++i) {
    for (int k = 0; k < kChains; ++k) a[k] = a[k] * m + c;
    __asm__ volatile("" : "+x"(m));  // keeps the chains from being folded
  }
  T s = 0;
  for (int k = 0; k < kChains; ++k)
    for (int l = 0; l < Bytes / static_cast<int>(sizeof(T)); ++l) s += a[k][l];
  return s;
}

template <class T>
T fma_generic(long n) { return fma_chains<T, 16>(n); }
#if defined(__x86_64__)
template <class T>
__attribute__((target("avx2,fma"), flatten)) T fma_avx2(long n) { return fma_chains<T, 32>(n); }
template <class T>
__attribute__((target("avx512f,avx512vl,avx2,fma"), flatten)) T fma_avx512(long n) { return fma_chains<T, 64>(n); }
#endif

/// Flops of one fma_chains() iteration per thread, for vectors of `bytes`.
template <class T>
double fma_flops(long iterations, int bytes) {
  return 2.0 * 12 * iterations * (bytes / static_cast<double>(sizeof(T)));
}

const char* kKernelNames[] = {"reference", "generic", "avx2", "avx512"};
fem::MatrixFreeKernel kernel_of(int k) { return static_cast<fem::MatrixFreeKernel>(k + 1); }

/// Arguments: instruction set (1 generic/SSE2, 2 AVX2 + FMA, 3 AVX-512), precision (8 double, 4
/// float), threads.
void BM_FmaPeak(benchmark::State& state) {
  const int isa = static_cast<int>(state.range(0)), bytes_of_t = static_cast<int>(state.range(1));
  const int threads = static_cast<int>(state.range(2));
  if (!fem::matrix_free_kernel_available(kernel_of(isa))) {
    state.SkipWithError("this CPU lacks the instruction set");
    return;
  }
  const long iterations = 1 << 22;
  const int bytes = isa == 1 ? 16 : isa == 2 ? 32 : 64;
  double sink = 0;
  for (auto _ : state) {
#pragma omp parallel num_threads(threads) reduction(+ : sink)
    {
      if (bytes_of_t == 8) {
#if defined(__x86_64__)
        sink += isa == 3 ? fma_avx512<double>(iterations) : isa == 2 ? fma_avx2<double>(iterations) : fma_generic<double>(iterations);
#else
        sink += fma_generic<double>(iterations);
#endif
      } else {
#if defined(__x86_64__)
        sink += isa == 3 ? fma_avx512<float>(iterations) : isa == 2 ? fma_avx2<float>(iterations) : fma_generic<float>(iterations);
#else
        sink += fma_generic<float>(iterations);
#endif
      }
    }
  }
  benchmark::DoNotOptimize(sink);
  state.counters["flops"] = threads * (bytes_of_t == 8 ? fma_flops<double>(iterations, bytes) : fma_flops<float>(iterations, bytes));
}

/// The triad at a given number of threads.
void BM_TriadThreads(benchmark::State& state) {
  const int keep = omp_get_max_threads();
  omp_set_num_threads(static_cast<int>(state.range(0)));
  BM_Triad(state);
  omp_set_num_threads(keep);
}

/// Arguments: degree, kernel (0 reference, 1 generic, 2 avx2, 3 avx512), precision (8 double, 4
/// float), threads, dynamic (0: y = K x; 1: y = M x + Δt² K_R x).
void BM_MatrixFree(benchmark::State& state) {
  System& s = system_of(static_cast<int>(state.range(0)));
  const fem::MatrixFreeKernel kernel = static_cast<fem::MatrixFreeKernel>(state.range(1) + 1);
  const bool single = state.range(2) == 4;
  const int threads = static_cast<int>(state.range(3));
  const bool dynamic = state.range(4) == 1;
  if (!fem::matrix_free_kernel_available(kernel) || (single && kernel == fem::MatrixFreeKernel::reference)) {
    state.SkipWithError("kernel not available here");
    return;
  }
  const int keep = omp_get_max_threads();
  omp_set_num_threads(threads);
  s.op->set_kernel(kernel);
  s.op->update(dynamic ? &s.R : nullptr);
  s.op->set_weights(dynamic ? 1.0 : 0.0, dynamic ? 1e-4 : 1.0);
  Eigen::VectorXf xf = s.x.cast<float>(), yf(s.x.size());
  for (auto _ : state) {
    if (single) {
      s.op->apply_single(xf, yf);
      benchmark::DoNotOptimize(yf.data());
    } else {
      s.op->apply(s.x, s.y);
      benchmark::DoNotOptimize(s.y.data());
    }
  }
  const double scale = single ? 0.5 : 1.0;  // the float kernel moves half the bytes (indices aside)
  const double index_bytes = 4.0 * s.op->model().space().nodes_per_element() * s.mesh.num_tets();
  report(state, s, index_bytes + scale * (s.op->bytes_per_apply() - index_bytes), s.op->flops_per_apply());
  s.op->update(nullptr);
  s.op->set_weights(0.0, 1.0);
  s.op->set_kernel(fem::MatrixFreeKernel::automatic);
  omp_set_num_threads(keep);
}

void BM_MatrixFreeUpdate(benchmark::State& state) {
  System& s = system_of(static_cast<int>(state.range(0)));
  for (auto _ : state) s.op->update(&s.R);
  s.op->update(nullptr);
  state.counters["unknowns"] = static_cast<double>(s.x.size());
}

/// A time step's elastic force and energy (element_force with the step's rotations) with one
/// element kernel: 0 reference (the scalar element loop), -1 automatic (the batched kernels of the
/// product on this CPU).
void BM_ElementForce(benchmark::State& state) {
  System& s = system_of(static_cast<int>(state.range(0)));
  const fem::MatrixFreeKernel kernel = static_cast<fem::MatrixFreeKernel>(state.range(1) + 1);
  if (!fem::matrix_free_kernel_available(kernel)) {
    state.SkipWithError("kernel not available here");
    return;
  }
  s.op->set_kernel(kernel);
  s.op->update(&s.R);
  s.op->set_weights(1.0, 1e-4);
  Vector u(s.model->num_dofs()), f;
  for (Eigen::Index i = 0; i < u.size(); ++i) u[i] = 1e-3 * std::sin(0.1 * static_cast<double>(i));
  double energy = 0.0;
  for (auto _ : state) {
    s.op->element_force(u, &s.R, f, &energy);
    benchmark::DoNotOptimize(f.data());
  }
  s.op->update(nullptr);
  s.op->set_weights(0.0, 1.0);
  s.op->set_kernel(fem::MatrixFreeKernel::automatic);
  state.counters["elements"] = static_cast<double>(s.mesh.num_tets());
}

void BM_DiagonalBlocks(benchmark::State& state) {
  System& s = system_of(static_cast<int>(state.range(0)));
  std::vector<double> blocks;
  for (auto _ : state) {
    s.op->diagonal_blocks(blocks);
    benchmark::DoNotOptimize(blocks.data());
  }
  state.counters["unknowns"] = static_cast<double>(s.x.size());
}

/// A level's assembly into its existing matrix (values only: a time step's, or the set-up's after
/// the pattern), p = 1 the linear level every multigrid solver assembles.
void BM_Assemble(benchmark::State& state) {
  System& s = system_of(static_cast<int>(state.range(0)));
  for (auto _ : state) s.model->assemble(nullptr, Vector(), s.K, nullptr);
  state.counters["elements"] = static_cast<double>(s.mesh.num_tets());
  state.counters["unknowns"] = static_cast<double>(s.x.size());
}

/// A level's matrix from nothing: the assembler's pattern, slots and colouring, the zeroed values
/// and the assembly (the set-up's first assembly).
void BM_AssembleFirst(benchmark::State& state) {
  System& s = system_of(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    fem::ElasticityModel model(s.mesh, static_cast<int>(state.range(0)), fem::Material{1e6, 0.3, 1000.0});
    model.fix_where([](const fem::Vec3& X) { return X.z() < 1e-12; });
    Bcsr K = model.assembler().make_matrix();
    model.assemble(nullptr, Vector(), K, nullptr);
    benchmark::DoNotOptimize(K.values().data());
  }
  state.counters["elements"] = static_cast<double>(s.mesh.num_tets());
}

class SummaryReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& r : runs) {
      if (!summary_run(r)) continue;
      const double seconds = r.real_accumulated_time / static_cast<double>(r.iterations);
      const std::string name = r.run_name.function_name;
      const std::string args = r.run_name.args;
      const auto bytes = r.counters.find("bytes");
      if (name == "BM_Triad") triad_ = std::max(triad_, bytes->second.value / seconds / 1e9);
      else if (name == "BM_ReadSum") read_ = std::max(read_, bytes->second.value / seconds / 1e9);
      else if (name == "BM_TriadThreads") triad_at_[args] = bytes->second.value / seconds / 1e9;
      else if (name == "BM_FmaPeak") {
        // args: isa/precision/threads; the peak of a precision and thread count is the best ISA's.
        const auto cut = args.find('/');
        const std::string key = args.substr(cut + 1);
        const double rate = r.counters.at("flops").value / seconds / 1e9;
        peak_isa_[args] = rate;
        peak_[key] = std::max(peak_[key], rate);
      } else if (bytes != r.counters.end()) {
        const std::string key = name + "/" + args;
        times_[key] = seconds;
        bytes_[key] = bytes->second.value;
        flops_[key] = r.counters.at("flops").value;
        unknowns_[args.substr(0, args.find('/'))] = r.counters.at("unknowns").value;
        order_.push_back(key);
      }
    }
  }
  void Finalize() override {
    ConsoleReporter::Finalize();
    std::printf("\nRoofline of this machine, measured in this run\n");
    for (const auto& [args, rate] : peak_isa_) {
      int isa = 0, prec = 0, threads = 0;
      std::sscanf(args.c_str(), "%d/%d/%d", &isa, &prec, &threads);
      std::printf("  FMA peak %-8s %-6s %d thread%s: %7.1f GFLOP/s\n", kKernelNames[isa], prec == 8 ? "double" : "float",
                  threads, threads > 1 ? "s" : " ", rate);
    }
    for (const auto& [threads, bw] : triad_at_) std::printf("  triad %s thread(s): %.1f GB/s\n", threads.c_str(), bw);
    std::printf("  triad %d threads %.2f GB/s, read-only %.2f GB/s\n\n", omp_get_max_threads(), triad_, read_);
    std::printf("%-6s %-9s %-26s %9s %9s %9s %8s %10s %10s\n", "degree", "unknowns", "kernel", "time ms", "vs BCSR",
                "GFLOP/s", "of peak", "B/unknown", "x bw bound");
    for (const std::string& key : order_) {
      const std::string name = key.substr(0, key.find('/'));
      const std::string args = key.substr(key.find('/') + 1);
      const std::string degree = args.substr(0, args.find('/'));
      const double t = times_[key], n = unknowns_[degree];
      const double bcsr = times_.count("BM_Bcsr/" + degree) ? times_["BM_Bcsr/" + degree] : 0.0;
      std::string label = name == "BM_Bcsr" ? "bcsr" : name;
      std::string peak_key;
      if (name == "BM_MatrixFree") {
        int p = 0, k = 0, prec = 0, threads = 0, dyn = 0;
        std::sscanf(args.c_str(), "%d/%d/%d/%d/%d", &p, &k, &prec, &threads, &dyn);
        label = std::string(dyn ? "M+dt2K " : "K ") + kKernelNames[k] + (prec == 8 ? " f64 " : " f32 ") +
                std::to_string(threads) + "t";
        peak_key = std::to_string(prec) + "/" + std::to_string(threads);
      } else {
        peak_key = "8/" + std::to_string(omp_get_max_threads());
      }
      const double rate = flops_[key] / t / 1e9;
      const double peak = peak_.count(peak_key) ? peak_[peak_key] : 0.0;
      const double bound = read_ > 0 ? bytes_[key] / (read_ * 1e9) : 0.0;
      std::printf("%-6s %-9.0f %-26s %9.3f %8.2fx %9.2f %7.0f%% %10.1f %9.2fx\n", degree.c_str(), n, label.c_str(), 1e3 * t,
                  bcsr > 0 ? bcsr / t : 0.0, rate, peak > 0 ? 100.0 * rate / peak : 0.0, bytes_[key] / n,
                  bound > 0 ? t / bound : 0.0);
    }
    std::printf("(of peak: the flop rate against the best FMA peak of the same precision and thread count; vs BCSR:\n"
                " BCSR SpMV time (double, all threads) / kernel time; x bw bound: time over the least bytes at the\n"
                " read-only bandwidth; M+dt2K applies M + dt^2 K_R, whose BCSR matrix costs as K's)\n");
  }

 private:
  double triad_ = 0, read_ = 0;
  std::map<std::string, double> times_, bytes_, flops_, unknowns_, triad_at_, peak_, peak_isa_;
  std::vector<std::string> order_;
};

}  // namespace

int main(int argc, char** argv) {
  size_t triad_mib = 384;
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    if (!integer_flag(a, "pmg_boxes", g_boxes) && !integer_flag(a, "pmg_triad_mib", triad_mib))
      rest.push_back(argv[i]);
  }
  start_benchmarks(rest, triad_mib);
  const int max_threads = omp_get_max_threads();
  std::vector<int> thread_counts = {1};
  if (max_threads > 1) thread_counts.push_back(max_threads);
  for (int threads : thread_counts) {
    benchmark::RegisterBenchmark("BM_TriadThreads", BM_TriadThreads)->Arg(threads)->UseRealTime()->Unit(benchmark::kMillisecond);
    for (int isa = 1; isa <= 3; ++isa)
      for (int prec : {8, 4})
        benchmark::RegisterBenchmark("BM_FmaPeak", BM_FmaPeak)->Args({isa, prec, threads})->UseRealTime()->Unit(benchmark::kMillisecond);
  }
  for (int p : {2, 3}) {
    benchmark::RegisterBenchmark("BM_Bcsr", BM_Bcsr)->Arg(p)->UseRealTime()->Unit(benchmark::kMillisecond);
    for (int threads : thread_counts)
      for (int dynamic : {0, 1})
        for (int kernel = 0; kernel <= 3; ++kernel)
          for (int prec : {8, 4}) {
            if (prec == 4 && kernel == 0) continue;  // no scalar float kernel
            if (dynamic && (kernel == 1 || threads != max_threads)) continue;  // M + dt^2 K: the fast kernels, all threads
            benchmark::RegisterBenchmark("BM_MatrixFree", BM_MatrixFree)->Args({p, kernel, prec, threads, dynamic})->UseRealTime()->Unit(benchmark::kMillisecond);
          }
    benchmark::RegisterBenchmark("BM_MatrixFreeUpdate", BM_MatrixFreeUpdate)->Arg(p)->UseRealTime()->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark("BM_DiagonalBlocks", BM_DiagonalBlocks)->Arg(p)->UseRealTime()->Unit(benchmark::kMillisecond);
    for (int kernel : {0, -1})
      benchmark::RegisterBenchmark("BM_ElementForce", BM_ElementForce)->Args({p, kernel})->UseRealTime()->Unit(benchmark::kMillisecond);
  }
  for (int p : {1, 2}) {
    benchmark::RegisterBenchmark("BM_Assemble", BM_Assemble)->Arg(p)->UseRealTime()->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark("BM_AssembleFirst", BM_AssembleFirst)->Arg(p)->UseRealTime()->Unit(benchmark::kMillisecond);
  }
  SummaryReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  return 0;
}
