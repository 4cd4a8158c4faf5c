// The matrix-free BB elasticity operator against the assembled matrices of the same model.
#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/fem/matrix_free.hpp"
#include "pmg/fem/element_kernel.hpp"
#include "pmg/multigrid/chebyshev.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/multigrid/levels.hpp"
#include "pmg/cholmod/cholmod_solver.hpp"
#include "pmg/sparse/solver.hpp"

#include "jittered.hpp"

#include <catch2/catch.hpp>

#include <limits>

#ifdef _OPENMP
#include <omp.h>
#endif

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Eigenvalues>

using namespace pmg;
using namespace pmg::fem;

namespace {

using test::jittered_box;
using test::smooth_vector;


/// m M + s K_R assembled over the free nodes.
Bcsr assembled(const ElasticityModel& model, const Rotations* R, double m, double s) {
  Bcsr A = model.assembler().make_matrix();
  if (m != 0) {
    model.assemble_mass(A);
    for (double& v : A.values()) v *= m;
  }
  ElasticityModel::ElementPass pass;
  pass.R = R;
  pass.stiffness = &A;
  pass.stiffness_weight = s;
  pass.add_to_stiffness = m != 0;
  model.evaluate(pass);
  return A;
}

double rel_diff(const Vector& a, const Vector& b) { return (a - b).norm() / b.norm(); }

}  // namespace

TEST_CASE("matrix-free operator equals the assembled one, p = 1..3, rotations and weights",
          "[fem][matrix_free]") {
  const TetMesh mesh = jittered_box();
  const Material mat{3.0e5, 0.35, 1.2e3};
  for (int p = 1; p <= 3; ++p) {
    ElasticityModel model(mesh, p, mat);
    model.fix_where([](const Vec3& X) { return X[0] < 1e-12; });
    std::vector<double> scale(mesh.num_tets());
    for (size_t e = 0; e < scale.size(); ++e) scale[e] = 1.0 + 0.5 * std::sin(1.7 * e);
    model.set_stiffness_scale(scale);
    const Vector u = 0.1 * smooth_vector(model.num_dofs(), 0.4);
    const Rotations R = model.rotations(u);
    ElasticityOperator op(model);
    const Vector x = smooth_vector(op.rows(), 1.1);
    Vector y, ref(op.rows());

    INFO("degree " << p);
    // Linear elasticity (R = I), stiffness only.
    op.apply(x, y);
    Bcsr K = assembled(model, nullptr, 0.0, 1.0);
    K.multiply(x.data(), ref.data());
    CHECK(rel_diff(y, ref) < 1e-12);

    // Rotated, with the implicit-Euler weights m M + s K_R.
    op.update(&R);
    op.set_weights(1.3, 0.02);
    op.apply(x, y);
    const Bcsr A = assembled(model, &R, 1.3, 0.02);
    A.multiply(x.data(), ref.data());
    CHECK(rel_diff(y, ref) < 1e-12);

    // Its diagonal blocks are the matrix's.
    std::vector<double> d;
    op.diagonal_blocks(d);
    const std::vector<double> dref = A.diagonal_blocks();
    REQUIRE(d.size() == dref.size());
    double err = 0, size = 0;
    for (size_t i = 0; i < d.size(); ++i) err = std::max(err, std::abs(d[i] - dref[i])), size = std::max(size, std::abs(dref[i]));
    CHECK(err <= 1e-12 * size);
#ifdef _OPENMP
    // The product's ranges add the nodes only they hold in place and the shared ones in slots:
    // any thread count gives them.
    const int threads_before = omp_get_max_threads();
    for (int threads : {1, 3}) {
      omp_set_num_threads(threads);
      std::vector<double> dt;
      op.diagonal_blocks(dt);
      double e = 0;
      for (size_t i = 0; i < dt.size(); ++i) e = std::max(e, std::abs(dt[i] - dref[i]));
      INFO(threads << " threads");
      CHECK(e <= 1e-12 * size);
    }
    omp_set_num_threads(threads_before);
#endif
    CHECK(rel_diff(diagonal_of(op, "test"), diagonal_of(A, "test")) < 1e-12);

    // Elastic force and energy of the state, as the assembled element pass computes them.
    Vector f, fref;
    double energy = 0, eref = 0;
    op.element_force(u, &R, f, &energy);
    ElasticityModel::ElementPass pass;
    pass.u = &u;
    pass.R = &R;
    pass.force = &fref;
    pass.energy = &eref;
    model.evaluate(pass);
    CHECK(rel_diff(f, fref) < 1e-12);
    CHECK(std::abs(energy - eref) <= 1e-12 * std::abs(eref));

    // Symmetric: xᵀ A z = zᵀ A x.
    const Vector z = smooth_vector(op.rows(), 2.3);
    Vector Az;
    op.apply(z, Az);
    CHECK(std::abs(x.dot(Az) - z.dot(y)) <= 1e-12 * std::abs(x.dot(Az)));
  }
}

