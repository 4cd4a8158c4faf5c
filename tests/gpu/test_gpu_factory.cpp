// The GPU solvers as factory methods: registration, keys and errors checked everywhere; set-up, a
// solve checked by its true residual and update() where a device is present, a clear refusal where
// it is not. (Agreement with the CPU methods iteration by iteration is test_gpu's.)
#include <catch2/catch.hpp>

#include "hierarchy.hpp"
#include "pmg/gpu/device.hpp"
#include "pmg/gpu/factory.hpp"
#include "pmg/gpu/solvers.hpp"

#include <cmath>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <string>

using namespace pmg;

namespace {

bool registered(const std::string& name) {
  const auto all = registered_solvers();
  return std::any_of(all.begin(), all.end(), [&](const SolverInfo& i) { return i.name == name; });
}

}  // namespace

TEST_CASE("register_solvers adds gpu-mcg, gpu-pcg, gpu-pmg and gpu-mgpcg with their keys, once", "[gpu][factory]") {
  gpu::register_solvers();
  gpu::register_solvers();  // again: replaced, not duplicated
  const auto all = registered_solvers();
  for (const char* m : {"gpu-mcg", "gpu-pcg", "gpu-pmg", "gpu-mgpcg"}) {
    CHECK(registered(m));
    CHECK(std::count_if(all.begin(), all.end(), [&](const SolverInfo& i) { return i.name == m; }) == 1);
    CHECK(method_needs_blocks(m));
    CHECK(method_accepts_key(m, "tol"));
  }
  CHECK(method_accepts_key("gpu-mcg", "check_every"));
  CHECK(method_accepts_key("gpu-pmg", "degree"));
  CHECK(method_uses_levels("gpu-pmg"));
  CHECK(method_uses_levels("gpu-mgpcg"));
  for (const char* key : {"degree", "kind", "lower_fraction", "operator"}) CHECK(method_accepts_key("gpu-mgpcg", key));
  CHECK_FALSE(method_uses_levels("gpu-mcg"));
}

TEST_CASE("GPU methods refuse what they cannot use, naming the key", "[gpu][factory]") {
  gpu::register_solvers();
  REQUIRE_THROWS_WITH(make_solver(Config::from_pairs({"method=gpu-pmg"}, "test")),
                      Catch::Contains("gpu-pmg needs a level hierarchy"));
  REQUIRE_THROWS_WITH(make_solver(Config::from_pairs({"method=gpu-mgpcg"}, "test")),
                      Catch::Contains("gpu-mgpcg needs a level hierarchy"));
  const test::GpuCantilever c(2, 1);
  SolverContext ctx;
  ctx.levels = &c.h;
  REQUIRE_THROWS_WITH(make_solver(Config::from_pairs({"method=gpu-mgpcg", "kind=second"}, "test"), ctx),
                      Catch::Contains("kind"));
  REQUIRE_THROWS_WITH(make_solver(Config::from_pairs({"method=gpu-mgpcg", "degree=7"}, "test"), ctx),
                      Catch::Contains("degree"));  // the optimised fourth kind: 1 to 6
  CHECK_NOTHROW(make_solver(Config::from_pairs({"method=gpu-mgpcg", "degree=7", "kind=fourth"}, "test"), ctx));
  REQUIRE_THROWS_WITH(make_solver(Config::from_pairs({"method=gpu-mgpcg", "degree=65", "kind=first"}, "test"), ctx),
                      Catch::Contains("degree"));
  REQUIRE_THROWS_WITH(make_solver(Config::from_pairs({"method=gpu-mgpcg", "operator=csr"}, "test"), ctx),
                      Catch::Contains("operator"));
  REQUIRE_THROWS_WITH(make_solver(Config::from_pairs({"method=gpu-mcg", "smoother=chebyshev"}, "test")),
                      Catch::Contains("smoother"));
  REQUIRE_THROWS_WITH(make_solver(Config::from_pairs({"method=gpu-mcg", "check_every=0"}, "test")),
                      Catch::Contains("check_every"));
}

