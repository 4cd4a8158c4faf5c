// pmg::gpu on a device, each kernel against its host oracle. Without a CUDA device (or driver)
// the program prints why and exits 77, which CTest reports as skipped.
#define CATCH_CONFIG_RUNNER
#include <catch2/catch.hpp>

#include "../sparse/fixture.hpp"
#include "hierarchy.hpp"
#include "pmg/fem/generators.hpp"
#include "pmg/gpu/matrix_free.hpp"
#include "pmg/gpu/solvers.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/multigrid/transfer.hpp"

#include <cmath>
#include <cstdio>

using namespace pmg;

int main(int argc, char** argv) {
  if (gpu::device_count() == 0) {
    std::puts("no CUDA device or driver: the [gpu] tests are skipped");
    return 77;
  }
  const gpu::DeviceInfo info = gpu::device_info();
  std::printf("device: %s (sm_%d%d, %d SMs)\n", info.name.c_str(), info.major, info.minor,
              info.multiprocessors);
  return Catch::Session().run(argc, argv);
}

namespace {

KrylovParams tolerance(double tol, int check_every = 1) {
  KrylovParams p;
  p.rel_tol = tol;
  p.max_iterations = 2000;
  p.check_every = check_every;
  return p;
}

}  // namespace

TEST_CASE("device arrays round-trip, resize in place and move", "[gpu]") {
  const Vector v = test::random_vector(1000, 1);
  gpu::DeviceVector d(v);
  CHECK(d.to_vector() == v);
  const double* p = d.data();
  d.resize(500);  // smaller: same allocation
  CHECK(d.data() == p);
  gpu::DeviceVector e(std::move(d));
  CHECK(e.data() == p);
  CHECK(d.empty());
  gpu::DeviceVector f;
  f.assign(e);
  CHECK(f.to_vector() == v.head(500));
}

TEST_CASE("every device SpMV matches the host BCSR SpMV", "[gpu]") {
  std::vector<Bcsr> mats;
  mats.push_back(Bcsr::from_block_triplets(23, 23, test::irregular_blocks()));
  for (int p = 1; p <= 3; ++p) mats.push_back(test::GpuCantilever(p, 2).A());
  for (const Bcsr& A : mats) {
    const Vector x = test::random_vector(A.cols(), 2);
    Vector y_ref;
    A.apply(x, y_ref);
    const gpu::DeviceVector dx(x);
    gpu::DeviceVector dy;
    const BinBcsr bin(A);
    gpu::DeviceBinBcsr(bin).multiply(dx, dy);
    CHECK(test::rel_diff(dy.to_vector(), y_ref) < 1e-13);
    for (int lanes : {1, 4, 32}) {  // every lane count the shuffle tree takes, unsorted as well
      gpu::DeviceBinBcsr(BinBcsr(A, {lanes, lanes == 4 ? 1 : 0})).multiply(dx, dy);
      CHECK(test::rel_diff(dy.to_vector(), y_ref) < 1e-13);
    }
    gpu::DeviceBcsr(A).multiply(dx, dy);
    CHECK(test::rel_diff(dy.to_vector(), y_ref) < 1e-13);
    gpu::CusparseBsr(A).multiply(dx, dy);
    CHECK(test::rel_diff(dy.to_vector(), y_ref) < 1e-13);
    gpu::CusparseCsr(A.to_csr()).multiply(dx, dy);
    CHECK(test::rel_diff(dy.to_vector(), y_ref) < 1e-13);
    // r = b - A x in one pass
    const Vector b = test::random_vector(A.rows(), 3);
    gpu::DeviceBinBcsr(bin).residual(gpu::DeviceVector(b), dx, dy);
    CHECK(test::rel_diff(dy.to_vector(), Vector(b - y_ref)) < 1e-13);
  }
}

TEST_CASE("new values re-upload without re-slicing and give the new product", "[gpu]") {
  Bcsr A = test::GpuCantilever(2, 1).A();
  BinBcsr bin(A);
  gpu::DeviceBinBcsr dA(bin);
  for (double& v : A.values()) v *= 2.5;
  bin.update_values(A);
  dA.update_values(bin);
  const Vector x = test::random_vector(A.cols(), 4);
  Vector y_ref;
  A.apply(x, y_ref);
  gpu::DeviceVector dy;
  dA.multiply(gpu::DeviceVector(x), dy);
  CHECK(test::rel_diff(dy.to_vector(), y_ref) < 1e-13);
  const Bcsr other = test::GpuCantilever(1, 1).A();
  CHECK_THROWS_AS(dA.update_values(BinBcsr(other)), InputError);
}

