// The set-up a FEM code pays to hand its levels to pmgkit (mg::UserLevels + the MGPCG set-up),
// with the level matrices as the code produced them: rows sorted (canonical CSR), each row's
// diagonal first and the rest unsorted (deal.II's SparseMatrix), or unsorted with every entry
// split into two duplicates (unassembled element sums). The unsorted input is read in place, with
// no sorting copy; the target is a set-up within 10% of the sorted input's.
//
//   bench_user_levels [--pmg_boxes=12] [--pmg_degree=2] [google benchmark flags]
//
// The system: a unit cube of n^3 boxes of 24 tetrahedra, clamped at z = 0 (quadratic n = 12: 183k
// unknowns), its degree hierarchy's matrices and prolongations as scalar CSR arrays.
#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/multigrid/user_levels.hpp"

#include "../bandwidth.hpp"
#include "cube.hpp"

#include <benchmark/benchmark.h>

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

namespace {

using namespace pmg;
using namespace pmg::bench;

int g_boxes = 12, g_degree = 2;

/// A level matrix's arrays in one of the orders (0 sorted, 1 diagonal first, 2 with duplicates).
struct Arrays {
  std::vector<std::int64_t> row_ptr{0};
  std::vector<std::int32_t> cols;
  std::vector<double> values;
  CsrView view;
  Arrays(const Csr& A, int order) {
    const auto& p = A.pattern();
    for (index_t i = 0; i < A.rows(); ++i) {
      const offset_t b = p.row_ptr[i], e = p.row_ptr[i + 1];
      auto put = [&](offset_t k) {
        if (order == 2 && p.col_idx[k] != i) {
          for (int half = 0; half < 2; ++half) cols.push_back(p.col_idx[k]), values.push_back(0.5 * A.values()[k]);
        } else {
          cols.push_back(p.col_idx[k]), values.push_back(A.values()[k]);
        }
      };
      if (order == 0) {
        for (offset_t k = b; k < e; ++k) put(k);
      } else {  // the diagonal first, then the others from the last to the first
        for (offset_t k = b; k < e; ++k)
          if (p.col_idx[k] == i) put(k);
        for (offset_t k = e - 1; k >= b; --k)
          if (p.col_idx[k] != i) put(k);
      }
      row_ptr.push_back(static_cast<std::int64_t>(cols.size()));
    }
    view.rows = A.rows(), view.cols = A.cols(), view.nnz = static_cast<offset_t>(cols.size());
    view.row_ptr = row_ptr.data(), view.row_ptr_bytes = 8;
    view.col_idx = cols.data(), view.col_idx_bytes = 4;
    view.values = values.data();
  }
};

struct Scene {
  std::unique_ptr<ClampedCube> cube;
  fem::DegreeHierarchy* h = nullptr;  // the cube's
  std::vector<Csr> P;
  std::vector<std::vector<Arrays>> levels;  // [order][level]
};

Scene& scene() {
  static std::unique_ptr<Scene> s;
  if (s) return *s;
  s = std::make_unique<Scene>();
  s->cube = std::make_unique<ClampedCube>(g_boxes, g_degree);
  s->h = s->cube->h.get();
  for (int l = 1; l < s->h->num_levels(); ++l) s->P.push_back(s->h->prolongation(l));
  std::vector<Csr> A;
  for (int l = 0; l < s->h->num_levels(); ++l) A.push_back(s->h->matrix(l).to_csr());
  s->levels.resize(3);
  for (int order = 0; order < 3; ++order)
    for (const Csr& m : A) s->levels[order].emplace_back(m, order);
  mg::register_solvers();
  return *s;
}

void BM_UserLevelsSetup(benchmark::State& state) {
  Scene& s = scene();
  const int order = static_cast<int>(state.range(0));
  std::vector<CsrView> mats, ps;
  for (const Arrays& a : s.levels[order]) mats.push_back(a.view);
  for (const Csr& p : s.P) ps.push_back(view_of(p));
  for (auto _ : state) {
    mg::UserLevels levels(mats, ps, {});
    auto solver = make_solver(Config::from_pairs({"method=mgpcg", "smoother=chebyshev"}, "bench"), {&levels});
    solver->setup(levels.matrix(levels.num_levels() - 1));
    benchmark::DoNotOptimize(solver.get());
  }
  static const char* names[] = {"sorted rows", "diagonal first, unsorted", "unsorted with duplicates"};
  state.SetLabel(names[order]);
  state.counters["unknowns"] = static_cast<double>(s.h->finest().num_free_dofs());
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    if (!integer_flag(a, "pmg_boxes", g_boxes) && !integer_flag(a, "pmg_degree", g_degree, 2)) rest.push_back(argv[i]);
  }
  if (g_degree > 3) {
    std::fprintf(stderr, "bench_user_levels: --pmg_degree must be 2 or 3\n");
    return 2;
  }
  initialize_benchmarks(rest);  // 5 repetitions, medians, unless told otherwise
  benchmark::RegisterBenchmark("BM_UserLevelsSetup", BM_UserLevelsSetup)
      ->Arg(0)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
