// Vertex-patch Schwarz smoothing (mg::PatchSchwarz) on the BB degree hierarchy: the patches are the
// open vertex stars, one application equals the dense sum of patch solves, and Chebyshev in M⁻¹A
// reaches the tolerance in fewer iterations than D⁻¹ as ν approaches 1/2.
#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/multigrid/chebyshev.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/multigrid/patch.hpp"
#include "pmg/sparse/solver.hpp"

#include "jittered.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <set>

using namespace pmg;
using namespace pmg::fem;

namespace {


Eigen::MatrixXd dense(const Bcsr& A) {
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(A.rows(), A.cols());
  const BlockPattern& p = A.pattern();
  for (index_t I = 0; I < p.rows; ++I)
    for (offset_t k = p.row_ptr[I]; k < p.row_ptr[I + 1]; ++k)
      D.block<3, 3>(3 * I, 3 * p.col_idx[k]) = A.block(k);
  return D;
}

}  // namespace

TEST_CASE("vertex patches are the open stars of the mesh vertices", "[fem][patch]") {
  const TetMesh mesh = box_mesh_24(1, 1, 1, 1, 1, 1);
  DegreeHierarchy h(mesh, 3, Material{}, [](const Vec3& X) { return X[0] < 1e-12; });
  CHECK(h.vertex_patches(0) == nullptr);
  for (int l = 1; l < h.num_levels(); ++l) {
    const ElasticityModel& model = h.model(l);
    const std::vector<std::vector<index_t>>& patches = *h.vertex_patches(l);
    const std::vector<index_t>& free = model.assembler().free_index();
    // Every free node in a patch; a vertex node in exactly one, an edge node in two, a face node
    // (p = 3) in three: the vertices of the sub-simplex it lies on.
    std::vector<int> count(model.assembler().num_free(), 0);
    for (const auto& P : patches) {
      CHECK(std::is_sorted(P.begin(), P.end()));
      for (index_t i : P) ++count[i];
    }
    const BBSpace& space = model.space();
    const std::vector<MultiIndex>& alpha = multi_indices(space.degree());
    std::vector<int> expected(count.size(), -1);
    for (index_t e = 0; e < mesh.num_tets(); ++e)
      for (int a = 0; a < space.nodes_per_element(); ++a) {
        const index_t f = free[space.node(e, a)];
        if (f < 0) continue;
        int support = 0;
        for (int i = 0; i < 4; ++i) support += alpha[a][i] > 0;
        expected[f] = support;
      }
    // Clamped vertices keep their stars (their free edge and face nodes need them).
    for (size_t i = 0; i < count.size(); ++i) {
      INFO("level " << l << ", free node " << i);
      CHECK(count[i] == expected[i]);
    }
  }
}

TEST_CASE("patch Schwarz equals the dense sum of patch solves, p = 2, 3, with rotations",
          "[fem][patch]") {
  const TetMesh mesh = test::jittered_box(2, 2, 1, 0.03);
  DegreeHierarchy h(mesh, 3, Material{2e5, 0.45, 1e3}, [](const Vec3& X) { return X[0] < 1e-12; });
  const Vector u = 0.05 * test::smooth_vector(h.finest().num_dofs(), 0.4);
  const Rotations R = h.finest().rotations(u);
  h.assemble(&R, nullptr, 1.0, 1e-3);
  for (int l = 1; l < h.num_levels(); ++l) {
    INFO("degree " << l + 1);
    const Bcsr& A = h.matrix(l);
    const std::vector<std::vector<index_t>>& patches = *h.vertex_patches(l);
    const Vector r = test::smooth_vector(A.rows(), 1.1);
    const Eigen::MatrixXd D = dense(A);
    Vector reference = Vector::Zero(r.size());
    for (const auto& P : patches) {
      std::vector<Eigen::Index> dofs;
      for (index_t i : P)
        for (int c = 0; c < 3; ++c) dofs.push_back(3 * i + c);
      const auto n = static_cast<Eigen::Index>(dofs.size());
      Eigen::MatrixXd AP(n, n);
      Vector rP(n);
      for (Eigen::Index a = 0; a < n; ++a) {
        rP[a] = r[dofs[a]];
        for (Eigen::Index b = 0; b < n; ++b) AP(a, b) = D(dofs[a], dofs[b]);
      }
      const Vector zP = AP.fullPivLu().solve(rP);
      for (Eigen::Index a = 0; a < n; ++a) reference[dofs[a]] += zP[a];
    }
    // Double inverses to round-off; float ones (the default) to float accuracy: entries rounded to
    // 2^-24 relative, the sums over up to 3|P| terms in float, amplified by the patches' condition.
    for (const bool single : {false, true}) {
      INFO((single ? "float" : "double"));
      mg::PatchParams params;
      params.single = single;
      mg::PatchSchwarz M(patches, params);
      M.setup(A);
      Vector z;
      M.apply(r, z);
      CHECK((z - reference).norm() <= (single ? 1e-6 : 1e-10) * reference.norm());
      // Symmetric: <M r, s> = <r, M s> (the stored inverses are exactly symmetric).
      const Vector s = test::smooth_vector(A.rows(), 2.3);
      Vector Ms;
      M.apply(s, Ms);
      CHECK(std::abs(z.dot(s) - r.dot(Ms)) <= (single ? 1e-7 : 1e-12) * std::abs(z.dot(s)));
      CHECK(M.factor_bytes() > 0);
      CHECK_THAT(M.describe(), Catch::Contains(single ? "float inverses" : "double inverses"));
    }
  }
}