TEST_CASE("batched matrix-free kernels equal the scalar reference, p = 1..3, rotations and weights",
          "[fem][matrix_free][simd]") {
  // 192 elements (12 full batches of 16), and 24 (one full batch and one of 8 and 8 empty lanes).
  const TetMesh jittered = jittered_box(), small = box_mesh_24(1, 1, 1, 1.0, 0.7, 0.5);
  const Material mat{3.0e5, 0.35, 1.2e3};
  for (int p = 1; p <= 3; ++p)
  for (const TetMesh* mesh_of : {&jittered, &small}) {
    const TetMesh& mesh = *mesh_of;
    ElasticityModel model(mesh, p, mat);
    model.fix_where([](const Vec3& X) { return X[0] < 1e-12; });
    const Vector u = 0.1 * smooth_vector(model.num_dofs(), 0.4);
    const Rotations R = model.rotations(u);
    ElasticityOperator op(model);
    const Vector x = smooth_vector(op.rows(), 1.1), b = smooth_vector(op.rows(), 0.3);
    for (int dynamic = 0; dynamic < 2; ++dynamic) {
      op.update(dynamic ? &R : nullptr);
      op.set_weights(dynamic ? 1.3 : 0.0, dynamic ? 0.02 : 1.0);
      op.set_kernel(MatrixFreeKernel::reference);
      CHECK(op.kernel() == MatrixFreeKernel::reference);
      Vector ref, rref;
      op.apply(x, ref);
      op.residual(b, x, rref);
      for (MatrixFreeKernel k : {MatrixFreeKernel::generic, MatrixFreeKernel::avx2, MatrixFreeKernel::avx512,
                                 MatrixFreeKernel::automatic}) {
        INFO("degree " << p << ", " << mesh.num_tets() << " elements, dynamic " << dynamic << ", kernel "
                       << to_string(k));
        if (!matrix_free_kernel_available(k)) {
          CHECK_THROWS_AS(op.set_kernel(k), InputError);
          continue;
        }
        op.set_kernel(k);
        CHECK(op.kernel() != MatrixFreeKernel::automatic);
        Vector y, r;
        op.apply(x, y);
        op.residual(b, x, r);
        CHECK(rel_diff(y, ref) < 1e-13);
        CHECK(rel_diff(r, rref) < 1e-13);
        // Single precision: the same product to float accuracy.
        Eigen::VectorXf yf;
        op.apply_single(x.cast<float>(), yf);
        CHECK(rel_diff(yf.cast<double>(), ref) < 2e-6);
        CHECK(rel_diff(yf.cast<double>(), ref) > 0.0);  // it did run in float
      }
    }
  }
}

