// A static problem on a mesh no rank holds whole (pmg/distributed/mesh_problem.hpp).
#include "pmg/distributed/mesh_problem.hpp"

#include "pmg/metis/partition.hpp"
#include "pmg/mpi/agreement.hpp"
#include "pmg/mpi/session.hpp"
#include "pmg/petsc/pcmg.hpp"
#include "pmg/petsc/plex.hpp"
#include "pmg/sparse/file_io.hpp"
#include "pmg/sparse/timer.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <mutex>

namespace pmg::dist {

namespace {

/// The coarse mesh on rank 0 (nothing elsewhere), as PlexMesh takes it; an exception on rank 0
/// reaches every rank. With `metis`, `parts` gets rank 0's METIS partition of the cells (empty on
/// the other ranks, which hold none; empty everywhere when there are fewer cells than ranks, which
/// PlexMesh::distribute() then refuses).
std::unique_ptr<petsc::PlexMesh> coarse_plex(MPI_Comm comm, const std::function<fem::TetMesh()>& coarse, bool metis,
                                             std::vector<int>& parts) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  std::vector<double> X;
  std::vector<index_t> cells;
  mpi::together(comm, [&] {
    if (rank != 0) return;
    const fem::TetMesh mesh = coarse();
    X.reserve(3 * mesh.vertices.size());
    for (const fem::Vec3& v : mesh.vertices) X.insert(X.end(), {v[0], v[1], v[2]});
    cells.reserve(4 * mesh.tets.size());
    for (const fem::Tet& t : mesh.tets) cells.insert(cells.end(), t.begin(), t.end());
    if (metis && size > 1 && mesh.num_tets() >= size)
      parts = metis::partition_elements(mesh.tets, static_cast<index_t>(mesh.num_vertices()), size);
  });
  return std::make_unique<petsc::PlexMesh>(comm, X, cells);
}

double reduce(MPI_Comm comm, double mine, MPI_Op op) {
  double out = 0.0;
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  MPI_Allreduce(&mine, &out, 1, MPI_DOUBLE, op, comm);
  return out;
}

double dot(MPI_Comm comm, const Vector& a, const Vector& b) { return reduce(comm, a.dot(b), MPI_SUM); }

/// Refuses, on every rank, a refined mesh whose share on this machine's ranks would not fit its
/// memory: `cells` after refinement, an equal share per rank, times the ranks on this node, at a
/// lower estimate of the bytes per cell of the route (measured: 3.8-4.0 KB per quadratic cell on
/// the refined cubes of docs/distributed.md; taken 2 KB, and 8 KB for cubic cells), so that a run
/// that would be killed for memory stops with a clear error before DMPlex refines.
void require_memory_per_node(MPI_Comm comm, double cells, const MeshProblemOptions& o) {
  int size = 1, on_node = 1;
  {
    std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
    MPI_Comm_size(comm, &size);
    MPI_Comm node = MPI_COMM_NULL;
    MPI_Comm_split_type(comm, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
    MPI_Comm_size(node, &on_node);
    MPI_Comm_free(&node);
  }
  const double per_cell = o.degree >= 3 ? 8e3 : 2e3;
  char what[200];
  std::snprintf(what, sizeof what, "distributed mesh: %.3g cells of degree %d after %d refinement(s) on %d rank(s), %d on this machine,",
                cells, o.degree, o.refine, size, on_node);
  mpi::together(comm, [&] { require_memory(cells / size * per_cell * on_node, what); });
}

}  // namespace

void MeshProblem::check(const MeshProblemOptions& o) const {
  mpi::together(comm_, [&] {
    if (o.degree < 2 || o.degree > 3) throw InputError("distributed mesh: degree " + std::to_string(o.degree) + " (2 or 3)");
    if (o.refine < 0 || o.refine > 6) throw InputError("distributed mesh: refine " + std::to_string(o.refine) + " (0 to 6)");
    if ((o.clamp_axis < 0 && !o.free_body) || o.clamp_axis < -1 || o.clamp_axis > 2)
      throw InputError("distributed mesh: a clamp axis (0, 1, 2) is needed unless the body is free (a time-stepping "
                       "scene)");
    if (!(o.clamp_fraction >= 0 && o.clamp_fraction < 1))
      throw InputError("distributed mesh: clamp fraction " + std::to_string(o.clamp_fraction) + " (in [0, 1))");
    o.material.check();
  });
}

MeshProblem::MeshProblem(MPI_Comm comm, const std::function<fem::TetMesh()>& coarse, const MeshProblemOptions& o)
    : comm_(comm) {
  mpi::start();
  check(o);
  if (o.partitioner != "auto" && o.partitioner != "metis" && o.partitioner != "ptscotch" && o.partitioner != "simple")
    throw InputError("distributed mesh: partitioner '" + o.partitioner + "' (auto, metis, ptscotch, simple)");
  const bool metis = o.partitioner == "auto" || o.partitioner == "metis";
  const auto t0 = Clock::now();
  std::vector<int> parts;
  std::unique_ptr<petsc::PlexMesh> plex = coarse_plex(comm, coarse, metis, parts);
  int partitioned = !parts.empty();
  MPI_Bcast(&partitioned, 1, MPI_INT, 0, comm);
  stages_.emplace_back(std::string("coarse mesh (rank 0) into DMPlex") + (partitioned ? ", METIS partition" : ""),
                       seconds_since(t0));
  peaks_.push_back(peak_resident_bytes());
  build(std::move(plex), o, partitioned ? &parts : nullptr);
}

MeshProblem::MeshProblem(MPI_Comm comm, const std::string& plex_file, const MeshProblemOptions& o) : comm_(comm) {
  mpi::start();
  check(o);
  if (o.partitioner != "auto" && o.partitioner != "ptscotch" && o.partitioner != "simple")
    throw InputError("distributed mesh: partitioner '" + o.partitioner + "' for a mesh read in parallel (auto, ptscotch, "
                     "simple; METIS partitions a coarse mesh on rank 0)");
  const auto t0 = Clock::now();
  std::unique_ptr<petsc::PlexMesh> plex = petsc::PlexMesh::load(comm, plex_file);
  stages_.emplace_back("read the mesh in parallel (HDF5)", seconds_since(t0));
  peaks_.push_back(peak_resident_bytes());
  build(std::move(plex), o, nullptr);
}

void MeshProblem::build(std::unique_ptr<petsc::PlexMesh> plex, const MeshProblemOptions& o, const std::vector<int>* parts) {
  MPI_Comm comm = comm_;
  auto t0 = Clock::now();
  int size = 1;
  MPI_Comm_size(comm, &size);
  const std::string partitioner = size == 1 ? "one rank: nothing to move"
                                  : parts   ? "metis"
                                  : o.partitioner == "auto" || o.partitioner == "metis" ? "ptscotch"
                                                                                        : o.partitioner;
  if (parts)
    plex->distribute(*parts);
  else
    plex->distribute(size == 1 ? "simple" : partitioner);
  stages_.emplace_back("distribute (" + partitioner + ")", seconds_since(t0));
  peaks_.push_back(peak_resident_bytes());
  require_memory_per_node(comm, static_cast<double>(plex->global_cells()) * std::pow(8.0, o.refine), o);
  t0 = Clock::now();
  plex->refine(o.refine);
  stages_.emplace_back("refine x" + std::to_string(o.refine) + " on the ranks", seconds_since(t0));
  peaks_.push_back(peak_resident_bytes());
  if (!o.save_mesh.empty()) {
    t0 = Clock::now();
    plex->save(o.save_mesh);
    stages_.emplace_back("save the mesh in parallel (HDF5)", seconds_since(t0));
    peaks_.push_back(peak_resident_bytes());
  }
  cells_ = plex->global_cells();

  // The bounding box over the ranks; the clamp as the serial scene's.
  t0 = Clock::now();
  const std::vector<double>& X = plex->local_vertices();
  const size_t nv = X.size() / 3;
  for (int d = 0; d < 3; ++d) {
    double lo = 1e300, hi = -1e300;
    for (size_t v = 0; v < nv; ++v) lo = std::min(lo, X[3 * v + d]), hi = std::max(hi, X[3 * v + d]);
    lo_[d] = reduce(comm, lo, MPI_MIN);
    hi_[d] = reduce(comm, hi, MPI_MAX);
  }
  const int axis = o.clamp_axis;
  const double tol = 1e-9 * (hi_ - lo_).maxCoeff();
  std::vector<char> clamped(nv, 0);
  long mine = 0;
  if (axis >= 0) {
    const double limit = lo_[axis] + o.clamp_fraction * (hi_[axis] - lo_[axis]) + tol;
    for (size_t v = 0; v < nv; ++v) {
      clamped[v] = X[3 * v + axis] <= limit ? 1 : 0;
      if (clamped[v] && plex->owns_vertex()[v]) ++mine;
    }
  }
  {
    std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
    MPI_Allreduce(&mine, &clamped_, 1, MPI_LONG, MPI_SUM, comm);
  }
  if (axis >= 0 && clamped_ < 3)
    throw InputError("distributed mesh: " + std::to_string(clamped_) + " clamped vertices: the body could still move "
                     "rigidly; clamp a larger fraction");
  std::vector<char> masks;  // the components each vertex holds (empty: none)
  if (!o.held.empty()) {
    masks.assign(nv, 0);
    for (const HeldPlane& h : o.held) {
      if (h.axis < 0 || h.axis > 2 || h.components < 1 || h.components > 7)
        throw InputError("distributed mesh: a held plane needs an axis 0-2 and components 1-7");
      const double face = h.at_max ? hi_[h.axis] : lo_[h.axis];
      for (size_t v = 0; v < nv; ++v)
        if (std::abs(X[3 * v + h.axis] - face) <= tol) masks[v] = static_cast<char>(masks[v] | h.components);
    }
  }
  ranks_ = std::make_unique<RankHierarchy>(*plex, o.degree, o.material, std::move(clamped), inclusion_scale(*plex, o),
                                           std::move(masks));
  plex.reset();  // the rank's mesh lives on in its hierarchy
  stages_.emplace_back("the rank's hierarchy and numbering", seconds_since(t0));
  peaks_.push_back(peak_resident_bytes());

  // Loads from the rank's own cells, summed into the owners.
  t0 = Clock::now();
  axis_ = axis, tol_ = tol;
  const int top = ranks_->num_levels() - 1;
  const fem::ElasticityModel& m = ranks_->local().finest();
  exchange_ = std::make_unique<petsc::GhostExchange>(comm, ranks_->first(top), ranks_->owned(top), ranks_->global(top));
  check_held(o);
  load_ = Vector::Zero(exchange_->owned_size());
  if (o.gravity.norm() > 0) exchange_->add_to_owners(m.restrict_to_free(m.gravity(o.gravity)), load_);
  if (o.end_force.norm() > 0) load_ += end_traction(o.end_force);
  stages_.emplace_back("loads", seconds_since(t0));
  peaks_.push_back(peak_resident_bytes());
}

std::vector<double> MeshProblem::inclusion_scale(const petsc::PlexMesh& plex, const MeshProblemOptions& o) {
  if (!o.inclusion) return {};
  if (!(o.inclusion_young > 0) || !std::isfinite(o.inclusion_young))
    throw InputError("distributed mesh: material.inclusion: Young's modulus must be positive and finite");
  const std::vector<double>& X = plex.local_vertices();
  const std::vector<index_t>& C = plex.local_cells();
  std::vector<double> scale(C.size() / 4, 1.0);
  long inside = 0;
  for (size_t e = 0; e < scale.size(); ++e) {
    fem::Vec3 c = fem::Vec3::Zero();
    for (int k = 0; k < 4; ++k) c += 0.25 * fem::Vec3(X[3 * C[4 * e + k]], X[3 * C[4 * e + k] + 1], X[3 * C[4 * e + k] + 2]);
    if ((c.array() >= o.inclusion_min.array()).all() && (c.array() <= o.inclusion_max.array()).all())
      scale[e] = o.inclusion_young / o.material.young, ++inside;
  }
  {
    std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
    MPI_Allreduce(&inside, &inclusion_cells_, 1, MPI_LONG, MPI_SUM, comm_);
  }
  if (inclusion_cells_ == 0) throw InputError("material.inclusion: no element centroid lies inside [min, max]");
  return scale;
}

void MeshProblem::check_held(const MeshProblemOptions& o) {
  // Each plane must hold a planar part of the boundary, as a serial scene's: the area of the
  // boundary faces on it, over the ranks.
  const fem::ElasticityModel& m = ranks_->local().finest();
  for (const HeldPlane& h : o.held) {
    const double face = h.at_max ? hi_[h.axis] : lo_[h.axis], tol = tol_;
    Vector scratch = Vector::Zero(m.num_dofs());
    const int axis = h.axis;
    const double area = reduce(
        comm_, m.add_traction(scratch, [=](const fem::Vec3& X) { return std::abs(X[axis] - face) <= tol; }, fem::Vec3::Zero()),
        MPI_SUM);
    if (!(area > 0))
      throw InputError(std::string("distributed mesh: the support or symmetry plane at the ") + (h.at_max ? "maximum" : "minimum") +
                       " of " + static_cast<char>('x' + h.axis) + " holds no boundary face (a symmetry plane needs a planar cut face)");
  }
  // Held components of owned nodes, counted once.
  const int top = ranks_->num_levels() - 1;
  const std::vector<char>* held = ranks_->local().constrained_dofs(top);
  long mine = 0;
  if (held) {
    const std::vector<index_t>& global = ranks_->global(top);
    for (size_t i = 0; i < global.size(); ++i)
      if (global[i] >= ranks_->first(top) && global[i] < ranks_->first(top) + ranks_->owned(top))
        for (int c = 0; c < 3; ++c) mine += (*held)[3 * i + c] != 0;
  }
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  MPI_Allreduce(&mine, &held_, 1, MPI_LONG, MPI_SUM, comm_);
}

Vector MeshProblem::end_traction(const fem::Vec3& F) const {
  if (axis_ < 0) throw InputError("distributed mesh: an end force needs a clamp axis (it loads the far face)");
  const fem::ElasticityModel& m = ranks_->local().finest();
  Vector g = Vector::Zero(m.num_dofs());
  const int axis = axis_;
  const double hi = hi_[axis], tol = tol_;
  const double area = reduce(comm_, m.add_traction(g, [=](const fem::Vec3& P) { return P[axis] >= hi - tol; }, F), MPI_SUM);
  if (!(area > 0)) throw InputError("distributed mesh: no boundary face at the maximum of the clamp axis to load");
  Vector owned;
  exchange_->add_to_owners(m.restrict_to_free(g), owned);
  return owned / area;
}

fem::Vec3 MeshProblem::vertex_with_smallest(const std::function<std::array<double, 4>(const fem::Vec3&)>& key) const {
  // The rank's smallest (key, x, y, z); the smallest over the ranks, compared in order.
  std::array<double, 7> mine;
  mine.fill(1e300);
  for (const fem::Vec3& X : ranks_->mesh().vertices) {
    const std::array<double, 4> k = key(X);
    const std::array<double, 7> c = {k[0], k[1], k[2], k[3], X[0], X[1], X[2]};
    if (c < mine) mine = c;
  }
  std::vector<double> all(7 * static_cast<size_t>(ranks_->size()));
  {
    std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
    MPI_Allgather(mine.data(), 7, MPI_DOUBLE, all.data(), 7, MPI_DOUBLE, comm_);
  }
  std::array<double, 7> best = mine;
  for (size_t r = 0; r < all.size(); r += 7) {
    std::array<double, 7> c;
    std::copy(all.begin() + static_cast<long>(r), all.begin() + static_cast<long>(r) + 7, c.begin());
    best = std::min(best, c);
  }
  return {best[4], best[5], best[6]};
}

MeshProblem::~MeshProblem() = default;

RankSolveReport solve_on_ranks(MeshProblem& problem, const DistributedMgpcgParams& params, Vector& x) {
  RankHierarchy& R = problem.ranks();
  MPI_Comm comm = R.comm();
  RankSolveReport out;
  auto t0 = Clock::now();
  R.bring_to(nullptr, 0.0, 1.0);
  petsc::PMultigridCg solver(comm, to_pcmg(params));
  solver.setup(R.rank_levels());
  out.setup_seconds = reduce(comm, seconds_since(t0), MPI_MAX);
  out.setup_stages = solver.setup_timings();
  out.description = solver.describe();
  out.peak_after_setup = peak_resident_bytes();
  const int top = R.num_levels() - 1;
  const Vector& b = problem.load();
  x = Vector::Zero(b.size());
  t0 = Clock::now();
  SolveMonitor monitor;
  monitor.start();
  mpi::together(comm, [&] { out.result = solver.solve(b, x, &monitor); });
  out.history = monitor.history();
  out.solve_seconds = reduce(comm, seconds_since(t0), MPI_MAX);
  out.peak_after_solve = peak_resident_bytes();
  Vector Ax(b.size());
  solver.multiply(top, x, Ax);
  const double bb = dot(comm, b, b);
  out.true_residual = std::sqrt(dot(comm, b - Ax, b - Ax) / (bb > 0 ? bb : 1.0));
  out.result.true_rel_residual = out.true_residual;
  out.compliance = dot(comm, b, x);
  double largest = 0.0;
  for (Eigen::Index i = 0; i < x.size() / 3; ++i) largest = std::max(largest, x.segment<3>(3 * i).norm());
  out.max_displacement = reduce(comm, largest, MPI_MAX);
  out.unknowns = solver.global_size(top);
  for (int l = top; l >= 0; --l) {
    const long mine[2] = {R.ghosts(l), R.owned(l)};
    std::vector<long> all(2 * static_cast<size_t>(R.size()));
    {
      std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
      MPI_Allgather(mine, 2, MPI_LONG, all.data(), 2, MPI_LONG, comm);
    }
    out.ghosts.emplace_back();
    for (int r = 0; r < R.size(); ++r) out.ghosts.back().emplace_back(all[2 * r], all[2 * r + 1]);
  }
  if (!out.result.ok() && params.throw_on_failure) throw SolveError(out.result);
  return out;
}

bool is_plex_file(const std::string& path) {
  return path.size() > 3 && path.compare(path.size() - 3, 3, ".h5") == 0;
}

double peak_resident_bytes() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return 1024.0 * static_cast<double>(u.ru_maxrss);  // kilobytes on Linux
}

}  // namespace pmg::dist
