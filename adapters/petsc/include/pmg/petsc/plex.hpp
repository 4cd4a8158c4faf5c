// pmg/petsc/plex.hpp — a tetrahedral mesh distributed over MPI ranks by PETSc's DMPlex: created
// from cells handed in by any ranks (typically rank 0 with a coarse mesh), moved to the ranks by a
// partition made elsewhere (METIS's on rank 0) or by PT-Scotch (Pellegrini and Roman 1996)
// through PETSc's partitioner, refined uniformly on every
// rank after distribution (DMRefine: each tetrahedron into 8), and numbered by PetscSections; read
// and written in parallel in PETSc's HDF5 mesh format (load(), save()).
// After distribute() no rank holds more than its own cells and their closure.
//
// The rank's part (local_vertices(), local_cells()): its cells (no overlap) and the vertices of
// their closure, ordered by increasing global vertex number, so that every rank orders the
// vertices of a shared edge or face the same way.
//
// Numbering of higher-order nodes (number()): a node is given by the vertices of the mesh entity
// it lies on (1 to 3 local vertex ids: a vertex, an edge, a face) and its multiplicities (the
// nonzero entries of its Bernstein–Bézier multi-index). Each entity gets one PetscSection dof
// block of 3 unknowns per node; an entity's nodes are ordered along increasing global vertex
// number (the node nearer the lower-numbered vertex first), which every rank computes alike.
// PETSc's point SF decides the owner of a shared entity; the global numbers are contiguous per
// rank (PetscSectionCreateGlobalSection), fixed nodes have none.
//
// Every call is collective over the communicator given at construction.
#pragma once

#include "pmg/sparse/types.hpp"

#include <mpi.h>

#include <array>
#include <memory>
#include <string>
#include <vector>

namespace pmg::petsc {

/// A node to number (see the file comment): the local vertex ids of its entity (-1 padded) and the
/// multiplicity of each (the entries of the multi-index, > 0), and whether it is fixed.
struct PlexNode {
  std::array<index_t, 3> vertices{-1, -1, -1};  ///< 1 to 3 local vertex ids (vertex, edge, face)
  std::array<int, 3> multiplicity{0, 0, 0};     ///< of each vertex, > 0 where a vertex is given
  bool fixed = false;                            ///< fixed nodes get no global number
};

/// The global numbering of a list of nodes (PlexMesh::number()).
struct PlexNumbering {
  /// Global number of each node (-1: fixed); owned nodes have [first, first + owned).
  std::vector<index_t> global;
  index_t first = 0;   ///< the rank's first owned global number
  index_t owned = 0;   ///< nodes the rank owns
  long total = 0;      ///< global nodes (every rank's owned nodes)
};

/// A distributed tetrahedral mesh on DMPlex (see the file comment).
class PlexMesh {
 public:
  /// Builds the mesh from the cells each rank passes: `coordinates` (3 per vertex) are this
  /// rank's consecutive share of the global vertices (rank 0's first), `cells` 4 global vertex ids
  /// per tetrahedron, any orientation. Passing the whole mesh on rank 0 and nothing elsewhere is
  /// the usual call. Collective; throws InputError for ids out of range, Error with PETSc's
  /// message when PETSc fails.
  PlexMesh(MPI_Comm comm, const std::vector<double>& coordinates, const std::vector<index_t>& cells);
  /// Reads a tetrahedral mesh in PETSc's HDF5 format (what save() writes; DMPlex's DMLoad) in
  /// parallel: each rank reads a contiguous share of the cells, no rank the whole mesh;
  /// distribute() then partitions it. Collective; throws InputError for a file that is missing,
  /// unreadable, not a PETSc mesh or not of tetrahedra in 3-D.
  static std::unique_ptr<PlexMesh> load(MPI_Comm comm, const std::string& path);
  /// Writes the mesh (every rank its part, in parallel) in PETSc's HDF5 format to `path` through a
  /// temporary name renamed once complete. Collective; throws InputError when the file cannot be
  /// written.
  void save(const std::string& path) const;
  ~PlexMesh();
  PlexMesh(const PlexMesh&) = delete;
  PlexMesh& operator=(const PlexMesh&) = delete;

  /// Partitions the cells over the ranks ("ptscotch", "parmetis" where PETSc has it, "simple":
  /// contiguous blocks) and moves them. Throws InputError when a rank would hold no cell.
  void distribute(const std::string& partitioner = "ptscotch");
  /// Moves each of the rank's cells (local_cells() order) to the rank `to` names (PETSc's shell
  /// partitioner): a partition made elsewhere, such as METIS's on rank 0, which, unlike
  /// PT-Scotch's parallel algorithms, is the same every run. Collective; throws InputError for a
  /// partition of the wrong size, a rank out of range, or a rank left without cells.
  void distribute(const std::vector<int>& to);
  /// Uniform refinement, `times` times, on every rank (each tetrahedron into 8; new vertices at
  /// edge midpoints).
  void refine(int times);

  /// The communicator.
  MPI_Comm comm() const { return comm_; }
  /// Cells of all ranks.
  long global_cells() const;
  /// Vertices of all ranks.
  long global_vertices() const;
  /// x, y, z of the rank's vertices (its cells' closure, increasing global number).
  const std::vector<double>& local_vertices() const { return vertices_; }
  /// 4 local vertex ids per cell of the rank, positively oriented (det[X1-X0, X2-X0, X3-X0] > 0).
  const std::vector<index_t>& local_cells() const { return cells_; }
  /// Global number of each local vertex.
  const std::vector<long>& global_vertex() const { return global_vertex_; }
  /// Whether the rank owns each local vertex (PETSc's point SF: exactly one rank owns a vertex).
  const std::vector<char>& owns_vertex() const { return owns_vertex_; }

  /// Global numbers of `nodes` (see the file comment): every node of an entity must be listed
  /// alike on every rank holding it. Throws InputError for a node whose vertices name no entity of
  /// the rank's mesh or whose multiplicities do not fit one entity numbering.
  PlexNumbering number(const std::vector<PlexNode>& nodes) const;

 private:
  explicit PlexMesh(MPI_Comm comm);
  void move_cells(const std::string& partitioner, const std::vector<int>* to);
  void extract();
  struct Impl;
  std::unique_ptr<Impl> impl_;
  MPI_Comm comm_;
  std::vector<double> vertices_;
  std::vector<index_t> cells_;
  std::vector<long> global_vertex_;
  std::vector<char> owns_vertex_;
};

}  // namespace pmg::petsc
