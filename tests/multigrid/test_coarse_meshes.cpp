// The linear levels of a refined mesh's coarser meshes (fem::CoarseMeshLevels) and the cycle the
// factory builds on them (coarse_meshes): exact linear interpolation, the same answers as the
// lowest level solved on the linear level itself, held components, updates and the refusals.
#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/multigrid/cycle.hpp"
#include "pmg/multigrid/factory.hpp"

#include <catch2/catch.hpp>

using namespace pmg;
using namespace pmg::fem;
using pmg::Config;

namespace {
bool clamped(const Vec3& X) { return X.x() < 1e-12; }
const Material kRubberless{500e3, 0.3, 1000.0};

/// A cantilever box refined `refine` times, its hierarchy told the refinements, loaded at x = 1.
struct Refined {
  std::vector<Refinement> record;  // before the mesh, whose refinement fills it
  TetMesh mesh;
  DegreeHierarchy h;
  Vector b;
  Refined(int refine, int degree, std::vector<char> components = {}, const TetMesh& base = box_mesh_24(2, 1, 1, 1.0, 0.5, 0.5))
      : record(), mesh(refine_uniform(base, refine, &record)), h(mesh, degree, kRubberless, clamped, std::move(components)) {
    h.set_refinements(record);
    h.assemble(nullptr);
    Vector f = Vector::Zero(h.finest().num_dofs());
    h.finest().add_traction(f, [](const Vec3& X) { return X.x() > 1 - 1e-12; }, Vec3(0, 100.0, -250.0));
    b = h.finest().restrict_to_free(f);
  }
};

struct Run {
  SolveResult result;
  Vector x;
  std::string described;
};

Run solve(const DegreeHierarchy& h, const Vector& b, std::vector<std::string> options) {
  options.push_back("max_iterations=300");
  SolverContext ctx;
  ctx.levels = &h;
  auto s = make_solver(Config::from_pairs(options, "test"), ctx);
  s->setup(h.matrix(h.num_levels() - 1));
  Run r;
  r.x = Vector::Zero(b.size());
  r.result = s->solve(b, r.x);
  r.described = s->describe();
  return r;
}
}  // namespace

TEST_CASE("a refinement record gives each new vertex the edge it halves", "[fem][mesh]") {
  const TetMesh base = box_mesh_24(2, 1, 1, 1.0, 0.5, 0.5);
  std::vector<Refinement> record;
  const TetMesh fine = refine_uniform(base, 2, &record);
  REQUIRE(record.size() == 2);
  CHECK(record[0].coarse_vertices == base.num_vertices());
  CHECK(record[1].coarse_vertices == record[0].fine_vertices());
  CHECK(record[1].fine_vertices() == fine.num_vertices());
  // The record's parents: each new vertex is the midpoint of its coarse edge, and the mesh after
  // one refinement is the same with and without a record.
  const TetMesh once = refine_uniform(base, 1);
  for (size_t k = 0; k < record[0].midpoints.size(); ++k) {
    const auto [a, b] = record[0].midpoints[k];
    CHECK((once.vertices[record[0].coarse_vertices + k] - 0.5 * (base.vertices[a] + base.vertices[b])).norm() < 1e-15);
  }
  for (index_t v = 0; v < once.num_vertices(); ++v) CHECK(fine.vertices[v] == once.vertices[v]);
  // Children 8e..8e+7 lie in element e: their centroids have positive barycentric coordinates.
  for (index_t e = 0; e < base.num_tets(); ++e)
    for (int c = 0; c < 8; ++c) {
      const Tet& t = once.tets[8 * e + c];
      const Vec3 centroid = 0.25 * (once.vertices[t[0]] + once.vertices[t[1]] + once.vertices[t[2]] + once.vertices[t[3]]);
      const Tet& p = base.tets[e];
      Mat3 D;
      for (int i = 0; i < 3; ++i) D.col(i) = base.vertices[p[i + 1]] - base.vertices[p[0]];
      const Vec3 l = D.inverse() * (centroid - base.vertices[p[0]]);
      CHECK(l.minCoeff() > 0);
      CHECK(l.sum() < 1);
    }
}