TEST_CASE("batched product on 1 to 3 threads writes in place: the reference kernel's result, mesh order and shuffled",
          "[fem][matrix_free][threads]") {
  // 3072 elements (192 batches): in the generator's order the batches follow the mesh; shuffled,
  // they follow the Morton order of the centroids (ElementRanges). Each thread's range of batches
  // writes y at the nodes only it holds and its shared slots into its own buffer.
  const TetMesh ordered = box_mesh_24(128, 1, 1, 8.0, 0.0625, 0.0625);
  TetMesh shuffled = ordered;
  std::shuffle(shuffled.tets.begin(), shuffled.tets.end(), std::mt19937(3));
  const Material mat{3.0e5, 0.35, 1.2e3};
#ifdef _OPENMP
  const int threads_before = omp_get_max_threads();
#endif
  for (const TetMesh* mesh : std::vector<const TetMesh*>{&ordered, &shuffled})
    for (int p = 2; p <= 3; ++p) {
      ElasticityModel model(*mesh, p, mat);
      model.fix_where([](const Vec3& X) { return X[0] < 1e-12; });
      CHECK(model.assembler().ranges().reordered() == (mesh == &shuffled));
      ElasticityOperator op(model);
      const Vector x = smooth_vector(op.rows(), 1.1), b = smooth_vector(op.rows(), 0.3);
      op.set_weights(0.7, 1.0);
      op.set_kernel(MatrixFreeKernel::reference);
      Vector ref, rref;
      op.apply(x, ref);
      op.residual(b, x, rref);
      op.set_kernel(MatrixFreeKernel::automatic);
      for (int threads : {1, 2, 3}) {
        INFO("degree " << p << (mesh == &shuffled ? ", shuffled" : ", generator's order") << ", " << threads
                       << " threads");
#ifdef _OPENMP
        omp_set_num_threads(threads);
#endif
        Vector y = Vector::Constant(op.rows(), 7.0), r;  // stale contents must not leak through
        op.apply(x, y);
        op.residual(b, x, r);
        CHECK(rel_diff(y, ref) < 1e-13);
        CHECK(rel_diff(r, rref) < 1e-13);
        Eigen::VectorXf yf = Eigen::VectorXf::Constant(op.rows(), 7.0f);
        op.apply_single(x.cast<float>(), yf);
        CHECK(rel_diff(yf.cast<double>(), ref) < 2e-6);
        // The float residual in the product's pass, into a separate vector and in place (r = b).
        Eigen::VectorXf rf = Eigen::VectorXf::Constant(op.rows(), 7.0f), rin = b.cast<float>();
        op.residual_single(b.cast<float>(), x.cast<float>(), rf);
        op.residual_single(rin, x.cast<float>(), rin);
        CHECK(rel_diff(rf.cast<double>(), rref) < 2e-6);
        CHECK(rin == rf);
      }
#ifdef _OPENMP
      omp_set_num_threads(threads_before);
      // Called from inside a parallel region that cannot start another: one thread, the same result.
      const int levels_before = omp_get_max_active_levels();
      omp_set_max_active_levels(1);
      Vector nested;
#pragma omp parallel num_threads(2)
      {
#pragma omp master
        op.apply(x, nested);
      }
      omp_set_max_active_levels(levels_before);
      CHECK(rel_diff(nested, ref) < 1e-13);
#endif
    }
}

TEST_CASE("matrix-free kernel names and bad single-precision input", "[fem][matrix_free][simd]") {
  for (MatrixFreeKernel k : {MatrixFreeKernel::automatic, MatrixFreeKernel::reference, MatrixFreeKernel::generic,
                             MatrixFreeKernel::avx2, MatrixFreeKernel::avx512})
    CHECK(parse_matrix_free_kernel(to_string(k)) == k);
  CHECK_THROWS_AS(parse_matrix_free_kernel("sse9"), InputError);
  CHECK(matrix_free_kernel_available(MatrixFreeKernel::generic));
  const TetMesh mesh = box_mesh_24(1, 1, 1, 1, 1, 1);
  ElasticityModel model(mesh, 2, Material{});
  ElasticityOperator op(model);
  Eigen::VectorXf y;
  CHECK_THROWS_AS(op.apply_single(Eigen::VectorXf::Zero(op.rows() + 1), y), InputError);
  Eigen::VectorXf same = Eigen::VectorXf::Ones(op.rows());
  CHECK_THROWS_AS(op.apply_single(same, same), InputError);
  CHECK_THROWS_AS(op.residual_single(same, same, same), InputError);
  CHECK_THROWS_AS(op.residual_single(Eigen::VectorXf::Zero(op.rows() + 1), same, y), InputError);
  CHECK_THROWS_AS(op.residual_single(same, Eigen::VectorXf::Zero(op.rows() - 1), y), InputError);
}

