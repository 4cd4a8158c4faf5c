// The distributed mesh (pmg/petsc/plex.hpp, DMPlex + PT-Scotch) and the static problem built on it
// without any rank holding the whole mesh (pmg/distributed/mesh_problem.hpp): cell and vertex
// counts, a numbering in which every rank sees a shared node under the same global number, and
// solutions equal to pmgkit's serial MGPCG on the same mesh. The same executable runs on 1 rank
// and under mpirun -np 2, 3 and 4 (oversubscribed: equality, not speed).
#include "pmg/distributed/dynamics.hpp"
#include "pmg/distributed/mesh_problem.hpp"
#include "pmg/distributed/rank_hierarchy.hpp"
#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/fem/static_solve.hpp"
#include "pmg/petsc/plex.hpp"
#include "pmg/petsc/pcmg.hpp"
#include "pmg/sparse/factory.hpp"

#include <catch2/catch.hpp>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <algorithm>
#include <map>

using namespace pmg;
using namespace pmg::fem;

namespace {

int world_rank() {
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}

/// The mesh as PlexMesh takes it: all of it on rank 0 (`comm`'s), nothing elsewhere.
std::unique_ptr<petsc::PlexMesh> plex_of(const TetMesh& mesh, MPI_Comm comm) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  std::vector<double> X;
  std::vector<index_t> cells;
  if (rank == 0) {
    for (const Vec3& v : mesh.vertices) X.insert(X.end(), {v[0], v[1], v[2]});
    for (const Tet& t : mesh.tets) cells.insert(cells.end(), t.begin(), t.end());
  }
  return std::make_unique<petsc::PlexMesh>(comm, X, cells);
}

/// A position key rounded to 1e-9 (control points of the meshes below are 1e-3 apart or more).
std::array<long long, 3> key(const Vec3& X) {
  return {std::llround(X[0] * 1e9), std::llround(X[1] * 1e9), std::llround(X[2] * 1e9)};
}

/// The rank's owned nodes on a level: each one's position and its offset among the owned nodes
/// (its unknowns are 3 offset .. 3 offset + 2 of an owned vector).
std::vector<std::pair<Vec3, index_t>> owned_nodes(const dist::RankHierarchy& R, int l) {
  const ElasticityModel& m = R.local().model(l);
  const auto& free = m.assembler().free_index();
  const auto& P = m.space().positions();
  std::vector<std::pair<Vec3, index_t>> out;
  for (size_t n = 0; n < P.size(); ++n) {
    if (free[n] < 0) continue;
    const index_t g = R.global(l)[free[n]];
    if (g >= R.first(l) && g < R.first(l) + R.owned(l)) out.emplace_back(P[n], g - R.first(l));
  }
  return out;
}

/// pmgkit's serial MGPCG (CHOLMOD lowest level) on a hierarchy: the full displacement vector.
Vector serial_displacement(DegreeHierarchy& h, const Vec3& g) {
  const Vector b = h.finest().restrict_to_free(h.finest().gravity(g));
  auto s = make_solver(Config::from_pairs({"method=mgpcg", "tol=1e-12", "lowest_level=cholmod"}, "test"),
                       SolverContext{&h, nullptr});
  const LinearOperator& A = h.bind(*s).prepare();
  s->setup(A);
  Vector x = Vector::Zero(b.size());
  s->solve(b, x);
  return h.finest().expand(x, Vector::Zero(h.finest().num_dofs()));
}

/// The largest difference between the distributed answer (owned unknowns) and a serial full
/// displacement on the same nodes, matched by position, relative to the serial largest.
double difference_to_serial(const dist::RankHierarchy& R, const Vector& x, const ElasticityModel& serial,
                            const Vector& u) {
  std::map<std::array<long long, 3>, index_t> node_at;
  const auto& P = serial.space().positions();
  for (size_t n = 0; n < P.size(); ++n) node_at[key(P[n])] = static_cast<index_t>(n);
  double worst = 0.0, largest = 0.0;
  for (const auto& [position, k] : owned_nodes(R, R.num_levels() - 1)) {
    const auto it = node_at.find(key(position));
    if (it == node_at.end()) return 1e300;  // a node the serial mesh lacks
    const Vec3 mine = x.segment<3>(3 * k);
    const Vec3 theirs = u.segment<3>(3 * it->second);
    worst = std::max(worst, (mine - theirs).norm());
  }
  for (Eigen::Index i = 0; i < u.size() / 3; ++i) largest = std::max(largest, u.segment<3>(3 * i).norm());
  double all = 0.0;
  MPI_Allreduce(&worst, &all, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  return all / largest;
}

}  // namespace