TEST_CASE("GPU MCG agrees with the CPU MCG, reading the residual every 1 or 10 iterations", "[gpu]") {
  test::GpuCantilever c(3, 2);
  const BlockJacobiPreconditioner M(c.A());
  Vector x_cpu;
  const SolveResult cpu = mcg(c.A(), M, c.b, x_cpu, tolerance(1e-8));
  const BinBcsr bin(c.A());
  const gpu::DeviceBinBcsr dA(bin);
  const gpu::DeviceBlockJacobi dM(M);
  const gpu::Mcg solver(dA, dM);
  for (int k : {1, 10}) {
    gpu::DeviceVector x;
    const SolveResult r = solver.solve(gpu::DeviceVector(c.b), x, tolerance(1e-8, k));
    INFO("check_every " << k << ": GPU " << r.iterations << " iterations, CPU " << cpu.iterations);
    CHECK(r.status == SolveStatus::converged);
    // Round-off may move the crossing of the tolerance by one iteration; the host reads the
    // residual every k iterations, so the GPU may run up to k - 1 past it.
    CHECK(r.iterations >= cpu.iterations - 1);
    CHECK(r.iterations <= cpu.iterations + k);
    CHECK(test::rel_diff(x.to_vector(), x_cpu) < 1e-6);
    Vector res;
    c.A().residual(c.b, x.to_vector(), res);
    CHECK(res.norm() <= 2e-8 * c.b.norm());
  }
}

TEST_CASE("GPU MCG reports breakdown on an indefinite matrix and NaN in the right-hand side", "[gpu][errors]") {
  const Bcsr A0 = test::GpuCantilever(1, 1).A();
  Bcsr A = A0;
  const BlockJacobiPreconditioner M(A0);
  for (double& v : A.values()) v = -v;  // negative definite with the positive D⁻¹ of the original
  BinBcsr bin(A);
  gpu::DeviceBinBcsr dA(bin);
  const gpu::DeviceBlockJacobi dM(M);
  KrylovParams p = tolerance(1e-8, 10);
  p.throw_on_failure = false;
  const Vector b = Vector::Ones(A.rows());
  Vector x_cpu;
  const SolveResult cpu = mcg(A, M, b, x_cpu, p);
  REQUIRE(cpu.status == SolveStatus::breakdown);
  const gpu::Mcg solver(dA, dM);
  gpu::DeviceVector x;
  const SolveResult r = solver.solve(gpu::DeviceVector(b), x, p);
  CHECK(r.status == SolveStatus::breakdown);
  CHECK(r.iterations == cpu.iterations);
  // The iterations queued behind the breakdown in the same chunk of 10 did not touch x.
  CHECK(x.to_vector() == x_cpu);
  // The same solver on the definite matrix (values re-uploaded): the restart clears the halt.
  bin.update_values(A0);
  dA.update_values(bin);
  gpu::DeviceVector x1;
  CHECK(solver.solve(gpu::DeviceVector(b), x1, p).status == SolveStatus::converged);

  Vector bad = b;
  bad[3] = std::nan("");
  gpu::DeviceVector x2;
  CHECK(solver.solve(gpu::DeviceVector(bad), x2, p).status == SolveStatus::non_finite);
}

TEST_CASE("the cuBLAS/cuSPARSE PCG agrees with the CPU PCG", "[gpu]") {
  test::GpuCantilever c(2, 2);
  const BlockJacobiPreconditioner M(c.A());
  Vector x_cpu;
  const SolveResult cpu = pcg(c.A(), &M, c.b, x_cpu, tolerance(1e-8));
  gpu::DeviceVector x;
  const SolveResult r = gpu::LibraryPcg(c.A(), M).solve(gpu::DeviceVector(c.b), x, tolerance(1e-8));
  CHECK(r.status == SolveStatus::converged);
  CHECK(std::abs(r.iterations - cpu.iterations) <= 1);
  CHECK(test::rel_diff(x.to_vector(), x_cpu) < 1e-6);
}

TEST_CASE("the GPU V-cycle equals the CPU Chebyshev V-cycle, and GPU PMG converges like CPU PMG", "[gpu]") {
  test::GpuCantilever c(3, 2);
  const gpu::VCycle C(c.matrices(), c.transfers());
  const Vector r = test::random_vector(c.A().rows(), 9);
  Vector z_ref;
  c.cycle().apply(r, z_ref);
  gpu::DeviceVector z;
  C.apply(gpu::DeviceVector(r), z);
  CHECK(test::rel_diff(z.to_vector(), z_ref) < 1e-10);

  Vector x_cpu = Vector::Zero(c.b.size());
  c.cycle().params().iteration = tolerance(1e-8);
  const SolveResult cpu = c.cycle().solve(c.b, x_cpu);
  gpu::DeviceVector x;
  const SolveResult g = gpu::multigrid_solve(C, gpu::DeviceVector(c.b), x, tolerance(1e-8));
  CHECK(g.status == SolveStatus::converged);
  CHECK(std::abs(g.iterations - cpu.iterations) <= 1);
  CHECK(test::rel_diff(x.to_vector(), x_cpu) < 1e-6);
}