TEST_CASE("matrix-free operator refuses bad weights and rotation counts", "[fem][matrix_free]") {
  const TetMesh mesh = box_mesh_24(1, 1, 1, 1, 1, 1);
  ElasticityModel model(mesh, 2, Material{});
  ElasticityOperator op(model);
  CHECK_THROWS_AS(op.set_weights(-1.0, 1.0), InputError);
  CHECK_THROWS_AS(op.set_weights(0.0, 0.0), InputError);
  CHECK_THROWS_AS(op.set_weights(1.0, -1.0), InputError);
  CHECK_NOTHROW(op.set_weights(1.0, 0.0));  // the mass alone
  CHECK_THROWS_AS(op.set_weights(std::nan(""), 1.0), InputError);
  const Rotations R(3, Mat3::Identity());
  CHECK_THROWS_AS(op.update(&R), InputError);
  Vector f;
  CHECK_THROWS_AS(op.element_force(Vector::Zero(5), nullptr, f, nullptr), InputError);
}

TEST_CASE("the matrix-free route's lmax estimate: 10 Lanczos steps, a Ritz value inside the 10% margin",
          "[fem][matrix_free][smoother]") {
  // λmax of D⁻¹A for the operator of a cubic and a nearly incompressible quadratic level, exactly
  // (the dense generalized eigenproblem A v = λ D v), against the route's default estimate. (On
  // these small levels 15 power steps come as close or closer — 0.980 against 0.973 of λmax on the
  // cubic one; on the models' levels Lanczos was the closer, docs/scaling.md.)
  const TetMesh mesh = jittered_box(2, 1, 1);
  for (const auto& [p, nu] : std::vector<std::pair<int, double>>{{3, 0.3}, {2, 0.49}}) {
    ElasticityModel model(mesh, p, Material{1.0e5, nu, 1.0});
    model.fix_where([](const Vec3& X) { return X.x() < 1e-12; });
    const ElasticityOperator op(model);
    const Bcsr A = assembled(model, nullptr, 0.0, 1.0);
    const Eigen::MatrixXd dense = A.to_csr().to_eigen().toDense();
    Eigen::MatrixXd D = Eigen::MatrixXd::Zero(dense.rows(), dense.cols());
    for (Eigen::Index I = 0; I < dense.rows() / 3; ++I) D.block<3, 3>(3 * I, 3 * I) = dense.block<3, 3>(3 * I, 3 * I);
    const double exact = Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd>(dense, D).eigenvalues().maxCoeff();
    mg::ChebyshevParams lanczos;
    lanczos.lanczos = true;
    lanczos.power_iterations = 10;  // the matrix-free route's defaults (multigrid/src/register.cpp)
    lanczos.update_iterations = 1;
    const double by_lanczos = mg::Chebyshev(op, lanczos).lambda_max() / 1.1;
    INFO("degree " << p << ", nu " << nu << ", " << A.rows() << " unknowns: exact " << exact << ", 10 Lanczos steps "
                   << by_lanczos);
    CHECK(by_lanczos <= exact * (1 + 1e-10));  // a Ritz value: never above
    CHECK(1.1 * by_lanczos >= exact);          // the bound the smoother uses lies above λmax
  }
}

TEST_CASE("the matrix-free smoother's lmax estimate runs in float where D^-1 fits float, in double beyond",
          "[fem][matrix_free][smoothers]") {
  // λmax(D⁻¹A) does not depend on E, so the estimate on the operator (in float where it may and
  // can) equals the one on the assembled matrix (always in double) to float's rounding. Where E puts
  // D⁻¹'s block scales beyond [kSingleLow, kSingleHigh] (E = 1e±36: still inside float's range,
  // but a product's data would be near its subnormals; 1e±45: outside it), or where no float cycle
  // asked for float (set_single_precision), the operator's estimate runs in double and equals the
  // matrix's to double's rounding.
  const TetMesh mesh = jittered_box(2, 1, 1);
  for (const double young : {1.0e5, 1.0e-36, 1.0e36, 1.0e-45, 1.0e45}) {
    for (const bool wanted : {true, false}) {
      ElasticityModel model(mesh, 2, Material{young, 0.3, 1.0});
      model.fix_where([](const Vec3& X) { return X.x() < 1e-12; });
      const ElasticityOperator op(model);
      const Bcsr A = assembled(model, nullptr, 0.0, 1.0);
      mg::ChebyshevParams lanczos;
      lanczos.lanczos = true;
      lanczos.power_iterations = 10;
      mg::Chebyshev on_operator(lanczos), on_matrix(lanczos);
      on_operator.set_single_precision(wanted), on_matrix.set_single_precision(wanted);
      on_operator.setup(op), on_matrix.setup(A);
      const bool in_float = wanted && young == 1.0e5;
      INFO("E = " << young << (wanted ? ", float wanted" : "") << ": operator " << on_operator.lambda_max()
                  << ", matrix " << on_matrix.lambda_max());
      CHECK(on_operator.inverse_diagonal_single().empty() == !in_float);
      CHECK(on_matrix.inverse_diagonal_single().empty());  // an assembled matrix applies in double only
      CHECK(on_operator.lambda_max() == Approx(on_matrix.lambda_max()).epsilon(in_float ? 1e-5 : 1e-12));
    }
  }
}

