// A tetrahedral mesh distributed by DMPlex (pmg/petsc/plex.hpp).
#include "pmg/petsc/plex.hpp"

#include "common.hpp"
#include "pmg/mpi/agreement.hpp"
#include "pmg/mpi/session.hpp"
#include "vectors.hpp"

#include <petscdmplex.h>
#include <petscsf.h>

#include <petscviewer.h>

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <mutex>
#include <numeric>
#include <unordered_map>

namespace pmg::petsc {

using detail::check;

namespace {

/// A key for a sorted pair or triple of local vertex ids.
struct EntityKey {
  std::array<index_t, 3> v{-1, -1, -1};
  bool operator<(const EntityKey& o) const { return v < o.v; }
};

double signed_volume(const double* X0, const double* X1, const double* X2, const double* X3) {
  const double a[3] = {X1[0] - X0[0], X1[1] - X0[1], X1[2] - X0[2]};
  const double b[3] = {X2[0] - X0[0], X2[1] - X0[1], X2[2] - X0[2]};
  const double c[3] = {X3[0] - X0[0], X3[1] - X0[1], X3[2] - X0[2]};
  return (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])) /
         6.0;
}

/// PETSc's message for a failed call (its error is then forgotten).
std::string petsc_message(PetscErrorCode code, const char* what) {
  try {
    check(code, what);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

struct PlexMesh::Impl {
  DM dm = nullptr;
  PetscInt v_start = 0, v_end = 0;
  std::vector<PetscInt> point_of_vertex;     // local vertex id -> plex point
  std::map<EntityKey, PetscInt> entities;    // sorted local vertex ids (2 or 3) -> edge or face point
  ~Impl() {
    std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
    if (dm && libraries_running()) DMDestroy(&dm);
  }
};

PlexMesh::PlexMesh(MPI_Comm comm, const std::vector<double>& coordinates, const std::vector<index_t>& cells)
    : impl_(std::make_unique<Impl>()), comm_(comm) {
  detail::start();
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  const long my_vertices = static_cast<long>(coordinates.size() / 3);
  long total = 0;
  MPI_Allreduce(&my_vertices, &total, 1, MPI_LONG, MPI_SUM, comm);
  std::string error;
  if (coordinates.size() % 3 != 0 || cells.size() % 4 != 0)
    error = "plex mesh: " + std::to_string(coordinates.size()) + " coordinates and " + std::to_string(cells.size()) +
            " cell entries (3 per vertex, 4 per cell)";
  for (size_t i = 0; error.empty() && i < cells.size(); ++i)
    if (cells[i] < 0 || cells[i] >= total)
      error = "plex mesh: cell " + std::to_string(i / 4) + " names vertex " + std::to_string(cells[i]) + " of " +
              std::to_string(total);
  for (size_t e = 0; error.empty() && e < cells.size() / 4; ++e)
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b)
        if (cells[4 * e + a] == cells[4 * e + b])
          error = "plex mesh: cell " + std::to_string(e) + " names vertex " + std::to_string(cells[4 * e + a]) + " twice";
  mpi::agree_on_error(comm, error, /*input_error=*/true);
  long my_cells = static_cast<long>(cells.size() / 4), all_cells = 0;
  MPI_Allreduce(&my_cells, &all_cells, 1, MPI_LONG, MPI_SUM, comm);
  if (all_cells == 0) throw InputError("plex mesh: no cells");
  // PETSc's reference tetrahedron is inverted with respect to pmgkit's (as its Gmsh reader does):
  // the first face's normal points into the cell.
  std::vector<PetscInt> c(cells.size());
  for (size_t e = 0; e < cells.size() / 4; ++e) {
    c[4 * e] = cells[4 * e];
    c[4 * e + 1] = cells[4 * e + 2];
    c[4 * e + 2] = cells[4 * e + 1];
    c[4 * e + 3] = cells[4 * e + 3];
  }
  std::vector<PetscReal> X(coordinates.begin(), coordinates.end());
  check(DMPlexCreateFromCellListParallelPetsc(comm, 3, static_cast<PetscInt>(my_cells), static_cast<PetscInt>(my_vertices),
                                              PETSC_DECIDE, 4, PETSC_TRUE, c.data(), 3, X.data(), nullptr, nullptr,
                                              &impl_->dm),
        "DMPlexCreateFromCellListParallelPetsc");
  extract();
}

PlexMesh::~PlexMesh() = default;

PlexMesh::PlexMesh(MPI_Comm comm) : impl_(std::make_unique<Impl>()), comm_(comm) {}

std::unique_ptr<PlexMesh> PlexMesh::load(MPI_Comm comm, const std::string& path) {
  detail::start();
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  // Checked on every rank first: PETSc's HDF5 errors name neither the file nor the cause plainly.
  std::string error;
  if (path.size() < 3 || path.compare(path.size() - 3, 3, ".h5") != 0)
    error = "plex mesh: " + path + ": expected PETSc's HDF5 mesh format (.h5)";
  else if (FILE* f = std::fopen(path.c_str(), "rb")) {
    // HDF5's signature at offset 0, 512, 1024, 2048, ... (checked here: HDF5 itself would print
    // its error stack on every rank before PETSc's message).
    static const char signature[8] = {'\x89', 'H', 'D', 'F', '\r', '\n', '\x1a', '\n'};
    bool found = false;
    char head[8];
    for (long at = 0; !found; at = at == 0 ? 512 : 2 * at) {
      if (std::fseek(f, at, SEEK_SET) != 0 || std::fread(head, 1, 8, f) != 8) break;
      found = std::equal(head, head + 8, signature);
    }
    std::fclose(f);
    if (!found) error = "plex mesh: " + path + ": not an HDF5 file (PETSc's HDF5 mesh format expected)";
  } else {
    error = "plex mesh: " + path + ": cannot be read";
  }
  mpi::agree_on_error(comm, error, /*input_error=*/true);
  std::unique_ptr<PlexMesh> mesh(new PlexMesh(comm));
  DM& dm = mesh->impl_->dm;
  const PetscErrorCode code = DMPlexCreateFromFile(comm, path.c_str(), "pmgkit", PETSC_TRUE, &dm);
  mpi::agree_on_error(comm, code ? "plex mesh: " + path + ": not a mesh PETSc can read (" + petsc_message(code, "reading") + ")" : "",
                      /*input_error=*/true);
  PetscInt dim = 0;
  check(DMGetDimension(dm, &dim), "DMGetDimension");
  if (dim != 3) throw InputError("plex mesh: " + path + ": a mesh of dimension " + std::to_string(dim) + " (3 expected)");
  mpi::together(comm, [&] { mesh->extract(); });
  return mesh;
}

void PlexMesh::save(const std::string& path) const {
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  int rank = 0;
  MPI_Comm_rank(comm_, &rank);
  // A temporary name of rank 0's process, the same on every rank.
  long pid = rank == 0 ? static_cast<long>(getpid()) : 0;
  MPI_Bcast(&pid, 1, MPI_LONG, 0, comm_);
  const std::string part = path + "." + std::to_string(pid) + ".part";
  // PetscViewerHDF5Open's steps, without HDF5's own header; every rank agrees on any failure
  // before the next collective call (a viewer is destroyed collectively).
  PetscViewer viewer = nullptr;
  PetscErrorCode code = PetscViewerCreate(comm_, &viewer);
  if (!code) code = PetscViewerSetType(viewer, PETSCVIEWERHDF5);
  if (!code) code = PetscViewerFileSetMode(viewer, FILE_MODE_WRITE);
  if (!code) code = PetscViewerFileSetName(viewer, part.c_str());
  int failed = code != 0, any = 0;
  MPI_Allreduce(&failed, &any, 1, MPI_INT, MPI_MAX, comm_);
  if (!any) {
    code = PetscViewerPushFormat(viewer, PETSC_VIEWER_HDF5_PETSC);
    if (!code) code = DMView(impl_->dm, viewer);
    failed = code != 0;
    MPI_Allreduce(&failed, &any, 1, MPI_INT, MPI_MAX, comm_);
  }
  const std::string mine = failed ? petsc_message(code, "writing") : "";
  if (viewer) PetscViewerDestroy(&viewer);
  detail::clear_error();
  std::string error;
  if (any) {
    error = "plex mesh: writing " + path + " failed" + (mine.empty() ? std::string() : " (" + mine + ")");
    if (rank == 0) std::remove(part.c_str());
  } else if (rank == 0 && std::rename(part.c_str(), path.c_str()) != 0) {
    error = "plex mesh: cannot rename " + part + " to " + path;
    std::remove(part.c_str());
  }
  mpi::agree_on_error(comm_, error, /*input_error=*/true);
}

void PlexMesh::distribute(const std::string& partitioner) { move_cells(partitioner, nullptr); }

void PlexMesh::distribute(const std::vector<int>& to) { move_cells(PETSCPARTITIONERSHELL, &to); }

void PlexMesh::move_cells(const std::string& partitioner, const std::vector<int>* to) {
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  int size = 1;
  MPI_Comm_size(comm_, &size);
  const long cells = global_cells();
  std::string error;
  if (cells < size)
    error = "plex mesh: " + std::to_string(cells) + " cells for " + std::to_string(size) + " ranks (each rank needs at least one)";
  else if (to && to->size() != cells_.size() / 4)
    error = "plex mesh: a partition of " + std::to_string(to->size()) + " cells for the rank's " +
            std::to_string(cells_.size() / 4);
  for (size_t c = 0; error.empty() && to && c < to->size(); ++c)
    if ((*to)[c] < 0 || (*to)[c] >= size)
      error = "plex mesh: cell " + std::to_string(c) + " sent to rank " + std::to_string((*to)[c]) + " of " + std::to_string(size);
  mpi::agree_on_error(comm_, error, /*input_error=*/true);
  if (size == 1) return;
  PetscPartitioner part = nullptr;
  check(DMPlexGetPartitioner(impl_->dm, &part), "DMPlexGetPartitioner");
  check(PetscPartitionerSetType(part, partitioner.c_str()), ("PetscPartitionerSetType " + partitioner).c_str());
  if (to) {
    // The shell partitioner takes, on each rank, how many of its cells go to each rank and which
    // (cell points grouped by target rank).
    PetscInt c_start = 0, c_end = 0;
    check(DMPlexGetHeightStratum(impl_->dm, 0, &c_start, &c_end), "DMPlexGetHeightStratum");
    std::vector<PetscInt> sizes(size, 0), first(size, 0), points(to->size());
    for (int r : *to) ++sizes[r];
    for (int r = 1; r < size; ++r) first[r] = first[r - 1] + sizes[r - 1];
    for (size_t c = 0; c < to->size(); ++c) points[first[(*to)[c]]++] = static_cast<PetscInt>(c);  // == c_start + c
    check(PetscPartitionerShellSetPartition(part, size, sizes.data(), points.data()), "PetscPartitionerShellSetPartition");
  }
  DM moved = nullptr;
  check(DMPlexDistribute(impl_->dm, 0, nullptr, &moved), "DMPlexDistribute");
  if (moved) {
    DMDestroy(&impl_->dm);
    impl_->dm = moved;
  }
  extract();
  const long mine = static_cast<long>(cells_.size() / 4);
  long fewest = 0;
  MPI_Allreduce(&mine, &fewest, 1, MPI_LONG, MPI_MIN, comm_);
  if (fewest == 0) throw InputError("plex mesh: the partition left a rank without cells (use fewer ranks)");
}

void PlexMesh::refine(int times) {
  if (times < 0) throw InputError("plex mesh: refine " + std::to_string(times) + " times (>= 0)");
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  for (int k = 0; k < times; ++k) {
    check(DMPlexSetRefinementUniform(impl_->dm, PETSC_TRUE), "DMPlexSetRefinementUniform");
    DM fine = nullptr;
    check(DMRefine(impl_->dm, comm_, &fine), "DMRefine");
    DMDestroy(&impl_->dm);
    impl_->dm = fine;
  }
  extract();
}

long PlexMesh::global_cells() const {
  long mine = static_cast<long>(cells_.size() / 4), all = 0;
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  MPI_Allreduce(&mine, &all, 1, MPI_LONG, MPI_SUM, comm_);
  return all;
}

long PlexMesh::global_vertices() const {
  long mine = std::count(owns_vertex_.begin(), owns_vertex_.end(), 1), all = 0;
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  MPI_Allreduce(&mine, &all, 1, MPI_LONG, MPI_SUM, comm_);
  return all;
}

void PlexMesh::extract() {
  Impl& d = *impl_;
  DM dm = d.dm;
  PetscInt c_start = 0, c_end = 0, v_start = 0, v_end = 0;
  check(DMPlexGetHeightStratum(dm, 0, &c_start, &c_end), "DMPlexGetHeightStratum");
  check(DMPlexGetDepthStratum(dm, 0, &v_start, &v_end), "DMPlexGetDepthStratum");
  d.v_start = v_start, d.v_end = v_end;
  const PetscInt nv = v_end - v_start;

  // Global vertex numbers (negative -(g + 1) for vertices another rank owns); the local order by
  // increasing global number.
  IS numbering = nullptr;
  check(DMPlexGetVertexNumbering(dm, &numbering), "DMPlexGetVertexNumbering");
  const PetscInt* g = nullptr;
  check(ISGetIndices(numbering, &g), "ISGetIndices");
  std::vector<long> global(nv);
  std::vector<char> owned(nv);
  for (PetscInt i = 0; i < nv; ++i) {
    owned[i] = g[i] >= 0;
    global[i] = g[i] >= 0 ? g[i] : -(g[i] + 1);
  }
  check(ISRestoreIndices(numbering, &g), "ISRestoreIndices");
  std::vector<index_t> order(nv);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](index_t a, index_t b) { return global[a] < global[b]; });
  std::vector<index_t> local_of(nv);
  d.point_of_vertex.resize(nv);
  global_vertex_.resize(nv);
  owns_vertex_.resize(nv);
  for (PetscInt k = 0; k < nv; ++k) {
    local_of[order[k]] = static_cast<index_t>(k);
    d.point_of_vertex[k] = v_start + order[k];
    global_vertex_[k] = global[order[k]];
    owns_vertex_[k] = owned[order[k]];
  }

  // Coordinates of the local vertices.
  Vec coords = nullptr;
  PetscSection cs = nullptr;
  check(DMGetCoordinatesLocal(dm, &coords), "DMGetCoordinatesLocal");
  check(DMGetCoordinateSection(dm, &cs), "DMGetCoordinateSection");
  const PetscScalar* x = nullptr;
  check(VecGetArrayRead(coords, &x), "VecGetArrayRead");
  vertices_.assign(3 * static_cast<size_t>(nv), 0.0);
  for (PetscInt k = 0; k < nv; ++k) {
    PetscInt off = 0;
    check(PetscSectionGetOffset(cs, d.point_of_vertex[k], &off), "PetscSectionGetOffset");
    for (int i = 0; i < 3; ++i) vertices_[3 * k + i] = x[off + i];
  }
  check(VecRestoreArrayRead(coords, &x), "VecRestoreArrayRead");

  // Cells: the 4 vertices of each cell's closure, positively oriented.
  cells_.assign(4 * static_cast<size_t>(c_end - c_start), -1);
  for (PetscInt c = c_start; c < c_end; ++c) {
    PetscInt n = 0, *points = nullptr;
    check(DMPlexGetTransitiveClosure(dm, c, PETSC_TRUE, &n, &points), "DMPlexGetTransitiveClosure");
    int k = 0;
    for (PetscInt i = 0; i < n; ++i) {
      const PetscInt p = points[2 * i];
      if (p >= v_start && p < v_end && k++ < 4) cells_[4 * (c - c_start) + k - 1] = local_of[p - v_start];
    }
    check(DMPlexRestoreTransitiveClosure(dm, c, PETSC_TRUE, &n, &points), "DMPlexRestoreTransitiveClosure");
    if (k != 4) throw InputError("plex mesh: a cell with " + std::to_string(k) + " vertices (tetrahedra only)");
    index_t* t = &cells_[4 * (c - c_start)];
    if (signed_volume(&vertices_[3 * t[0]], &vertices_[3 * t[1]], &vertices_[3 * t[2]], &vertices_[3 * t[3]]) < 0)
      std::swap(t[1], t[2]);
  }

  // Edges and faces by their sorted local vertex ids.
  d.entities.clear();
  for (int depth = 1; depth <= 2; ++depth) {
    PetscInt start = 0, end = 0;
    check(DMPlexGetDepthStratum(dm, depth, &start, &end), "DMPlexGetDepthStratum");
    for (PetscInt p = start; p < end; ++p) {
      PetscInt n = 0, *points = nullptr;
      check(DMPlexGetTransitiveClosure(dm, p, PETSC_TRUE, &n, &points), "DMPlexGetTransitiveClosure");
      EntityKey key;
      int k = 0;
      for (PetscInt i = 0; i < n; ++i) {
        const PetscInt q = points[2 * i];
        if (q >= v_start && q < v_end && k < 3) key.v[k++] = local_of[q - v_start];
      }
      check(DMPlexRestoreTransitiveClosure(dm, p, PETSC_TRUE, &n, &points), "DMPlexRestoreTransitiveClosure");
      for (int i = 0; i < k; ++i)  // sort the k <= 3 ids
        for (int j = i + 1; j < k; ++j)
          if (key.v[j] < key.v[i]) std::swap(key.v[i], key.v[j]);
      d.entities[key] = p;
    }
  }
}