TEST_CASE("MGPCG with Chebyshev on vertex patches reaches the tolerance as nu -> 1/2, in fewer iterations",
          "[fem][patch][multigrid]") {
  const TetMesh mesh = box_mesh_24(3, 1, 1, 3.0, 1.0, 1.0);
  SolverContext ctx;
  for (const double nu : {0.3, 0.499}) {
    DegreeHierarchy h(mesh, 2, Material{1e6, nu, 1e3}, [](const Vec3& X) { return X[0] < 1e-12; });
    h.assemble(nullptr);
    ctx.levels = &h;
    const Vector b = h.finest().restrict_to_free(h.finest().gravity(Vec3(0, 0, -9.81)));
    int its[2] = {0, 0};
    for (int patch = 0; patch < 2; ++patch) {
      INFO("nu " << nu << (patch ? ", patch" : ", block Jacobi"));
      std::vector<std::string> keys = {"method=mgpcg", "tol=1e-8", "operator=assembled", "smoother.method=chebyshev",
                                       "smoother.kind=opt-fourth", "smoother.degree=3"};
      if (patch) keys.push_back("smoother.preconditioner.method=patch");
      auto s = make_solver(Config::from_pairs(keys, "test"), ctx);
      s->setup(h.matrix(h.num_levels() - 1));
      Vector x = Vector::Zero(b.size());
      const SolveResult res = s->solve(b, x);
      REQUIRE(res.ok());
      Vector r;
      h.matrix(h.num_levels() - 1).residual(b, x, r);
      CHECK(r.norm() <= 1.01e-8 * b.norm());
      its[patch] = res.iterations;
    }
    // Where the point smoother degrades, the patches take fewer iterations (on this 3 x 1 x 1
    // box: 23 against 48 at nu = 0.499; the cubic Homer's figures are in docs/robustness.md).
    if (nu > 0.4) CHECK(its[1] < its[0]);
  }
}

TEST_CASE("patch Schwarz refuses what it cannot do, naming it", "[fem][patch]") {
  const TetMesh mesh = box_mesh_24(1, 1, 1, 1, 1, 1);
  DegreeHierarchy h(mesh, 2, Material{}, [](const Vec3& X) { return X[0] < 1e-12; });
  SolverContext ctx;
  ctx.levels = &h;
  SECTION("a matrix-free level") {
    mg::PatchSchwarz M(*h.vertex_patches(1));
    CHECK_THROWS_WITH(M.setup(*h.matrix_free_operator(1)), Catch::Contains("assembled matrix"));
  }
  SECTION("a singular patch matrix") {
    h.assemble(nullptr);
    Bcsr A = h.matrix(1);
    for (double& v : A.values()) v = 0.0;  // no stiffness at all
    mg::PatchSchwarz M(*h.vertex_patches(1));
    CHECK_THROWS_WITH(M.setup(A), Catch::Contains("not positive definite"));
  }
  SECTION("a patch too ill-conditioned for float inverses keeps double ones") {
    h.assemble(nullptr);
    Bcsr A = h.matrix(1);
    // D A D with D = 1e-5 on block row 0's unknowns: still SPD, its patch's condition about 1e10.
    const BlockPattern& p = A.pattern();
    for (index_t I = 0; I < p.rows; ++I)
      for (offset_t k = p.row_ptr[I]; k < p.row_ptr[I + 1]; ++k) {
        if (I == 0) A.block(k) *= 1e-5;
        if (p.col_idx[k] == 0) A.block(k) *= 1e-5;
      }
    mg::PatchSchwarz M(*h.vertex_patches(1));  // float by default
    M.setup(A);
    CHECK_THAT(M.describe(), Catch::Contains("double inverses") && Catch::Contains("float would not keep"));
    mg::PatchParams twice;
    twice.single = false;
    mg::PatchSchwarz D(*h.vertex_patches(1), twice);
    D.setup(A);
    const Vector r = test::smooth_vector(A.rows(), 0.7);
    Vector z, zd;
    M.apply(r, z);
    D.apply(r, zd);
    CHECK((z - zd).norm() == 0.0);
  }
  SECTION("patches that miss a row, or name one out of range") {
    h.assemble(nullptr);
    std::vector<std::vector<index_t>> patches = *h.vertex_patches(1);
    patches.pop_back();
    std::set<index_t> covered;
    for (const auto& P : patches) covered.insert(P.begin(), P.end());
    // The last patch is the last vertex's star, whose free vertex node lies in no other patch.
    REQUIRE(static_cast<index_t>(covered.size()) < h.matrix(1).pattern().rows);
    CHECK_THROWS_WITH(mg::PatchSchwarz(patches).setup(h.matrix(1)), Catch::Contains("lies in no patch"));
    CHECK_THROWS_WITH(mg::PatchSchwarz({{0, 100000}}).setup(h.matrix(1)), Catch::Contains("names block row"));
    CHECK_THROWS_WITH(mg::PatchSchwarz({}), Catch::Contains("no patches"));
  }
  SECTION("levels without patches, through the factory") {
    CHECK_THROWS_WITH(make_solver(Config::from_pairs({"method=richardson", "preconditioner.method=patch"}, "test")),
                      Catch::Contains("vertex patches"));
  }
}