TEST_CASE("matrix-free residual in one pass equals b - A x", "[fem][matrix_free]") {
  const TetMesh mesh = jittered_box();
  ElasticityModel model(mesh, 3, Material{});
  model.fix_where([](const Vec3& X) { return X[2] < 1e-12; });
  ElasticityOperator op(model);
  op.set_weights(0.7, 0.01);
  const Vector x = smooth_vector(op.rows(), 0.2), b = smooth_vector(op.rows(), 0.9);
  Vector Ax, r;
  op.apply(x, Ax);
  op.residual(b, x, r);
  CHECK(rel_diff(r, Vector(b - Ax)) < 1e-14);
}

namespace {
/// The true relative residual of x for the hierarchy's assembled finest matrix.
double true_residual(const DegreeHierarchy& h, const Vector& b, const Vector& x) {
  Vector r;
  h.matrix(h.num_levels() - 1).residual(b, x, r);
  return r.norm() / b.norm();
}
}  // namespace

TEST_CASE("matrix-free p-multigrid (PMG and MGPCG) reaches the tolerance of the assembled system",
          "[fem][matrix_free][multigrid]") {
  const TetMesh mesh = box_mesh_24(3, 2, 2, 1.5, 1.0, 1.0);
  const Material mat{1e6, 0.3, 1e3};
  DegreeHierarchy h(mesh, 3, mat, [](const Vec3& X) { return X[0] < 1e-12; });
  const int L = h.num_levels();
  SECTION("static, linear elasticity") {
    h.assemble(nullptr);
    const Vector b = h.finest().restrict_to_free(h.finest().gravity(Vec3(0, 0, -9.81)));
    Vector x_ref;
    CholmodSolver chol;
    chol.setup(h.matrix(L - 1));
    chol.apply(b, x_ref);
    SolverContext ctx;
    ctx.levels = &h;
    for (const char* method : {"pmg", "mgpcg"}) {
      INFO(method);
      auto s = make_solver(Config::from_pairs({std::string("method=") + method, "operator=matrix-free",
                                               "tol=1e-9"}, "test"), ctx);
      CHECK(s->needs().matrix_free);
      s->setup(*h.matrix_free_operator(L - 1));
      Vector x = Vector::Zero(b.size());
      const SolveResult res = s->solve(b, x);
      CHECK(res.ok());
      CHECK(true_residual(h, b, x) <= 2e-9);
      CHECK((x - x_ref).norm() <= 1e-6 * x_ref.norm());
    }
  }
  SECTION("implicit-Euler weights and rotations, updated per step") {
    const Vector u = 0.05 * smooth_vector(h.finest().num_dofs(), 0.3);
    const Rotations R = h.finest().rotations(u);
    SolverContext ctx;
    ctx.levels = &h;
    auto s = make_solver(Config::from_pairs({"method=mgpcg", "operator=matrix-free", "tol=1e-9"}, "test"), ctx);
    const double m = 1.0, st = 1e-4;
    for (int step = 0; step < 2; ++step) {
      const Rotations Rs = step == 0 ? Rotations(mesh.num_tets(), Mat3::Identity()) : R;
      h.assemble(&Rs, nullptr, m, st);  // the matrices, to check against
      for (int l = 1; l < L; ++l) h.update_matrix_free(l, &Rs, m, st);
      if (step == 0) s->setup(*h.matrix_free_operator(L - 1));
      else s->update();
      const Vector b = smooth_vector(h.matrix(L - 1).rows(), 0.5 + step);
      Vector x = Vector::Zero(b.size());
      CHECK(s->solve(b, x).ok());
      CHECK(true_residual(h, b, x) <= 2e-9);
      Vector y, yref;
      h.matrix_free_operator(L - 1)->apply(b, y);
      h.matrix(L - 1).apply(b, yref);
      CHECK(rel_diff(y, yref) < 1e-12);
    }
  }
  SECTION("refused where it cannot work") {
    SolverContext ctx;
    ctx.levels = &h;
    CHECK_THROWS_AS(make_solver(Config::from_pairs({"method=pmg", "operator=matrix-free",
                                                    "coarse_operator=galerkin"}, "test"), ctx),
                    InputError);
    CHECK(h.matrix_free_operator(0) == nullptr);
    mg::StoredLevels stored({h.matrix(0), h.matrix(1)}, {h.prolongation(1)});
    ctx.levels = &stored;
    CHECK_THROWS_AS(make_solver(Config::from_pairs({"method=pmg", "operator=matrix-free"}, "test"), ctx),
                    InputError);
  }
  SECTION("defaults: PMG and MGPCG matrix-free where the levels offer operators") {
    SolverContext ctx;
    ctx.levels = &h;
    auto uses_mf = [&](std::vector<std::string> pairs) {
      return make_solver(Config::from_pairs(pairs, "test"), ctx)->needs().matrix_free;
    };
    CHECK(uses_mf({"method=mgpcg"}));
    CHECK(uses_mf({"method=mgpcg", "smoother=chebyshev", "smoother.degree=3"}));
    CHECK(uses_mf({"method=mgpcg", "smoother.kind=opt-fourth"}));  // Chebyshev's keys alone
    CHECK(uses_mf({"method=pmg"}));
    CHECK_FALSE(uses_mf({"method=pmg", "operator=assembled"}));
    CHECK_FALSE(uses_mf({"method=mgpcg", "operator=assembled"}));
    CHECK_FALSE(uses_mf({"method=mgpcg", "smoother=gauss-seidel"}));
    CHECK_FALSE(uses_mf({"method=mgpcg", "smoother.sweeps=3"}));  // Gauss–Seidel's key: assembled
    CHECK_FALSE(uses_mf({"method=mgpcg", "coarse_operator=galerkin"}));
    // The resolved route is among the printed options.
    Config c = Config::from_pairs({"method=mgpcg"}, "test");
    make_solver(c, ctx);
    CHECK_THAT(c.to_string(), Catch::Contains("operator=matrix-free"));
    mg::StoredLevels stored({h.matrix(0), h.matrix(1)}, {h.prolongation(1)});
    ctx.levels = &stored;  // matrices only
    CHECK_FALSE(uses_mf({"method=mgpcg"}));
  }
}

