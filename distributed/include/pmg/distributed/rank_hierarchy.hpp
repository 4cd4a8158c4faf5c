// pmg/distributed/rank_hierarchy.hpp — one MPI rank's share of a degree hierarchy: the element
// partition, the ownership of every level's nodes, their global numbering, and the rank's own
// hierarchy over its elements, whose matrix-free operators, lowest-level matrix and prolongations
// become the levels of the PETSc p-multigrid (pmg/petsc/pcmg.hpp).
//
// Partition: METIS cuts the element graph (elements sharing a face are neighbours) on rank 0;
// rank 0 broadcasts it. One partition for all degrees.
// Ownership: a node (vertex, edge, face or interior control point) belongs to the lowest rank among
// the ranks whose elements hold it (the rule of MFEM and deal.II); its 3 components go together.
// Global numbering: contiguous per rank (rank 0's owned nodes first), within a rank in the serial
// hierarchy's order of free nodes; fixed nodes are not numbered.
// The rank's hierarchy: the sub-mesh of its elements (vertices renumbered in increasing global
// order), the same degree, material, clamp and per-element stiffness scale; its levels' free nodes
// are the rank's local nodes (owned and ghost).
//
// Two ways to build it. From a serial hierarchy that every rank holds (the replicated set-up of
// petsc-mgpcg on a scene's solver seam). Or from a mesh that DMPlex distributed
// (pmg/petsc/plex.hpp), where no rank holds more than its own cells and their closure: the
// partition is the one the mesh was distributed with, the ownership of a shared node is its mesh
// entity's owner in PETSc's point SF, and the global numbering that of a PetscSection (contiguous
// per rank); the serial-only members (owned_part(), gather(), local_part(), bring_to(serial)) are
// then refused, and element_parts(), elements(), serial_of_owned() and owner_of_serial() are
// empty.
#pragma once

#include "pmg/fem/hierarchy.hpp"

#include <mpi.h>

#include <memory>
#include <vector>

namespace pmg::petsc {
struct RankLevel;
class PlexMesh;
}

namespace pmg::dist {

/// One rank's share of a DegreeHierarchy (see the file comment).
class RankHierarchy {
 public:
  /// Partitions `serial`'s mesh over comm's ranks and builds this rank's share. Collective. Throws
  /// InputError when there are fewer elements than ranks, or a rank would hold no element.
  RankHierarchy(const fem::DegreeHierarchy& serial, MPI_Comm comm);
  /// This rank's share of a distributed mesh (see the file comment): degrees 1 to `degree` on the
  /// rank's cells, `clamped` one flag per local vertex of `mesh` (every rank must flag a shared
  /// vertex alike), the material's stiffness scaled per local cell by `stiffness_scale` (empty:
  /// 1), `components` the components held on their own per local vertex (bits 1, 2, 4; empty:
  /// none; fem::DegreeHierarchy's rule, alike on every rank). Collective; `mesh` may be destroyed
  /// afterwards.
  RankHierarchy(const petsc::PlexMesh& mesh, int degree, const fem::Material& material, std::vector<char> clamped,
                const std::vector<double>& stiffness_scale = {}, std::vector<char> components = {});
  ~RankHierarchy();
  /// Whether the share was built from a serial hierarchy (else from a distributed mesh).
  bool from_serial() const { return !parts_.empty(); }

  /// This rank in the communicator.
  int rank() const { return rank_; }
  /// Ranks of the communicator.
  int size() const { return size_; }
  /// The communicator.
  MPI_Comm comm() const { return comm_; }
  /// Levels (degrees 1 to p).
  int num_levels() const { return local_->num_levels(); }
  /// The part (rank) of every element of the serial mesh.
  const std::vector<int>& element_parts() const { return parts_; }
  /// The serial element of each of the rank's elements, in the rank's order.
  const std::vector<index_t>& elements() const { return elements_; }
  /// The sub-mesh of the rank's elements.
  const fem::TetMesh& mesh() const { return *mesh_; }
  /// The rank's hierarchy over its elements.
  fem::DegreeHierarchy& local() { return *local_; }
  /// The rank's hierarchy over its elements.
  const fem::DegreeHierarchy& local() const { return *local_; }

  /// Global number of the rank's first owned node on a level.
  index_t first(int level) const { return levels_.at(level).first; }
  /// The rank's owned nodes on a level.
  index_t owned(int level) const { return levels_.at(level).owned; }
  /// Nodes the rank's elements touch but another rank owns.
  index_t ghosts(int level) const {
    return static_cast<index_t>(levels_.at(level).global.size()) - owned(level);
  }
  /// Global nodes of a level (every rank's owned nodes).
  index_t global_nodes(int level) const { return levels_.at(level).total; }
  /// Global number of each of the rank's local (free) nodes on a level.
  const std::vector<index_t>& global(int level) const { return levels_.at(level).global; }
  /// The serial hierarchy's free node of each owned node, in global order.
  const std::vector<index_t>& serial_of_owned(int level) const { return levels_.at(level).serial_of_owned; }
  /// The owner of every free node of the serial hierarchy's level, by serial free index.
  const std::vector<int>& owner_of_serial(int level) const { return levels_.at(level).owner; }

  /// The owned unknowns (3 per owned node, global order) of a serial vector over the level's free
  /// nodes.
  Vector owned_part(int level, const Vector& serial) const;
  /// The serial vector from every rank's owned unknowns (collective; every rank gets all of it).
  Vector gather(int level, const Vector& owned) const;

  /// The rank's full vector of a level (3 per node of the rank's sub-mesh space, fixed nodes
  /// included) from the serial hierarchy's full vector of that level: the state every rank holds
  /// at the start, put on the rank's elements.
  Vector local_part(const fem::DegreeHierarchy& serial, int level, const Vector& serial_full) const;
  /// The rank's index of a serial element, -1 when another rank holds it.
  index_t local_element(index_t serial_element) const;

  /// Brings the rank's levels to the serial finest level's last rotations and weights
  /// (DegreeHierarchy::last_rotations(), last_weights()): the matrix-free operators above the
  /// lowest level updated, the lowest level assembled. A time step's per-rank work.
  void bring_to(const fem::DegreeHierarchy& serial);
  /// The same from the rank's own elements' rotations (nullptr: linear elasticity) and weights:
  /// each level's operator mass_weight M + stiffness_weight K. A static solve is (nullptr, 0, 1).
  void bring_to(const fem::Rotations* rotations, double mass_weight, double stiffness_weight);
  /// The levels for pmg::petsc::PMultigridCg: the rank's matrix-free operators above the lowest
  /// level, its lowest-level matrix (as the last bring_to() left it: call it first), coordinates and
  /// prolongations.
  std::vector<petsc::RankLevel> rank_levels();

 private:
  struct Level {
    index_t first = 0, owned = 0, total = 0;
    std::vector<index_t> global;           // per local free node
    std::vector<index_t> serial_of_owned;  // per owned node
    std::vector<int> owner;                // per serial free node
  };
  MPI_Comm comm_;
  int rank_ = 0, size_ = 1;
  std::vector<int> parts_;
  std::vector<index_t> elements_;
  std::unique_ptr<fem::TetMesh> mesh_;
  std::unique_ptr<fem::DegreeHierarchy> local_;
  std::vector<Level> levels_;
  fem::Rotations rotations_;  // the rank's elements' rotations (bring_to)
};

}  // namespace pmg::dist