PlexNumbering PlexMesh::number(const std::vector<PlexNode>& nodes) const {
  const Impl& d = *impl_;
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  PetscInt p_start = 0, p_end = 0;
  check(DMPlexGetChart(d.dm, &p_start, &p_end), "DMPlexGetChart");
  // Each node's entity point and slot; the entity's node count and fixedness.
  const size_t n = nodes.size();
  std::vector<PetscInt> point(n), slot(n);
  std::vector<PetscInt> count(p_end - p_start, 0);
  std::vector<signed char> fixed(p_end - p_start, -1);
  std::string error;
  const index_t nv = static_cast<index_t>(d.point_of_vertex.size());
  for (size_t i = 0; i < n && error.empty(); ++i) {
    const PlexNode& node = nodes[i];
    // Sort the entity's vertices (local order = global order), multiplicities along.
    std::array<std::pair<index_t, int>, 3> vm;
    int k = 0;
    for (int j = 0; j < 3; ++j)
      if (node.vertices[j] >= 0) vm[k++] = {node.vertices[j], node.multiplicity[j]};
    std::sort(vm.begin(), vm.begin() + k);
    bool ok = k >= 1;
    for (int j = 0; j < k; ++j) ok = ok && vm[j].first < nv && vm[j].second > 0 && (j == 0 || vm[j].first != vm[j - 1].first);
    if (ok && k == 1) {
      point[i] = d.point_of_vertex[vm[0].first], slot[i] = 0;
    } else if (ok) {
      EntityKey key;
      for (int j = 0; j < k; ++j) key.v[j] = vm[j].first;
      const auto it = d.entities.find(key);
      ok = it != d.entities.end() && (k == 2 || (vm[0].second == 1 && vm[1].second == 1 && vm[2].second == 1));
      if (ok) point[i] = it->second, slot[i] = k == 2 ? vm[1].second - 1 : 0;
    }
    if (!ok) {
      error = "plex numbering: node " + std::to_string(i) + " lies on no vertex, edge or face of the rank's mesh "
              "(or has multiplicities beyond degree 3)";
      break;
    }
    const PetscInt nodes_here = k == 2 ? vm[0].second + vm[1].second - 1 : 1;
    PetscInt& c = count[point[i] - p_start];
    if (c != 0 && c != nodes_here) error = "plex numbering: nodes of one edge with different degrees";
    c = nodes_here;
    signed char& f = fixed[point[i] - p_start];
    if (f >= 0 && f != (node.fixed ? 1 : 0)) error = "plex numbering: an entity with fixed and free nodes";
    f = node.fixed ? 1 : 0;
  }
  mpi::agree_on_error(comm_, error, /*input_error=*/true);

  PetscSection local = nullptr, global = nullptr;
  check(PetscSectionCreate(comm_, &local), "PetscSectionCreate");
  check(PetscSectionSetChart(local, p_start, p_end), "PetscSectionSetChart");
  for (PetscInt p = p_start; p < p_end; ++p)
    if (fixed[p - p_start] == 0) check(PetscSectionSetDof(local, p, 3 * count[p - p_start]), "PetscSectionSetDof");
  check(PetscSectionSetUp(local), "PetscSectionSetUp");
  PetscSF sf = nullptr;
  check(DMGetPointSF(d.dm, &sf), "DMGetPointSF");
  check(PetscSectionCreateGlobalSection(local, sf, PETSC_FALSE, PETSC_FALSE, &global),
        "PetscSectionCreateGlobalSection");
  PlexNumbering out;
  PetscInt owned_dofs = 0;
  check(PetscSectionGetConstrainedStorageSize(global, &owned_dofs), "PetscSectionGetConstrainedStorageSize");
  out.owned = static_cast<index_t>(owned_dofs / 3);
  long mine = out.owned, before = 0;
  MPI_Exscan(&mine, &before, 1, MPI_LONG, MPI_SUM, comm_);
  int rank = 0;
  MPI_Comm_rank(comm_, &rank);
  out.first = rank == 0 ? 0 : static_cast<index_t>(before);
  MPI_Allreduce(&mine, &out.total, 1, MPI_LONG, MPI_SUM, comm_);
  out.global.assign(n, -1);
  for (size_t i = 0; i < n; ++i) {
    if (nodes[i].fixed) continue;
    PetscInt off = 0;
    check(PetscSectionGetOffset(global, point[i], &off), "PetscSectionGetOffset");
    if (off < 0) off = -(off + 1);
    out.global[i] = static_cast<index_t>(off / 3 + slot[i]);
  }
  PetscSectionDestroy(&global);
  PetscSectionDestroy(&local);
  return out;
}

}  // namespace pmg::petsc
