// The GPU solvers as factory methods: registration, keys and errors checked everywhere; set-up, a
// solve checked by its true residual and update() where a device is present, a clear refusal where
// it is not. (Agreement with the CPU methods iteration by iteration is test_gpu's.)
#include <catch2/catch.hpp>

#include "hierarchy.hpp"
#include "pmg/gpu/device.hpp"
#include "pmg/gpu/factory.hpp"

#include <algorithm>
#include <string>

using namespace pmg;

namespace {

bool registered(const std::string& name) {
  const auto all = registered_solvers();
  return std::any_of(all.begin(), all.end(), [&](const SolverInfo& i) { return i.name == name; });
}

}  // namespace

TEST_CASE("register_solvers adds gpu-mcg, gpu-pcg and gpu-pmg with their keys, once", "[gpu][factory]") {
  gpu::register_solvers();
  gpu::register_solvers();  // again: replaced, not duplicated
  const auto all = registered_solvers();
  for (const char* m : {"gpu-mcg", "gpu-pcg", "gpu-pmg"}) {
    CHECK(registered(m));
    CHECK(std::count_if(all.begin(), all.end(), [&](const SolverInfo& i) { return i.name == m; }) == 1);
    CHECK(method_needs_blocks(m));
    CHECK(method_accepts_key(m, "tol"));
  }
  CHECK(method_accepts_key("gpu-mcg", "check_every"));
  CHECK(method_accepts_key("gpu-pmg", "degree"));
  CHECK(method_uses_levels("gpu-pmg"));
  CHECK_FALSE(method_uses_levels("gpu-mcg"));
}

TEST_CASE("GPU methods refuse what they cannot use, naming the key", "[gpu][factory]") {
  gpu::register_solvers();
  REQUIRE_THROWS_WITH(make_solver(Config::from_pairs({"method=gpu-pmg"}, "test")),
                      Catch::Contains("gpu-pmg needs a level hierarchy"));
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
  for (const char* m : {"gpu-mcg", "gpu-pcg", "gpu-pmg"}) {
    INFO(m);
    auto s = make_solver(Config::from_pairs({std::string("method=") + m, "tol=1e-8"}, "test"), ctx);
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