TEST_CASE("skip_levels: degree 2 as the factorised lowest level of a cubic hierarchy", "[fem][multigrid]") {
  const TetMesh mesh = box_mesh_24(3, 1, 1, 3.0, 1.0, 1.0);
  DegreeHierarchy h(mesh, 3, Material{1e6, 0.3, 1e3}, [](const Vec3& X) { return X[0] < 1e-12; });
  SolverContext ctx;
  ctx.levels = &h;
  const Vector b = h.finest().restrict_to_free(h.finest().gravity(Vec3(0, 0, -9.81)));
  for (const char* route : {"operator=matrix-free", "operator=assembled"}) {
    INFO(route);
    auto s = make_solver(Config::from_pairs({"method=mgpcg", "tol=1e-9", "skip_levels=1", route}, "test"), ctx);
    const SolverNeeds needs = s->needs();
    CHECK(needs.lowest_level == 1);
    // prepare() brings the levels from degree 2 up: degree 2 assembled, degree 1 left alone.
    BoundSystem bound = h.bind(*s);
    const LinearOperator& A = bound.prepare();
    CHECK(*std::max_element(h.matrix(1).values().begin(), h.matrix(1).values().end()) > 0);
    for (const auto& [part, seconds] : bound.prepare_seconds()) CHECK(part.find("degree 1") == std::string::npos);
    s->setup(A);
    CHECK_THAT(s->describe(), Catch::Contains("2 levels (degree 3") && Catch::Contains("degree 2"));
    CHECK_THAT(s->describe(), !Catch::Contains("degree 1"));
    Vector x = Vector::Zero(b.size());
    const SolveResult res = s->solve(b, x);
    REQUIRE(res.ok());
    h.assemble_level(2, nullptr);
    Vector r;
    h.matrix(2).residual(b, x, r);
    CHECK(r.norm() <= 1.01e-9 * b.norm());
  }
  CHECK_THROWS_WITH(make_solver(Config::from_pairs({"method=pmg", "skip_levels=2"}, "test"), ctx),
                    Catch::Contains("fewer than two"));
}

TEST_CASE("the factory's smoothing choices around vertex patches", "[fem][patch]") {
  const TetMesh mesh = box_mesh_24(2, 1, 1, 2.0, 1.0, 1.0);
  auto make = [&](double nu, std::vector<std::string> keys) {
    static std::vector<std::unique_ptr<DegreeHierarchy>> keep;  // outlive the solvers below
    keep.push_back(std::make_unique<DegreeHierarchy>(mesh, 2, Material{1e6, nu, 1e3},
                                                     [](const Vec3& X) { return X[0] < 1e-12; }));
    SolverContext ctx;
    ctx.levels = keep.back().get();
    return make_solver(Config::from_pairs(keys, "test"), ctx);
  };
  // Stationary pmg takes the patches from lambda/mu = 99 (nu = 0.495, which rounds just below 99).
  CHECK_THAT(make(0.495, {"method=pmg"})->describe(), Catch::Contains("chebyshev(patch)") &&
                                                          Catch::Contains("lambda/mu = 99 >= 99"));
  CHECK_THAT(make(0.49, {"method=pmg"})->describe(), !Catch::Contains("patch"));
  // Not where mgpcg runs, nor where keys or precision=single say otherwise.
  CHECK_THAT(make(0.499, {"method=mgpcg"})->describe(), !Catch::Contains("patch"));
  CHECK_THAT(make(0.499, {"method=pmg", "smoother.degree=2"})->describe(), !Catch::Contains("patch"));
  CHECK(make(0.499, {"method=pmg", "precision=single"})->needs().matrix_free);
  // A preconditioner key alone means Chebyshev: block-jacobi keeps the matrix-free route.
  auto bj = make(0.3, {"method=mgpcg", "smoother.preconditioner=block-jacobi"});
  CHECK(bj->needs().matrix_free);
  CHECK_THAT(bj->describe(), Catch::Contains("smoothing chebyshev"));
  // patch is a preconditioner only; Chebyshev takes no M but block-jacobi and patch.
  CHECK_THROWS_WITH(make(0.3, {"method=pmg", "smoother=patch"}), Catch::Contains("smoother.preconditioner=patch"));
  CHECK_THROWS_WITH(make(0.3, {"method=pmg", "smoother.preconditioner=gauss-seidel"}),
                    Catch::Contains("block-jacobi or patch"));
}