TEST_CASE("the GPU V-cycle with fourth-kind smoothing equals the CPU cycle, assembled and matrix-free", "[gpu]") {
  test::GpuCantilever c(3, 2);
  SolverContext ctx;
  ctx.levels = &c.h;
  // The same hierarchy again, prepared matrix-free above its lowest level.
  fem::DegreeHierarchy h(c.mesh, 3, fem::Material{500e3, 0.3, 1000.0}, [](const fem::Vec3& X) { return X.x() < 1e-12; });
  h.assemble_level(0, nullptr);
  for (int l = 1; l < h.num_levels(); ++l) h.update_matrix_free(l, nullptr);
  std::vector<mg::BlockTransfer> transfers;
  for (int l = 1; l < h.num_levels(); ++l) transfers.emplace_back(h.prolongation(l));
  std::vector<const mg::BlockTransfer*> tp;
  for (const auto& t : transfers) tp.push_back(&t);
  for (const char* kind : {"fourth", "opt-fourth"}) {
    INFO(kind);
    auto cpu = make_solver(Config::from_pairs({"method=pmg", "smoother=chebyshev", std::string("smoother.kind=") + kind,
                                               "smoother.degree=3", "operator=assembled"}, "test"), ctx);
    cpu->setup(c.A());
    mg::ChebyshevParams p;
    p.kind = std::string(kind) == "fourth" ? mg::ChebyshevKind::fourth : mg::ChebyshevKind::optimal_fourth;
    p.degree = 3;
    const gpu::VCycle C(c.matrices(), c.transfers(), p);
    const Vector r = test::random_vector(c.A().rows(), 9);
    Vector z_ref;
    cpu->apply(r, z_ref);
    gpu::DeviceVector z;
    C.apply(gpu::DeviceVector(r), z);
    CHECK(test::rel_diff(z.to_vector(), z_ref) < 1e-10);
    // Matrix-free levels: the same cycle (the operators equal the matrices to round-off).
    const gpu::VCycle M({&h.matrix(0), nullptr, nullptr}, tp, p,
                        {nullptr, h.matrix_free_operator(1), h.matrix_free_operator(2)});
    CHECK(M.matrix_free());
    gpu::DeviceVector zm;
    M.apply(gpu::DeviceVector(r), zm);
    CHECK(test::rel_diff(zm.to_vector(), z_ref) < 1e-10);
    // MGPCG on either converges like the CPU's.
    gpu::DeviceVector xa, xm;
    const SolveResult a = gpu::mgpcg_solve(C, gpu::DeviceVector(c.b), xa, tolerance(1e-8));
    const SolveResult m = gpu::mgpcg_solve(M, gpu::DeviceVector(c.b), xm, tolerance(1e-8));
    CHECK(a.status == SolveStatus::converged);
    CHECK(m.status == SolveStatus::converged);
    CHECK(std::abs(a.iterations - m.iterations) <= 1);
    CHECK(test::rel_diff(xm.to_vector(), xa.to_vector()) < 1e-6);
  }
}

TEST_CASE("the device matrix-free operator equals the CPU one, p = 1..3, rotations and weights", "[gpu]") {
  const fem::TetMesh mesh = fem::box_mesh_24(4, 2, 2, 1.0, 0.5, 0.5);
  for (int p = 1; p <= 3; ++p) {
    INFO("degree " << p);
    fem::ElasticityModel model(mesh, p, fem::Material{3.0e5, 0.35, 1.2e3});
    model.fix_where([](const fem::Vec3& X) { return X[0] < 1e-12; });
    fem::ElasticityOperator op(model);
    gpu::DeviceElasticityOperator dop(op);
    const Vector x = test::random_vector(op.rows(), 4);
    const gpu::DeviceVector dx(x);
    gpu::DeviceVector dy;
    Vector ref;
    op.apply(x, ref);
    dop.multiply(dx, dy);
    CHECK(test::rel_diff(dy.to_vector(), ref) < 1e-12);
    // Rotations applied on the device, weights refreshed from the host.
    Vector u(model.num_dofs());
    for (index_t i = 0; i < u.size(); ++i) u[i] = 0.05 * std::sin(0.3 * i);
    const fem::Rotations R = model.rotations(u);
    op.set_weights(1.3, 0.02);
    dop.refresh(op);
    op.update(&R);
    dop.update(&R);
    op.apply(x, ref);
    dop.multiply(dx, dy);
    CHECK(test::rel_diff(dy.to_vector(), ref) < 1e-12);
    std::vector<double> dref;
    op.diagonal_blocks(dref);
    gpu::DeviceArray<double> dd;
    dop.diagonal_blocks(dd);
    const std::vector<double> d = dd.to_host();
    REQUIRE(d.size() == dref.size());
    double err = 0.0, norm = 0.0;
    for (std::size_t k = 0; k < d.size(); ++k)
      err = std::max(err, std::abs(d[k] - dref[k])), norm = std::max(norm, std::abs(dref[k]));
    CHECK(err <= 1e-12 * norm);
    const fem::Rotations wrong(3);
    CHECK_THROWS_AS(dop.update(&wrong), InputError);
  }
}