TEST_CASE("the coarser meshes' linear levels interpolate linear fields exactly", "[fem][multigrid]") {
  Refined r(2, 2);
  const std::shared_ptr<const LevelProvider> below = r.h.levels_below();
  REQUIRE(below != nullptr);
  REQUIRE(below->num_levels() == 3);
  CHECK(below->has_matrix(2));
  CHECK_FALSE(below->has_matrix(0));
  CHECK(&below->matrix(2) == &r.h.matrix(0));
  CHECK(below->level_name(2) == "degree 1");
  CHECK(below->level_name(0) == "degree 1, mesh coarser by 2");
  // f(X) = 1 + 2x - y + 3z at each level's free nodes: P maps one level's values to the next's.
  auto field = [](const std::vector<double>& xyz) {
    Vector f(static_cast<Eigen::Index>(xyz.size() / 3));
    for (Eigen::Index i = 0; i < f.size(); ++i) f[i] = 1 + 2 * xyz[3 * i] - xyz[3 * i + 1] + 3 * xyz[3 * i + 2];
    return f;
  };
  for (int l = 1; l < 3; ++l) {
    const Vector coarse = field(below->node_coordinates(l - 1)), fine = field(below->node_coordinates(l));
    const Csr& P = below->prolongation(l);
    REQUIRE(P.cols() == coarse.size());
    REQUIRE(P.rows() == fine.size());
    // Rows whose parents are all free reproduce f (a clamped parent's value is 0, not f).
    Vector Pc = Vector::Zero(fine.size());
    P.multiply(coarse.data(), Pc.data());
    const std::vector<double> X = below->node_coordinates(l);
    index_t checked = 0;
    for (Eigen::Index i = 0; i < fine.size(); ++i) {
      if (X[3 * i] < 0.3) continue;  // away from the clamp at x = 0 (an edge's other end there)
      CHECK(Pc[i] == Approx(fine[i]).epsilon(1e-13));
      ++checked;
    }
    CHECK(checked > 0);
  }
}

TEST_CASE("a record that does not end at the hierarchy's mesh is refused", "[fem][multigrid][errors]") {
  Refined r(1, 2);
  std::vector<Refinement> wrong;
  refine_uniform(box_mesh_24(1, 1, 1, 1.0, 0.5, 0.5), 1, &wrong);
  CHECK_THROWS_WITH(r.h.set_refinements(wrong), Catch::Contains("hierarchy's mesh has"));
  std::vector<Refinement> bad = r.record;
  bad[0].midpoints[0] = {0, 0};
  CHECK_THROWS_WITH(r.h.set_refinements(bad), Catch::Contains("halves an edge"));
  r.h.set_refinements({});
  CHECK(r.h.levels_below() == nullptr);
}

TEST_CASE("MGPCG with the coarser meshes' cycle as its lowest level gives the linear level's answers",
          "[multigrid][cycle]") {
  const int p = GENERATE(2, 3);
  CAPTURE(p);
  Refined r(2, p);
  const Run off = solve(r.h, r.b, {"method=mgpcg", "tol=1e-10", "coarse_meshes=off"});
  const Run on = solve(r.h, r.b, {"method=mgpcg", "tol=1e-10", "coarse_meshes=on"});
  const Run w = solve(r.h, r.b, {"method=mgpcg", "tol=1e-10", "coarse_meshes=on", "cycle=W"});
  REQUIRE(off.result.status == SolveStatus::converged);
  REQUIRE(on.result.status == SolveStatus::converged);
  REQUIRE(w.result.status == SolveStatus::converged);
  CHECK((on.x - off.x).norm() <= 1e-8 * off.x.norm());
  CHECK((w.x - off.x).norm() <= 1e-8 * off.x.norm());
  CHECK_THAT(on.described, Catch::Contains("mesh coarser by 2"));
  CHECK_THAT(off.described, !Catch::Contains("mesh coarser"));
  // An inexact lowest level costs few iterations here (CHOLMOD on the linear level is exact).
  INFO("iterations: linear level " << off.result.iterations << ", coarser meshes " << on.result.iterations);
  CHECK(on.result.iterations <= off.result.iterations + 3);
  // Too small for auto: the linear level is solved on its own.
  const Run automatic = solve(r.h, r.b, {"method=mgpcg", "tol=1e-10"});
  CHECK_THAT(automatic.described, !Catch::Contains("mesh coarser"));
  // Stationary pmg takes them when asked.
  const Run pmg = solve(r.h, r.b, {"method=pmg", "tol=1e-8", "coarse_meshes=on"});
  CHECK(pmg.result.status == SolveStatus::converged);
  CHECK((pmg.x - off.x).norm() <= 1e-6 * off.x.norm());
}