TEST_CASE("GPU methods reach the tolerance by the true residual and again after update(), or say that there is no device", "[gpu][factory]") {
  gpu::register_solvers();
  const test::GpuCantilever c(3, 1);
  SolverContext ctx;
  ctx.levels = &c.h;
  for (const char* m : {"gpu-mcg", "gpu-pcg", "gpu-pmg", "gpu-mgpcg"}) {
    INFO(m);
    // gpu-mgpcg here on the assembled levels (the cantilever's matrices); matrix-free below.
    std::vector<std::string> pairs{std::string("method=") + m, "tol=1e-8"};
    if (std::string(m) == "gpu-mgpcg") pairs.push_back("operator=assembled");
    auto s = make_solver(Config::from_pairs(pairs, "test"), ctx);
    if (gpu::device_count() == 0) {
      REQUIRE_THROWS_WITH(s->setup(c.A()), Catch::Contains("no CUDA device or driver"));
      continue;
    }
    s->setup(c.A());
    Vector x = Vector::Zero(c.b.size());
    const SolveResult r = s->solve(c.b, x);
    CHECK(r.ok());
    Vector res;
    c.A().apply(x, res);
    CHECK((c.b - res).norm() <= 1e-7 * c.b.norm());
    CHECK(s->describe().find("last solve: upload") != std::string::npos);
    s->update();  // new values, same pattern: the device copies refreshed
    Vector y = Vector::Zero(c.b.size());
    CHECK(s->solve(c.b, y).ok());
    CHECK((x - y).norm() <= 1e-6 * x.norm());
  }
}

TEST_CASE("gpu-mgpcg on matrix-free levels reaches the tolerance like the CPU mgpcg, or says that there is no device", "[gpu][factory]") {
  gpu::register_solvers();
  mg::register_solvers();
  const fem::TetMesh mesh = fem::box_mesh_24(4, 1, 1, 1.0, 0.25, 0.25);
  fem::DegreeHierarchy h(mesh, 3, fem::Material{500e3, 0.3, 1000.0}, [](const fem::Vec3& X) { return X.x() < 1e-12; });
  SolverContext ctx;
  ctx.levels = &h;
  auto gpu_solver = make_solver(Config::from_pairs({"method=gpu-mgpcg", "tol=1e-8"}, "test"), ctx);
  REQUIRE(gpu_solver->needs().matrix_free);
  const LinearOperator& A = h.bind(*gpu_solver).prepare();
  if (gpu::device_count() == 0) {
    REQUIRE_THROWS_WITH(gpu_solver->setup(A), Catch::Contains("no CUDA device or driver"));
    return;
  }
  gpu_solver->setup(A);
  CHECK(gpu_solver->describe().find("matrix-free") != std::string::npos);
  Vector b(A.rows());
  for (index_t i = 0; i < b.size(); ++i) b[i] = std::sin(0.1 * i);
  Vector x = Vector::Zero(b.size());
  const SolveResult r = gpu_solver->solve(b, x);
  CHECK(r.ok());
  Vector res;
  A.residual(b, x, res);
  CHECK(res.norm() <= 1e-7 * b.norm());
  // The CPU mgpcg with the same smoother and levels takes the same number of iterations (±1).
  auto cpu = make_solver(Config::from_pairs({"method=mgpcg", "tol=1e-8", "precision=double"}, "test"), ctx);
  cpu->setup(A);
  Vector y = Vector::Zero(b.size());
  const SolveResult rc = cpu->solve(b, y);
  CHECK(std::abs(r.iterations - rc.iterations) <= 1);
}

TEST_CASE("gpu::VCycle refuses bad levels before it touches a device", "[gpu][factory]") {
  const test::GpuCantilever c(2, 1);
  const auto m = c.matrices();
  const auto t = c.transfers();
  CHECK_THROWS_WITH(gpu::VCycle(m, t, {}, {&c.A(), nullptr}), Catch::Contains("lowest level must be assembled"));
  CHECK_THROWS_WITH(gpu::VCycle(m, t, {}, {nullptr, &c.A()}), Catch::Contains("not a matrix-free elasticity operator"));
  CHECK_THROWS_WITH(gpu::VCycle(m, t, {}, {nullptr}), Catch::Contains("one operator per level"));
  CHECK_THROWS_WITH(gpu::VCycle({m[1], m[0]}, t, {}), Catch::Contains("does not match"));
}

TEST_CASE("cuBLAS and cuSPARSE open on first use, every function pmgkit calls in them resolves", "[gpu][factory]") {
  // No device needed: opening a library and finding its functions is the loader's work.
  REQUIRE_NOTHROW(gpu::load_vendor_libraries());
  std::ifstream maps("/proc/self/maps");
  const std::string all((std::istreambuf_iterator<char>(maps)), std::istreambuf_iterator<char>());
  CHECK(all.find("libcublas") != std::string::npos);
  CHECK(all.find("libcusparse") != std::string::npos);
  REQUIRE_NOTHROW(gpu::load_vendor_libraries());  // again: the handles are kept
}