TEST_CASE("a box on DMPlex: counts after distribution and refinement", "[plex]") {
  const TetMesh box = box_mesh_24(4, 2, 2, 1.0, 0.5, 0.5);
  auto plex = plex_of(box, MPI_COMM_WORLD);
  CHECK(plex->global_cells() == box.num_tets());
  CHECK(plex->global_vertices() == box.num_vertices());
  plex->distribute();
  CHECK(plex->global_cells() == box.num_tets());
  CHECK(plex->global_vertices() == box.num_vertices());
  CHECK(plex->local_cells().size() > 0);
  plex->refine(1);
  const BBSpace quadratic(box, 2);  // vertices + edges: the refined mesh's vertices
  CHECK(plex->global_cells() == 8 * box.num_tets());
  CHECK(plex->global_vertices() == quadratic.num_nodes());
  // Every local cell is positively oriented and of the refined size.
  const auto& X = plex->local_vertices();
  const auto& C = plex->local_cells();
  double volume = 0.0;
  for (size_t e = 0; e < C.size() / 4; ++e) {
    TetMesh one;
    for (int k = 0; k < 4; ++k) one.vertices.emplace_back(X[3 * C[4 * e + k]], X[3 * C[4 * e + k] + 1], X[3 * C[4 * e + k] + 2]);
    one.tets.push_back({0, 1, 2, 3});
    CHECK(one.signed_volume(0) > 0);
    volume += one.signed_volume(0);
  }
  double total = 0.0;
  MPI_Allreduce(&volume, &total, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  CHECK(total == Approx(0.25).epsilon(1e-12));
}

TEST_CASE("the plex numbering: one global number per node on every rank that sees it", "[plex]") {
  const TetMesh box = box_mesh_24(4, 2, 2, 1.0, 0.5, 0.5);
  const DegreeHierarchy serial(box, 3, Material{}, [](const Vec3& X) { return X.x() < 1e-12; });
  auto plex = plex_of(box, MPI_COMM_WORLD);
  plex->distribute();
  std::vector<char> clamped(plex->local_vertices().size() / 3);
  for (size_t v = 0; v < clamped.size(); ++v) clamped[v] = plex->local_vertices()[3 * v] < 1e-12;
  dist::RankHierarchy R(*plex, 3, Material{}, clamped);
  CHECK_FALSE(R.from_serial());
  CHECK_THROWS_AS(R.owned_part(0, Vector::Zero(3)), Error);
  for (int l = 0; l < R.num_levels(); ++l) {
    CAPTURE(l);
    const long total = R.global_nodes(l);
    CHECK(total == serial.model(l).assembler().num_free());
    long owned = R.owned(l), sum = 0;
    MPI_Allreduce(&owned, &sum, 1, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
    CHECK(sum == total);
    // The owners write their nodes' positions at their global numbers; every rank then finds its
    // own (owned and ghost) nodes' positions there.
    const ElasticityModel& m = R.local().model(l);
    const auto& free = m.assembler().free_index();
    const auto& P = m.space().positions();
    std::vector<double> mine(3 * static_cast<size_t>(total), 0.0), all(mine.size());
    for (size_t n = 0; n < P.size(); ++n) {
      const index_t f = free[n];
      if (f < 0) continue;
      const index_t g = R.global(l)[f];
      REQUIRE(g >= 0);
      REQUIRE(g < total);
      if (g >= R.first(l) && g < R.first(l) + R.owned(l))
        for (int c = 0; c < 3; ++c) mine[3 * g + c] = P[n][c];
    }
    MPI_Allreduce(mine.data(), all.data(), static_cast<int>(all.size()), MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    double worst = 0.0;
    for (size_t n = 0; n < P.size(); ++n) {
      const index_t f = free[n];
      if (f < 0) continue;
      const index_t g = R.global(l)[f];
      worst = std::max(worst, (Vec3(all[3 * g], all[3 * g + 1], all[3 * g + 2]) - P[n]).norm());
    }
    CHECK(worst < 1e-14);
  }
}

TEST_CASE("a static problem on a distributed mesh equals the serial MGPCG", "[plex]") {
  const Vec3 g(0, 0, -9.81);
  for (int p : {2, 3}) {
    CAPTURE(p);
    const TetMesh box = box_mesh_24(6, 2, 2, 1.0, 0.3, 0.3);
    dist::MeshProblemOptions o;
    o.degree = p;
    o.material = Material{500e3, 0.3, 1000.0};
    o.gravity = g;
    dist::MeshProblem problem(MPI_COMM_WORLD, [&] { return box; }, o);
    CHECK(problem.global_cells() == box.num_tets());
    dist::DistributedMgpcgParams params;
    params.tol = 1e-11;
    Vector x;
    const dist::RankSolveReport r = dist::solve_on_ranks(problem, params, x);
    CHECK(r.result.ok());
    CHECK(r.true_residual < 1e-10);
    DegreeHierarchy serial(box, p, o.material, [](const Vec3& X) { return X.x() < 1e-9; });
    const Vector u = serial_displacement(serial, g);
    CHECK(difference_to_serial(problem.ranks(), x, serial.finest(), u) < 1e-8);
    const Vector f = serial.finest().gravity(g);
    CHECK(r.compliance == Approx(f.dot(u)).epsilon(1e-9));
  }
}

TEST_CASE("a quarter model with two symmetry planes on a distributed mesh equals the serial MGPCG", "[plex][symmetry]") {
  const Vec3 g(0, 0, -9.81);
  const TetMesh box = box_mesh_24(6, 2, 2, 1.0, 0.25, 0.25);
  dist::MeshProblemOptions o;
  o.material = Material{500e3, 0.3, 1000.0};
  o.gravity = g;
  o.held = {{1, true, 2}, {2, true, 4}};  // u_y on y = max, u_z on z = max
  dist::MeshProblem problem(MPI_COMM_WORLD, [&] { return box; }, o);
  dist::DistributedMgpcgParams params;
  params.tol = 1e-11;
  Vector x;
  const dist::RankSolveReport r = dist::solve_on_ranks(problem, params, x);
  CHECK(r.result.ok());
  std::vector<char> masks(box.vertices.size(), 0);
  for (size_t v = 0; v < masks.size(); ++v) {
    if (std::abs(box.vertices[v].y() - 0.25) < 1e-9) masks[v] |= 2;
    if (std::abs(box.vertices[v].z() - 0.25) < 1e-9) masks[v] |= 4;
  }
  DegreeHierarchy serial(box, 2, o.material, [](const Vec3& X) { return X.x() < 1e-9; }, masks);
  const Vector u = serial_displacement(serial, g);
  CHECK(difference_to_serial(problem.ranks(), x, serial.finest(), u) < 1e-8);
  const Vector f = serial.finest().expand(serial.finest().restrict_to_free(serial.finest().gravity(g)), Vector());
  CHECK(r.compliance == Approx(f.dot(u)).epsilon(1e-9));
  // The held components: counted once over the ranks, zero in the answer.
  const auto& held = serial.finest().constrained_free_dofs();
  CHECK(problem.held_components() == std::count(held.begin(), held.end(), 1));
  const dist::RankHierarchy& R = problem.ranks();
  const int top = R.num_levels() - 1;
  const std::vector<char>& mine = *R.local().constrained_dofs(top);
  double on_planes = 0.0;
  for (size_t i = 0; i < R.global(top).size(); ++i) {
    const index_t k = R.global(top)[i] - R.first(top);
    if (k < 0 || k >= R.owned(top)) continue;
    for (int c = 0; c < 3; ++c)
      if (mine[3 * i + c]) on_planes = std::max(on_planes, std::abs(x[3 * k + c]));
  }
  CHECK(on_planes == 0.0);
  // A plane that holds no boundary face is refused on every rank.
  o.held = {{1, true, 2}};
  CHECK_THROWS_WITH(dist::MeshProblem(MPI_COMM_WORLD, [] {
                      TetMesh t;  // a single tetrahedron touches y = max in one vertex only
                      t.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
                      t.tets = {{0, 1, 2, 3}};
                      return t;
                    }, o),
                    Catch::Contains("holds no boundary face") || Catch::Contains("cells for"));
}

TEST_CASE("refined after distribution: the same answer as the serial MGPCG on the mesh DMPlex refines", "[plex]") {
  const TetMesh box = box_mesh_24(3, 1, 1, 1.0, 0.3, 0.3);
  const Vec3 g(0, 0, -9.81);
  dist::MeshProblemOptions o;
  o.degree = 2;
  o.refine = 1;
  o.material = Material{500e3, 0.3, 1000.0};
  o.gravity = g;
  o.end_force = Vec3(0, 0, -1.0);
  dist::MeshProblem problem(MPI_COMM_WORLD, [&] { return box; }, o);
  CHECK(problem.global_cells() == 8 * box.num_tets());
  dist::DistributedMgpcgParams params;
  params.tol = 1e-11;
  Vector x;
  const dist::RankSolveReport r = dist::solve_on_ranks(problem, params, x);
  REQUIRE(r.result.ok());
  // The same refinement on one process: every rank makes the whole fine mesh on its own.
  auto whole = plex_of(box, MPI_COMM_SELF);
  whole->refine(1);
  TetMesh fine;
  const auto& X = whole->local_vertices();
  for (size_t v = 0; v < X.size() / 3; ++v) fine.vertices.emplace_back(X[3 * v], X[3 * v + 1], X[3 * v + 2]);
  const auto& C = whole->local_cells();
  for (size_t e = 0; e < C.size() / 4; ++e) fine.tets.push_back({C[4 * e], C[4 * e + 1], C[4 * e + 2], C[4 * e + 3]});
  DegreeHierarchy serial(fine, 2, o.material, [](const Vec3& P) { return P.x() < 1e-9; });
  Vector f = serial.finest().gravity(g);
  Vector t = Vector::Zero(f.size());
  const double area = serial.finest().add_traction(t, [](const Vec3& P) { return P.x() > 1.0 - 1e-9; }, o.end_force);
  f += t / area;
  const Vector b = serial.finest().restrict_to_free(f);
  auto s = make_solver(Config::from_pairs({"method=mgpcg", "tol=1e-12", "lowest_level=cholmod"}, "test"),
                       SolverContext{&serial, nullptr});
  s->setup(serial.bind(*s).prepare());
  Vector y = Vector::Zero(b.size());
  s->solve(b, y);
  const Vector u = serial.finest().expand(y, Vector::Zero(serial.finest().num_dofs()));
  CHECK(difference_to_serial(problem.ranks(), x, serial.finest(), u) < 1e-8);
  CHECK(r.compliance == Approx(b.dot(y)).epsilon(1e-9));
}

TEST_CASE("after distribution no rank holds more than its share of the mesh and the unknowns", "[plex]") {
  // A box refined twice on the ranks: each rank's cells, vertices (its cells' closure) and the
  // hierarchy's nodes on every level (owned and ghost) are its share of the global counts plus a
  // layer at its partition surface, never the global mesh. Bounds: cells within 1.25x of an equal
  // share (PT-Scotch's balance on the coarse cells), closures within 1.6x (the surface layer of a
  // part of this size). Every array of the rank's hierarchy is sized by these counts.
  int size = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  dist::MeshProblemOptions o;
  o.degree = 2;
  o.refine = 2;
  o.gravity = Vec3(0, 0, -9.81);
  o.clamp_axis = 2;
  const TetMesh box = box_mesh_24(4, 4, 4, 1.0, 1.0, 1.0);
  dist::MeshProblem problem(MPI_COMM_WORLD, [&] { return box; }, o);
  const dist::RankHierarchy& R = problem.ranks();
  const double share = 1.0 / size;
  CHECK(problem.global_cells() == 64 * box.num_tets());
  const double cells = static_cast<double>(R.mesh().num_tets());
  CHECK(cells <= 1.25 * share * static_cast<double>(problem.global_cells()));
  const double vertices = static_cast<double>(R.mesh().num_vertices());
  auto whole = plex_of(box, MPI_COMM_SELF);  // the whole fine mesh, for its vertex count only
  whole->refine(2);
  CHECK(vertices <= 1.6 * share * static_cast<double>(whole->global_vertices()));
  for (int l = 0; l < R.num_levels(); ++l) {
    CAPTURE(l);
    const double local = static_cast<double>(R.owned(l) + R.ghosts(l));
    CHECK(local <= 1.6 * share * static_cast<double>(R.global_nodes(l)));
  }
}

TEST_CASE("a mesh saved in PETSc's HDF5 format is read back in parallel: the same problem", "[plex]") {
  // Rank 0's temporary name, shared by every rank.
  char name[256] = {0};
  if (world_rank() == 0) std::snprintf(name, sizeof name, "%s/pmg_plex_%d.h5", std::getenv("TMPDIR") ? std::getenv("TMPDIR") : "/tmp", static_cast<int>(getpid()));
  MPI_Bcast(name, sizeof name, MPI_CHAR, 0, MPI_COMM_WORLD);
  const std::string path = name;
  const TetMesh box = box_mesh_24(3, 1, 1, 1.0, 0.3, 0.3);
  dist::MeshProblemOptions o;
  o.degree = 2;
  o.refine = 1;
  o.material = Material{500e3, 0.3, 1000.0};
  o.gravity = Vec3(0, 0, -9.81);
  o.save_mesh = path;
  dist::DistributedMgpcgParams params;
  params.tol = 1e-11;
  Vector x, y;
  dist::MeshProblem made(MPI_COMM_WORLD, [&] { return box; }, o);
  const dist::RankSolveReport a = dist::solve_on_ranks(made, params, x);
  o.refine = 0;
  o.save_mesh.clear();
  dist::MeshProblem read(MPI_COMM_WORLD, path, o);
  CHECK(read.stages().front().first == "read the mesh in parallel (HDF5)");
  CHECK(read.global_cells() == made.global_cells());
  CHECK(read.ranks().global_nodes(1) == made.ranks().global_nodes(1));
  const dist::RankSolveReport b = dist::solve_on_ranks(read, params, y);
  CHECK(b.result.ok());
  CHECK(b.compliance == Approx(a.compliance).epsilon(1e-9));
  CHECK(b.max_displacement == Approx(a.max_displacement).epsilon(1e-8));
  MPI_Barrier(MPI_COMM_WORLD);
  if (world_rank() == 0) std::remove(path.c_str());
  // A file that is not there, or not a PETSc mesh: the same InputError on every rank.
  CHECK_THROWS_AS(dist::MeshProblem(MPI_COMM_WORLD, path + ".missing.h5", o), InputError);
  CHECK_THROWS_WITH(petsc::PlexMesh::load(MPI_COMM_WORLD, "mesh.ele"), Catch::Contains("HDF5"));
  char junk[256] = {0};
  std::snprintf(junk, sizeof junk, "%s.junk.h5", path.c_str());
  if (world_rank() == 0) {
    FILE* f = std::fopen(junk, "w");
    std::fputs("not HDF5", f);
    std::fclose(f);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  CHECK_THROWS_AS(petsc::PlexMesh::load(MPI_COMM_WORLD, junk), InputError);
  MPI_Barrier(MPI_COMM_WORLD);
  if (world_rank() == 0) std::remove(junk);
}

TEST_CASE("bad input on a distributed mesh is the same error on every rank", "[plex]") {
  dist::MeshProblemOptions o;
  o.gravity = Vec3(0, 0, -9.81);
  // The coarse mesh's maker fails on rank 0: every rank throws its message.
  CHECK_THROWS_WITH(dist::MeshProblem(MPI_COMM_WORLD, []() -> TetMesh { throw InputError("no such mesh file"); }, o),
                    Catch::Contains("no such mesh file"));
  o.degree = 1;
  CHECK_THROWS_AS(dist::MeshProblem(MPI_COMM_WORLD, [] { return box_mesh_24(1, 1, 1, 1, 1, 1); }, o), InputError);
  o.degree = 2;
  // A refinement whose cells would not fit this machine: refused on every rank before DMPlex refines.
  o.refine = 6;
  CHECK_THROWS_WITH(dist::MeshProblem(MPI_COMM_WORLD, [] { return box_mesh_24(20, 20, 20, 1, 1, 1); }, o),
                    Catch::Contains("would need an estimated"));
  o.refine = 0;
  o.clamp_fraction = 1.5;
  CHECK_THROWS_AS(dist::MeshProblem(MPI_COMM_WORLD, [] { return box_mesh_24(1, 1, 1, 1, 1, 1); }, o), InputError);
  // Fewer cells than ranks.
  int size = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  if (size > 1) {
    TetMesh one;
    one.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
    one.tets = {{0, 1, 2, 3}};
    auto plex = plex_of(one, MPI_COMM_WORLD);
    CHECK_THROWS_WITH(plex->distribute(), Catch::Contains("cells for"));
  }
  // A flat cell, on whichever rank METIS sends it: every rank throws, none waits.
  {
    TetMesh flat = box_mesh_24(2, 1, 1, 1.0, 0.5, 0.5);
    std::vector<index_t> bottom;
    for (index_t v = 0; v < flat.num_vertices() && bottom.size() < 4; ++v)
      if (std::abs(flat.vertices[v].z()) < 1e-12) bottom.push_back(v);
    flat.tets.push_back({bottom[0], bottom[1], bottom[2], bottom[3]});
    o.clamp_fraction = 0.0;
    CHECK_THROWS(dist::MeshProblem(MPI_COMM_WORLD, [&] { return flat; }, o));
  }
  // A cell naming a vertex twice.
  {
    std::vector<double> X;
    std::vector<index_t> cells;
    if (world_rank() == 0) X = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1}, cells = {0, 1, 1, 2};
    CHECK_THROWS_WITH(petsc::PlexMesh(MPI_COMM_WORLD, X, cells), Catch::Contains("names vertex 1 twice"));
  }
  // A cell naming a vertex that does not exist.
  std::vector<double> X;
  std::vector<index_t> cells;
  if (world_rank() == 0) X = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1}, cells = {0, 1, 2, 7};
  CHECK_THROWS_WITH(petsc::PlexMesh(MPI_COMM_WORLD, X, cells), Catch::Contains("names vertex 7"));
}

TEST_CASE("every level's product and the lowest level's matrix equal the serial ones by node position", "[plex]") {
  // PETSc's level operators (the shell products across ranks, the degree-1 MPIAIJ) applied to a
  // smooth field sampled at the nodes equal the serial hierarchy's assembled matrices applied to
  // the same field, node by node (found by position), on every rank's owned nodes.
  const TetMesh box = box_mesh_24(4, 2, 2, 1.0, 0.5, 0.5);
  dist::MeshProblemOptions o;
  o.degree = 3;
  o.clamp_axis = 1;
  o.clamp_fraction = 0.05;
  o.gravity = Vec3(0, 0, -9.81);
  dist::MeshProblem problem(MPI_COMM_WORLD, [&] { return box; }, o);
  dist::RankHierarchy& R = problem.ranks();
  R.bring_to(nullptr, 0.0, 1.0);
  petsc::PMultigridCg solver(MPI_COMM_WORLD, petsc::PcmgParams{});
  solver.setup(R.rank_levels());
  Vec3 lo = problem.lo(), hi = problem.hi();
  const double limit = lo[1] + 0.05 * (hi[1] - lo[1]) + 1e-9 * (hi - lo).maxCoeff();
  DegreeHierarchy serial(box, 3, o.material, [&](const Vec3& X) { return X[1] <= limit; });
  for (int l = 0; l < R.num_levels(); ++l) {
    const ElasticityModel& sm = serial.model(l);
    std::map<std::array<long long, 3>, index_t> at;
    const auto& SP = sm.space().positions();
    const auto& sfree = sm.assembler().free_index();
    Vector us = Vector::Zero(3 * sm.assembler().num_free());
    auto f = [](const Vec3& P) { return Vec3(std::sin(3 * P[0]) + P[1], std::cos(2 * P[1]) * P[2], P[0] * P[2] + 1); };
    for (size_t n = 0; n < SP.size(); ++n)
      if (sfree[n] >= 0) at[key(SP[n])] = sfree[n], us.segment<3>(3 * sfree[n]) = f(SP[n]);
    Vector ys = Vector::Zero(us.size());
    serial.assemble_level(l, nullptr, nullptr, 0.0, 1.0);
    serial.matrix(l).multiply(us.data(), ys.data());
    const auto owned = owned_nodes(R, l);
    Vector x = Vector::Zero(3 * R.owned(l)), y;
    for (const auto& [position, k] : owned) x.segment<3>(3 * k) = f(position);
    solver.multiply(l, x, y);
    double worst = 0, scale = ys.cwiseAbs().maxCoeff();
    for (const auto& [position, k] : owned)
      worst = std::max(worst, (y.segment<3>(3 * k) - ys.segment<3>(3 * at.at(key(position)))).norm() / scale);
    CAPTURE(l);
    CHECK(worst < 1e-13);
  }
  // METIS's partition on rank 0: the same ownership and numbering every time.
  dist::MeshProblem again(MPI_COMM_WORLD, [&] { return box; }, o);
  for (int l = 0; l < R.num_levels(); ++l) {
    CHECK(again.ranks().owned(l) == R.owned(l));
    CHECK(again.ranks().global(l) == R.global(l));
  }
}

TEST_CASE("a time step's start on a distributed mesh: the static state, a formula, a probe point", "[plex][simulation]") {
  const bool corotational = GENERATE(false, true);
  CAPTURE(corotational);
  const TetMesh box = box_mesh_24(6, 2, 2, 1.0, 0.3, 0.3);
  dist::MeshProblemOptions o;
  o.material = Material{500e3, 0.3, 1000.0};
  o.end_force = Vec3(0, 0, -2000.0);  // a large deflection: rotations matter
  dist::MeshProblem problem(MPI_COMM_WORLD, [&] { return box; }, o);
  SimulationParams sp;
  sp.corotational = corotational;
  dist::DistributedMgpcgParams params;
  params.tol = 1e-11;
  dist::DistributedEuler across(problem.ranks(), problem.load(), sp, params);
  StaticOptions so;
  so.corotational_tol = 1e-11;
  const int iterations = across.set_static_state(problem.load(), so, 1e-12);
  CHECK((corotational ? iterations > 2 : iterations == 1));

  // The serial fixed point on the same mesh with pmgkit's MGPCG.
  DegreeHierarchy serial(box, 2, o.material, [](const Vec3& X) { return X.x() < 1e-9; });
  const ElasticityModel& m = serial.finest();
  Vector f = Vector::Zero(m.num_dofs());
  f /= m.add_traction(f, [](const Vec3& X) { return X.x() >= 1.0 - 1e-9; }, o.end_force);  // total force F
  auto solver = make_solver(Config::from_pairs({"method=mgpcg", "tol=1e-12", "lowest_level=cholmod"}, "test"),
                            SolverContext{&serial, nullptr});
  const StaticResult r = solve_static(serial, f, corotational, *solver, so);
  CHECK(r.iterations == iterations);
  CHECK(difference_to_serial(problem.ranks(), across.displacement_owned(), m, r.u) < 1e-8);

  // A probe point: every rank gets the serial value; a point outside is refused on every rank.
  const Vec3 point(0.93, 0.21, 0.07);
  const Vec3 d = across.displacement_at(across.locate(point));
  CHECK((d - m.displacement_at(r.u, point)).norm() <= 1e-8 * d.norm());
  CHECK_THROWS_WITH(across.locate(Vec3(5, 5, 5)), Catch::Contains("lies outside the mesh"));

  // A formula on each rank's own nodes: the energies of the serial state.
  const auto bend = [](const Vec3& X) { return Vec3(0.0, 0.02 * X.x() * X.x(), -0.05 * X.x() * X.x()); };
  const ElasticityModel& local = problem.ranks().local().finest();
  Vector u_local = local.interpolate(bend), v_local = local.interpolate(bend);
  across.set_state_local(u_local, v_local);
  Vector u = m.interpolate(bend), v = m.interpolate(bend);
  for (index_t i = 0; i < m.num_nodes(); ++i)
    if (m.is_fixed(i)) u.segment<3>(3 * i).setZero(), v.segment<3>(3 * i).setZero();
  auto serial_solver = make_solver(Config::from_pairs({"method=mgpcg", "tol=1e-12", "lowest_level=cholmod"}, "test"),
                                   SolverContext{&serial, nullptr});
  ImplicitEuler one(serial, *serial_solver, Vector::Zero(m.num_dofs()), sp);
  one.set_state(u, v);
  CHECK(across.kinetic_energy() == Approx(one.kinetic_energy()).epsilon(1e-10));
  CHECK(across.elastic_energy() == Approx(one.elastic_energy()).epsilon(1e-10));
  CHECK_THROWS_WITH(across.set_state_local(Vector::Zero(3), v_local), Catch::Contains("set_state_local"));
  CHECK_THROWS_AS(across.set_state(u, v), InputError);  // serial vectors: the replicated set-up's
}