TEST_CASE("the coarser meshes' cycle keeps held components at zero and follows updates", "[multigrid][cycle]") {
  // A symmetry plane at y = 0: u_y held there on every mesh.
  const TetMesh base = box_mesh_24(2, 1, 1, 1.0, 0.5, 0.5);
  const TetMesh fine = refine_uniform(base, 1);
  std::vector<char> held(fine.vertices.size(), 0);
  for (size_t v = 0; v < held.size(); ++v) held[v] = fine.vertices[v].y() < 1e-12 ? 2 : 0;
  Refined r(1, 2, held, base);
  const Run off = solve(r.h, r.b, {"method=mgpcg", "tol=1e-10", "coarse_meshes=off"});
  const Run on = solve(r.h, r.b, {"method=mgpcg", "tol=1e-10", "coarse_meshes=on"});
  REQUIRE(on.result.status == SolveStatus::converged);
  CHECK((on.x - off.x).norm() <= 1e-8 * off.x.norm());
  const std::vector<char>& mask = r.h.finest().constrained_free_dofs();
  REQUIRE(!mask.empty());
  for (size_t i = 0; i < mask.size(); ++i)
    if (mask[i]) CHECK(on.x[static_cast<Eigen::Index>(i)] == 0.0);
  // New values on every level (the matrices doubled): update() refreshes the Galerkin products.
  SolverContext ctx;
  ctx.levels = &r.h;
  auto s = make_solver(Config::from_pairs({"method=mgpcg", "tol=1e-10", "coarse_meshes=on"}, "test"), ctx);
  s->setup(r.h.matrix(r.h.num_levels() - 1));
  for (int l = 0; l < r.h.num_levels(); ++l) {
    r.h.assemble_level(l, nullptr, nullptr, 0.0, 2.0);
    if (l > 0) r.h.update_matrix_free(l, nullptr, 0.0, 2.0);
  }
  s->update();
  Vector x = Vector::Zero(r.b.size());
  CHECK(s->solve(r.b, x).status == SolveStatus::converged);
  CHECK((2.0 * x - off.x).norm() <= 1e-8 * off.x.norm());
}

TEST_CASE("coarse_meshes=on without coarser meshes is refused, naming the key", "[multigrid][factory][errors]") {
  const TetMesh mesh = box_mesh_24(2, 1, 1, 1.0, 0.5, 0.5);
  DegreeHierarchy h(mesh, 3, kRubberless, clamped);
  h.assemble(nullptr);
  SolverContext ctx;
  ctx.levels = &h;
  CHECK_THROWS_WITH(make_solver(Config::from_pairs({"method=mgpcg", "coarse_meshes=on"}, "test"), ctx),
                    Catch::Contains("coarse_meshes") && Catch::Contains("refinement"));
  // Under Galerkin products the linear level is not the hierarchy's: refused for on, off for auto.
  Refined g(1, 2);
  ctx.levels = &g.h;
  CHECK_THROWS_WITH(make_solver(Config::from_pairs({"method=mgpcg", "coarse_meshes=on", "coarse_operator=galerkin"}, "test"), ctx),
                    Catch::Contains("coarse_operator=geometric"));
  // Levels skipped below degree 2 have no linear level to put the meshes under.
  Refined r(1, 3);
  ctx.levels = &r.h;
  CHECK_THROWS_WITH(make_solver(Config::from_pairs({"method=mgpcg", "coarse_meshes=on", "skip_levels=1"}, "test"), ctx),
                    Catch::Contains("skip_levels"));
}