TEST_CASE("single-precision cycles reach a true residual of 1e-10 in double, static and per time step",
          "[fem][matrix_free][multigrid][single]") {
  const TetMesh mesh = box_mesh_24(3, 2, 2, 1.5, 1.0, 1.0);
  const Material mat{1e6, 0.3, 1e3};
  DegreeHierarchy h(mesh, 3, mat, [](const Vec3& X) { return X[0] < 1e-12; });
  const int L = h.num_levels();
  SolverContext ctx;
  ctx.levels = &h;
  auto solve = [&](const std::string& method, const std::string& precision, const Vector& b, bool update) {
    auto s = make_solver(Config::from_pairs({"method=" + method, "operator=matrix-free", "tol=1e-10",
                                             "max_iterations=2000", "precision=" + precision}, "test"), ctx);
    s->setup(*h.matrix_free_operator(L - 1));
    if (update) s->update();
    Vector x = Vector::Zero(b.size());
    const SolveResult res = s->solve(b, x);
    CHECK(res.ok());
    return std::make_pair(res.iterations, x);
  };
  for (int dynamic = 0; dynamic < 2; ++dynamic) {
    const Vector u = 0.05 * smooth_vector(h.finest().num_dofs(), 0.3);
    const Rotations R = h.finest().rotations(u);
    if (dynamic) {
      h.assemble(&R, nullptr, 1.0, 1e-4);
      for (int l = 1; l < L; ++l) h.update_matrix_free(l, &R, 1.0, 1e-4);
    } else {
      h.assemble(nullptr);
      for (int l = 1; l < L; ++l) h.update_matrix_free(l, nullptr, 0.0, 1.0);
    }
    const Vector b = dynamic ? smooth_vector(h.matrix(L - 1).rows(), 0.5)
                             : Vector(h.finest().restrict_to_free(h.finest().gravity(Vec3(0, 0, -9.81))));
    for (const char* method : {"mgpcg", "pmg"}) {
      INFO(method << (dynamic ? ", time step" : ", static"));
      const auto [it_double, x_double] = solve(method, "double", b, dynamic);
      const auto [it_single, x_single] = solve(method, "single", b, dynamic);
      // The true residual in double, of the assembled matrix: the float cycle only preconditions.
      CHECK(true_residual(h, b, x_single) <= 1.05e-10);
      CHECK((x_single - x_double).norm() <= 1e-8 * x_double.norm());
      CHECK(it_single <= it_double + 2);
    }
  }
  // One application of the cycle in float against the double one, for each Chebyshev kind, a
  // W-cycle and two cycles per application: the same map to float accuracy.
  {
    h.assemble(nullptr);
    for (int l = 1; l < L; ++l) h.update_matrix_free(l, nullptr, 0.0, 1.0);
    const Vector r = smooth_vector(h.matrix(L - 1).rows(), 0.8);
    for (const std::vector<std::string>& keys :
         std::vector<std::vector<std::string>>{{"smoother.kind=first", "smoother.degree=2"},
                                               {"smoother.kind=fourth"},
                                               {"smoother.kind=fourth", "smoother.degree=1"},
                                               {"smoother.kind=opt-fourth"},
                                               {"cycle=W"},
                                               {"cycles=2"}}) {
      INFO(keys[0]);
      Vector z[2];
      for (int single = 0; single < 2; ++single) {
        std::vector<std::string> pairs = {"method=pmg", "operator=matrix-free",
                                          std::string("precision=") + (single ? "single" : "double")};
        pairs.insert(pairs.end(), keys.begin(), keys.end());
        auto s = make_solver(Config::from_pairs(pairs, "test"), ctx);
        s->setup(*h.matrix_free_operator(L - 1));
        s->apply(r, z[single]);
        // A badly scaled right-hand side: the same map (the float cycle runs on r scaled to 1).
        if (single) {
          Vector tiny;
          s->apply(1e-30 * r, tiny);
          CHECK(rel_diff(Vector(1e30 * tiny), z[1]) < 1e-6);
          // The cycle starts from zero: what the output and the levels' vectors held is never read.
          Vector again = Vector::Constant(r.size(), std::numeric_limits<double>::quiet_NaN());
          s->apply(r, again);
          CHECK(again == z[1]);
        }
      }
      CHECK(rel_diff(z[1], z[0]) < 1e-4);
      CHECK(rel_diff(z[1], z[0]) > 0.0);
    }
  }
  CHECK_THROWS_AS(make_solver(Config::from_pairs({"method=pmg", "operator=matrix-free", "precision=single",
                                                  "smoother=jacobi"}, "test"), ctx),
                  InputError);
  // Refused where it cannot run: assembled levels (no float operators or smoothers there).
  CHECK_THROWS_AS(make_solver(Config::from_pairs({"method=mgpcg", "operator=assembled", "precision=single"}, "test"),
                              ctx),
                  InputError);
  CHECK_THROWS_AS(make_solver(Config::from_pairs({"method=mgpcg", "precision=half"}, "test"), ctx), InputError);
}

