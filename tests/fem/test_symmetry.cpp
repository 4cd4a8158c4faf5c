// Symmetry planes in pmgkit's own FEM: components held on their own (ElasticityModel::
// constrain_components) are identity rows in every matrix and in the matrix-free operator, the
// cycles keep them out of their transfers, and a quarter model with two symmetry planes gives the
// full model's displacement field where they overlap.
#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/fem/matrix_free.hpp"
#include "pmg/sparse/factory.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace pmg;
using namespace pmg::fem;

namespace {

const Material kMaterial{5e5, 0.3, 1000.0};

/// Masks holding u_y on y = ly and u_z on z = lz (the symmetry planes of a quarter model).
std::vector<char> planes(const TetMesh& mesh, double ly, double lz) {
  std::vector<char> m(mesh.vertices.size(), 0);
  for (size_t v = 0; v < m.size(); ++v) {
    if (std::abs(mesh.vertices[v].y() - ly) < 1e-9) m[v] |= 2;
    if (std::abs(mesh.vertices[v].z() - lz) < 1e-9) m[v] |= 4;
  }
  return m;
}

/// A body force symmetric about y = 1/2 and z = 1/2: b = ρ g (1, 2 (y - 1/2), 2 (z - 1/2)).
Vector load(const ElasticityModel& m) {
  return m.restrict_to_free(m.body_force(
      [](const Vec3& X) { return Vec3(9.81e3, 2e4 * (X.y() - 0.5), 2e4 * (X.z() - 0.5)); }, 2));
}

struct Solved {
  Vector x;
  int iterations = 0;
};

Solved solve(DegreeHierarchy& h, const std::vector<std::string>& keys) {
  auto s = make_solver(Config::from_pairs(keys, "test"), {&h});
  const LinearOperator& A = h.bind(*s).prepare();
  s->setup(A);
  Solved out;
  const Vector b = load(h.finest());
  out.x = Vector::Zero(b.size());
  const SolveResult r = s->solve(b, out.x);
  REQUIRE(r.ok());
  out.iterations = r.iterations;
  return out;
}

bool clamped_at_x0(const Vec3& X) { return X.x() < 1e-9; }

}  // namespace

TEST_CASE("symmetry planes: identity rows in the matrices and in the matrix-free operator alike", "[fem][symmetry]") {
  const int p = GENERATE(2, 3);
  const TetMesh mesh = box_mesh_24(4, 2, 2, 2.0, 0.5, 0.5);
  DegreeHierarchy h(mesh, p, kMaterial, clamped_at_x0, planes(mesh, 0.5, 0.5));
  const ElasticityModel& m = h.finest();
  const std::vector<char>& held = m.constrained_free_dofs();
  REQUIRE(held.size() == static_cast<size_t>(m.num_free_dofs()));
  index_t count = 0;
  for (char c : held) count += c;
  CHECK(count > 0);
  // The edge y = z = 1/2 holds both components; no node holds all three (x stays free).
  h.assemble_level(h.num_levels() - 1, nullptr, nullptr, 2.0, 0.5);  // 2 M + K/2
  const Bcsr& A = h.matrix(h.num_levels() - 1);
  h.update_matrix_free(h.num_levels() - 1, nullptr, 2.0, 0.5);
  const ElasticityOperator& op = h.matrix_free(h.num_levels() - 1);
  const Vector x = Vector::LinSpaced(m.num_free_dofs(), -1.0, 2.0);
  Vector y_matrix, y_free;
  A.apply(x, y_matrix);
  op.apply(x, y_free);
  CHECK((y_matrix - y_free).norm() <= 1e-12 * y_matrix.norm());
  std::vector<double> d_free;
  op.diagonal_blocks(d_free);
  const std::vector<double> d_matrix = A.diagonal_blocks();
  double diff = 0.0;
  for (size_t k = 0; k < d_free.size(); ++k) diff = std::max(diff, std::abs(d_free[k] - d_matrix[k]));
  CHECK(diff <= 1e-9 * Eigen::Map<const Vector>(d_matrix.data(), static_cast<Eigen::Index>(d_matrix.size())).lpNorm<Eigen::Infinity>());
  for (size_t i = 0; i < held.size(); ++i) {
    if (!held[i]) continue;
    CHECK(y_matrix[static_cast<Eigen::Index>(i)] == x[static_cast<Eigen::Index>(i)]);
    CHECK(d_matrix[9 * (i / 3) + 4 * (i % 3)] == 1.0);
  }
  // A reduced load is zero on the held components.
  const Vector b = load(m);
  for (size_t i = 0; i < held.size(); ++i)
    if (held[i]) CHECK(b[static_cast<Eigen::Index>(i)] == 0.0);
  // Bad masks are refused.
  ElasticityModel other(mesh, p, kMaterial);
  CHECK_THROWS_WITH(other.constrain_components(std::vector<char>(3, 2)), Catch::Contains("masks for"));
  CHECK_THROWS_WITH(other.constrain_components(std::vector<char>(mesh.vertices.size(), 8)), Catch::Contains("bits 1, 2, 4"));
}

