// The matrix-free BB elasticity operator (pmg/fem/matrix_free.hpp) against BCSR SpMV of the same
// assembled matrix, in one run, with the memory bandwidth measured beside them.
//
//   bench_operator [--pmg_boxes=8] [--pmg_triad_mib=384] [google benchmark flags]
//
// The system: a unit cube of n^3 boxes of 24 tetrahedra, clamped at z = 0, degrees 2 and 3 (cubic
// n = 8: 164k unknowns). Per degree: BM_Bcsr (y = A x, A = K assembled), BM_MatrixFree (y = K x),
// BM_MatrixFreeDynamic (y = M x + Δt² K x, the implicit-Euler matrix, against BM_BcsrDynamic: the
// same BCSR kernel, the same bytes) and BM_MatrixFreeUpdate (a corotational step's update(R)).
// Bytes per unknown are each kernel's least traffic:
//   BCSR          76 B per 3x3 block (values + column index), 8 B per block row (row pointer),
//                 24 B x read and 24 B y written per block row
//   matrix-free   128 B element data + 4 B per element node (indices), x read once, y zeroed and
//                 accumulated (read and written once more)
// The summary prints, per degree, both times, the speed-up, bytes per unknown, the flop rate of
// the matrix-free kernel and each kernel's time as a multiple of its bandwidth bound.
#include "pmg/fem/generators.hpp"
#include "pmg/fem/matrix_free.hpp"

#include "../bandwidth.hpp"

#include <benchmark/benchmark.h>
#include <omp.h>

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

void BM_MatrixFree(benchmark::State& state) {
  System& s = system_of(static_cast<int>(state.range(0)));
  s.op->update(nullptr);
  s.op->set_weights(0.0, 1.0);
  for (auto _ : state) {
    s.op->apply(s.x, s.y);
    benchmark::DoNotOptimize(s.y.data());
  }
  report(state, s, s.op->bytes_per_apply(), s.op->flops_per_apply());
}

void BM_MatrixFreeDynamic(benchmark::State& state) {
  System& s = system_of(static_cast<int>(state.range(0)));
  s.op->update(&s.R);
  s.op->set_weights(1.0, 1e-4);
  for (auto _ : state) {
    s.op->apply(s.x, s.y);
    benchmark::DoNotOptimize(s.y.data());
  }
  report(state, s, s.op->bytes_per_apply(), s.op->flops_per_apply());
  s.op->update(nullptr);
  s.op->set_weights(0.0, 1.0);
}

void BM_MatrixFreeUpdate(benchmark::State& state) {
  System& s = system_of(static_cast<int>(state.range(0)));
  for (auto _ : state) s.op->update(&s.R);
  s.op->update(nullptr);
  state.counters["unknowns"] = static_cast<double>(s.x.size());
}

class SummaryReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& r : runs) {
      if (!summary_run(r)) continue;
      const double seconds = r.real_accumulated_time / static_cast<double>(r.iterations);
      const std::string name = r.run_name.function_name;
      const auto bytes = r.counters.find("bytes");
      if (name == "BM_Triad") triad_ = std::max(triad_, bytes->second.value / seconds / 1e9);
      else if (name == "BM_ReadSum") read_ = std::max(read_, bytes->second.value / seconds / 1e9);
      else if (bytes != r.counters.end()) {
        const std::string key = name + "/" + r.run_name.args;
        times_[key] = seconds;
        bytes_[key] = bytes->second.value;
        flops_[key] = r.counters.at("flops").value;
        unknowns_[r.run_name.args] = r.counters.at("unknowns").value;
      }
    }
  }
  void Finalize() override {
    ConsoleReporter::Finalize();
    std::printf("\nSummary (%d threads; triad %.2f GB/s, read-only %.2f GB/s)\n", omp_get_max_threads(),
                triad_, read_);
    std::printf("%-6s %-9s %-22s %9s %9s %11s %9s %11s\n", "degree", "unknowns", "kernel", "time ms",
                "vs BCSR", "B/unknown", "GFLOP/s", "x bw bound");
    for (const auto& [args, n] : unknowns_) {
      const double bcsr = times_["BM_Bcsr/" + args];
      for (const char* k : {"BM_Bcsr", "BM_MatrixFree", "BM_MatrixFreeDynamic"}) {
        const std::string key = std::string(k) + "/" + args;
        if (!times_.count(key)) continue;
        const double t = times_[key];
        const double bound = read_ > 0 ? bytes_[key] / (read_ * 1e9) : 0.0;
        std::printf("%-6s %-9.0f %-22s %9.3f %8.2fx %11.1f %9.2f %10.2fx\n", args.c_str(), n, k, 1e3 * t,
                    t > 0 ? bcsr / t : 0.0, bytes_[key] / n, flops_[key] / t / 1e9, bound > 0 ? t / bound : 0.0);
      }
    }
    std::printf("(vs BCSR: BCSR SpMV time / kernel time, the same matrix; BM_MatrixFreeDynamic applies "
                "M + dt^2 K_R, whose BCSR matrix has the same pattern and cost as K's)\n");
  }

 private:
  double triad_ = 0, read_ = 0;
  std::map<std::string, double> times_, bytes_, flops_, unknowns_;
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
  for (int p : {2, 3}) {
    benchmark::RegisterBenchmark("BM_Bcsr", BM_Bcsr)->Arg(p)->UseRealTime()->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark("BM_MatrixFree", BM_MatrixFree)->Arg(p)->UseRealTime()->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark("BM_MatrixFreeDynamic", BM_MatrixFreeDynamic)->Arg(p)->UseRealTime()->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark("BM_MatrixFreeUpdate", BM_MatrixFreeUpdate)->Arg(p)->UseRealTime()->Unit(benchmark::kMillisecond);
  }
  SummaryReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  return 0;
}