namespace {
// The lean element kernel (pmg/fem/element_kernel.hpp) run element by element on the host, as a
// GPU thread per element would: y = Σ_e r_e(x_e) through the operator's own element arrays.
template <int P>
Vector lean_product(const ElasticityOperator& op, const Vector& x) {
  const auto arr = op.element_arrays();
  const ElementKernelTables<P>& t = element_kernel_tables<P>();
  Vector y = Vector::Zero(op.rows());
  for (index_t e = 0; e < arr.elements; ++e) {
    const index_t* f = arr.free + static_cast<size_t>(e) * arr.nodes;
    auto load = [&](int a, int i) { return f[a] >= 0 ? x[3 * f[a] + i] : 0.0; };
    auto add = [&](int a, int i, double v) {
      if (f[a] >= 0) y[3 * f[a] + i] += v;
    };
    element_apply_lean<P>(t, arr.data.data() + static_cast<size_t>(e) * kElementData, load, add);
  }
  return y;
}

template <int P>
std::vector<double> lean_diagonal(const ElasticityOperator& op) {
  const auto arr = op.element_arrays();
  std::vector<double> D(3 * static_cast<size_t>(op.rows()), 0.0);
  for (index_t e = 0; e < arr.elements; ++e)
    for (int a = 0; a < arr.nodes; ++a) {
      const index_t I = arr.free[static_cast<size_t>(e) * arr.nodes + a];
      if (I < 0) continue;
      double B[9];
      element_diagonal_block<P>(element_kernel_tables<P>(), arr.data.data() + static_cast<size_t>(e) * kElementData, a, B);
      for (int k = 0; k < 9; ++k) D[9 * static_cast<size_t>(I) + k] += B[k];
    }
  return D;
}

template <int P>
void check_lean_kernel(const ElasticityModel& model, const Rotations& R) {
  ElasticityOperator op(model);
  op.set_kernel(MatrixFreeKernel::reference);
  op.update(&R);
  op.set_weights(1.3, 0.02);
  const Vector x = smooth_vector(op.rows(), 0.7);
  Vector ref;
  op.apply(x, ref);
  CHECK(rel_diff(lean_product<P>(op, x), ref) < 1e-13);
  std::vector<double> dref;
  op.diagonal_blocks(dref);
  const std::vector<double> d = lean_diagonal<P>(op);
  double err = 0.0, norm = 0.0;
  for (size_t k = 0; k < d.size(); ++k) err = std::max(err, std::abs(d[k] - dref[k])), norm = std::max(norm, std::abs(dref[k]));
  CHECK(err <= 1e-13 * norm);
  // The per-step rotation of the element data is element_rotate of the rest gradients.
  const auto arr = op.element_arrays();
  for (index_t e = 0; e < arr.elements; ++e) {
    double grad[12], Rm[9], d[12];
    const auto& g = model.geometry(e).grad;
    for (int k = 0; k < 4; ++k)
      for (int j = 0; j < 3; ++j) grad[3 * k + j] = g(k, j);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) Rm[3 * i + j] = R[static_cast<size_t>(e)](i, j);
    element_rotate(grad, Rm, d);
    for (int k = 0; k < 12; ++k)
      CHECK(d[k] == Approx(arr.data[static_cast<size_t>(e) * kElementData + k]).epsilon(1e-14).margin(1e-14 * g.norm()));
  }
  // Stiffness only (no mass term) as well.
  op.set_weights(0.0, 1.0);
  op.apply(x, ref);
  CHECK(rel_diff(lean_product<P>(op, x), ref) < 1e-13);
}
}  // namespace

TEST_CASE("the lean __host__ __device__ element kernel equals the CPU operator, p = 1..3",
          "[fem][matrix_free][gpu-host]") {
  const TetMesh mesh = jittered_box();
  const Material mat{3.0e5, 0.35, 1.2e3};
  for (int p = 1; p <= 3; ++p) {
    INFO("degree " << p);
    ElasticityModel model(mesh, p, mat);
    model.fix_where([](const Vec3& X) { return X[0] < 1e-12; });
    std::vector<double> scale(mesh.num_tets());
    for (size_t e = 0; e < scale.size(); ++e) scale[e] = 1.0 + 0.5 * std::sin(1.7 * e);
    model.set_stiffness_scale(scale);
    const Rotations R = model.rotations(0.1 * smooth_vector(model.num_dofs(), 0.4));
    if (p == 1) check_lean_kernel<1>(model, R);
    if (p == 2) check_lean_kernel<2>(model, R);
    if (p == 3) check_lean_kernel<3>(model, R);
  }
}