TEST_CASE("a quarter model with two symmetry planes: the full model's field, MGPCG as a direct solve, iterations as clamped",
          "[fem][symmetry]") {
  const int p = GENERATE(2, 3);
  CAPTURE(p);
  // Full bar [0, 2] x [0, 1] x [0, 1], clamped at x = 0, loaded symmetrically about y = 1/2 and
  // z = 1/2; the quarter [0, 2] x [0, 1/2] x [0, 1/2] with u_y = 0 on y = 1/2 and u_z = 0 on
  // z = 1/2. The 24-tetrahedron boxes are mirror symmetric, so the quarter mesh is the full mesh's
  // quarter and the two discrete solutions agree to the solver tolerance.
  const TetMesh full_mesh = box_mesh_24(4, 4, 4, 2.0, 1.0, 1.0);
  const TetMesh quarter_mesh = box_mesh_24(4, 2, 2, 2.0, 0.5, 0.5);
  DegreeHierarchy full(full_mesh, p, kMaterial, clamped_at_x0);
  DegreeHierarchy quarter(quarter_mesh, p, kMaterial, clamped_at_x0, planes(quarter_mesh, 0.5, 0.5));
  DegreeHierarchy clamped_only(quarter_mesh, p, kMaterial, clamped_at_x0);
  const std::vector<std::string> mgpcg{"method=mgpcg", "tol=1e-11"};
  const Solved f = solve(full, mgpcg), q = solve(quarter, mgpcg), c = solve(clamped_only, mgpcg);
  const Vector uf = full.finest().expand(f.x, Vector()), uq = quarter.finest().expand(q.x, Vector());
  double scale = 0.0, diff = 0.0;
  for (const Vec3& X : {Vec3(2.0, 0.25, 0.25), Vec3(2.0, 0.5, 0.5), Vec3(1.0, 0.1, 0.45), Vec3(0.3, 0.5, 0.0),
                       Vec3(1.7, 0.0, 0.5)}) {
    const Vec3 a = full.finest().displacement_at(uf, X), b = quarter.finest().displacement_at(uq, X);
    scale = std::max(scale, a.norm());
    diff = std::max(diff, (a - b).norm());
  }
  INFO("largest difference " << diff << " of " << scale);
  CHECK(scale > 1e-6);
  CHECK(diff <= 1e-8 * scale);
  // Held components exactly zero.
  const std::vector<char>& held = quarter.finest().constrained_free_dofs();
  double on_planes = 0.0;
  for (size_t i = 0; i < held.size(); ++i)
    if (held[i]) on_planes = std::max(on_planes, std::abs(q.x[static_cast<Eigen::Index>(i)]));
  CHECK(on_planes == 0.0);
  // The same as CHOLMOD's solve of the constrained (assembled) system.
  quarter.assemble_level(quarter.num_levels() - 1, nullptr);
  auto direct = make_solver(Config::from_pairs({"method=cholmod"}, "test"), {});
  direct->setup(quarter.matrix(quarter.num_levels() - 1));
  const Vector b = load(quarter.finest());
  Vector x_ref = Vector::Zero(b.size());
  direct->solve(b, x_ref);
  CHECK((q.x - x_ref).norm() <= 1e-8 * x_ref.norm());
  // The assembled route (Gauss-Seidel) too.
  const Solved qa = solve(quarter, {"method=mgpcg", "tol=1e-11", "operator=assembled"});
  CHECK((qa.x - x_ref).norm() <= 1e-8 * x_ref.norm());
  INFO("iterations: quarter " << q.iterations << ", clamped only " << c.iterations << ", full " << f.iterations);
  CHECK(q.iterations <= 1.2 * c.iterations);
}

TEST_CASE("components held on their own are refused by the GPU cycle", "[fem][symmetry][errors]") {
  // petsc-mgpcg takes them: tests/distributed/test_distributed.cpp (under mpirun, label mpi).
  const TetMesh mesh = box_mesh_24(4, 2, 2, 2.0, 0.5, 0.5);
  DegreeHierarchy h(mesh, 2, kMaterial, clamped_at_x0, planes(mesh, 0.5, 0.5));
  bool registered = false;
  for (const auto& s : registered_solvers()) registered = registered || s.name == "gpu-pmg";
  if (!registered) return;
  try {
    auto s = make_solver(Config::from_pairs({"method=gpu-pmg"}, "test"), {&h});
    s->setup(h.bind(*s).prepare());
    FAIL("no error");
  } catch (const InputError& e) {
    CHECK_THAT(e.what(), Catch::Contains("constrain") || Catch::Contains("held") || Catch::Contains("CUDA"));
  }
}
