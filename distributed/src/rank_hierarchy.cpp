// One rank's share of a degree hierarchy (pmg/distributed/rank_hierarchy.hpp).
#include "pmg/distributed/rank_hierarchy.hpp"

#include "pmg/metis/partition.hpp"
#include "pmg/mpi/agreement.hpp"
#include "pmg/mpi/session.hpp"
#include "pmg/petsc/pcmg.hpp"
#include "pmg/petsc/plex.hpp"

#include <algorithm>
#include <climits>
#include <string>

namespace pmg::dist {

namespace {

/// Rank 0's partition, broadcast; an error on rank 0 reaches every rank as the same InputError.
std::vector<int> partition(const fem::TetMesh& mesh, MPI_Comm comm, int rank, int size) {
  std::vector<int> parts(mesh.tets.size(), 0);
  std::string error;
  if (rank == 0) {
    try {
      parts = metis::partition_elements(mesh.tets, mesh.num_vertices(), size);
    } catch (const std::exception& e) {
      error = e.what();
    }
  }
  int length = static_cast<int>(error.size());
  MPI_Bcast(&length, 1, MPI_INT, 0, comm);
  if (length > 0) {
    error.resize(length);
    MPI_Bcast(error.data(), length, MPI_CHAR, 0, comm);
    throw InputError(error);
  }
  MPI_Bcast(parts.data(), static_cast<int>(parts.size()), MPI_INT, 0, comm);
  return parts;
}

}  // namespace

RankHierarchy::RankHierarchy(const fem::DegreeHierarchy& serial, MPI_Comm comm) : comm_(comm) {
  mpi::start();
  const fem::TetMesh& full = serial.model(0).space().mesh();
  {
    std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
    MPI_Comm_rank(comm, &rank_);
    MPI_Comm_size(comm, &size_);
    parts_ = partition(full, comm, rank_, size_);
  }

  // The rank's sub-mesh: its elements, their vertices in increasing global order.
  std::vector<index_t> local_vertex(full.vertices.size(), -1);
  for (index_t e = 0; e < full.num_tets(); ++e)
    if (parts_[e] == rank_) {
      elements_.push_back(e);
      for (index_t v : full.tets[e]) local_vertex[v] = 0;
    }
  mesh_ = std::make_unique<fem::TetMesh>();
  std::vector<char> clamped, components;
  const std::vector<char>& masks = serial.component_masks();
  for (size_t v = 0; v < full.vertices.size(); ++v)
    if (local_vertex[v] == 0) {
      local_vertex[v] = mesh_->num_vertices();
      mesh_->vertices.push_back(full.vertices[v]);
      clamped.push_back(serial.clamped_vertices()[v]);
      if (!masks.empty()) components.push_back(masks[v]);
    }
  for (index_t e : elements_) {
    fem::Tet t;
    for (int k = 0; k < 4; ++k) t[k] = local_vertex[full.tets[e][k]];
    mesh_->tets.push_back(t);
  }
  local_ = std::make_unique<fem::DegreeHierarchy>(*mesh_, serial.num_levels(), serial.finest().material(),
                                                  std::move(clamped), std::move(components));
  const std::vector<double>& scale = serial.model(0).stiffness_scale();
  if (!scale.empty()) {
    std::vector<double> mine;
    for (index_t e : elements_) mine.push_back(scale[e]);
    local_->set_stiffness_scale(mine);
  }

  // Per level: owners, the global numbering and the map of the rank's nodes.
  levels_.resize(serial.num_levels());
  for (int l = 0; l < serial.num_levels(); ++l) {
    const fem::BBSpace& S = serial.model(l).space();
    const std::vector<index_t>& free = serial.model(l).assembler().free_index();
    const index_t n_free = serial.model(l).assembler().num_free();
    const int n = S.nodes_per_element();
    Level& L = levels_[l];
    L.owner.assign(n_free, INT_MAX);
    for (index_t e = 0; e < full.num_tets(); ++e)
      for (int a = 0; a < n; ++a) {
        const index_t f = free[S.node(e, a)];
        if (f >= 0) L.owner[f] = std::min(L.owner[f], parts_[e]);
      }
    std::vector<index_t> count(size_ + 1, 0);
    for (int o : L.owner) {
      if (o == INT_MAX)  // the same on every rank: every rank walks the whole mesh
        throw InputError("rank hierarchy: a free node no element holds (a vertex outside every element)");
      ++count[o + 1];
    }
    for (int r = 0; r < size_; ++r) count[r + 1] += count[r];
    L.first = count[rank_];
    L.owned = count[rank_ + 1] - count[rank_];
    L.total = count[size_];
    std::vector<index_t> global_of_serial(n_free), next(count.begin(), count.end() - 1);
    L.serial_of_owned.resize(L.owned);
    for (index_t f = 0; f < n_free; ++f) {
      global_of_serial[f] = next[L.owner[f]]++;
      if (L.owner[f] == rank_) L.serial_of_owned[global_of_serial[f] - L.first] = f;
    }
    const fem::BBSpace& Sl = local_->model(l).space();
    const std::vector<index_t>& free_l = local_->model(l).assembler().free_index();
    L.global.assign(local_->model(l).assembler().num_free(), -1);
    for (size_t el = 0; el < elements_.size(); ++el)
      for (int a = 0; a < n; ++a) {
        const index_t fl = free_l[Sl.node(static_cast<index_t>(el), a)];
        const index_t f = free[S.node(elements_[el], a)];
        if ((fl < 0) != (f < 0)) throw Error("rank hierarchy: a node free in one numbering is fixed in the other");
        if (fl >= 0) L.global[fl] = global_of_serial[f];
      }
  }
}

RankHierarchy::RankHierarchy(const petsc::PlexMesh& plex, int degree, const fem::Material& material,
                             std::vector<char> clamped, const std::vector<double>& stiffness_scale,
                             std::vector<char> components)
    : comm_(plex.comm()) {
  {
    std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
    MPI_Comm_rank(comm_, &rank_);
    MPI_Comm_size(comm_, &size_);
  }
  // A flat or inverted cell, or a bad flag count, fails on the rank that holds it: every rank
  // throws it before the numbering's collective calls.
  mpi::together(comm_, [&] {
    mesh_ = std::make_unique<fem::TetMesh>();
    const std::vector<double>& X = plex.local_vertices();
    for (size_t v = 0; v < X.size() / 3; ++v) mesh_->vertices.emplace_back(X[3 * v], X[3 * v + 1], X[3 * v + 2]);
    const std::vector<index_t>& C = plex.local_cells();
    for (size_t e = 0; e < C.size() / 4; ++e) mesh_->tets.push_back({C[4 * e], C[4 * e + 1], C[4 * e + 2], C[4 * e + 3]});
    local_ = std::make_unique<fem::DegreeHierarchy>(*mesh_, degree, material, std::move(clamped), std::move(components));
    if (!stiffness_scale.empty()) local_->set_stiffness_scale(stiffness_scale);
  });

  // Per level: each local free node's entity and multiplicities, numbered by the plex.
  levels_.resize(local_->num_levels());
  for (int l = 0; l < local_->num_levels(); ++l) {
    const fem::BBSpace& S = local_->model(l).space();
    const std::vector<index_t>& free = local_->model(l).assembler().free_index();
    const auto& alpha = fem::multi_indices(S.degree());
    std::vector<petsc::PlexNode> nodes(local_->model(l).assembler().num_free());
    std::vector<char> seen(nodes.size(), 0);
    for (index_t e = 0; e < mesh_->num_tets(); ++e)
      for (int a = 0; a < S.nodes_per_element(); ++a) {
        const index_t f = free[S.node(e, a)];
        if (f < 0 || seen[f]) continue;
        seen[f] = 1;
        int k = 0;
        for (int i = 0; i < 4; ++i)
          if (alpha[a][i] > 0) {
            nodes[f].vertices[k] = mesh_->tets[e][i];
            nodes[f].multiplicity[k++] = alpha[a][i];
          }
      }
    const petsc::PlexNumbering numbering = plex.number(nodes);
    Level& L = levels_[l];
    L.first = numbering.first;
    L.owned = numbering.owned;
    L.total = numbering.total;
    L.global = numbering.global;
  }
}

RankHierarchy::~RankHierarchy() = default;

namespace {
void require_serial(bool from_serial, const char* what) {
  if (!from_serial)
    throw Error(std::string("rank hierarchy: ") + what + " needs the serial hierarchy (this share was built from a "
                "distributed mesh)");
}
}  // namespace

Vector RankHierarchy::owned_part(int level, const Vector& serial) const {
  require_serial(from_serial(), "owned_part");
  const Level& L = levels_.at(level);
  if (serial.size() != 3 * static_cast<Eigen::Index>(L.owner.size()))
    throw InputError("rank hierarchy: a vector of " + std::to_string(serial.size()) + " entries for " +
                     std::to_string(3 * L.owner.size()) + " unknowns");
  Vector out(3 * static_cast<Eigen::Index>(L.owned));
  for (index_t i = 0; i < L.owned; ++i)
    for (int c = 0; c < 3; ++c) out[3 * i + c] = serial[3 * static_cast<Eigen::Index>(L.serial_of_owned[i]) + c];
  return out;
}

Vector RankHierarchy::gather(int level, const Vector& owned) const {
  require_serial(from_serial(), "gather");
  const Level& L = levels_.at(level);
  if (owned.size() != 3 * static_cast<Eigen::Index>(L.owned))
    throw InputError("rank hierarchy: " + std::to_string(owned.size()) + " owned entries for " +
                     std::to_string(3 * L.owned) + " owned unknowns");
  Vector mine = Vector::Zero(3 * static_cast<Eigen::Index>(L.owner.size()));
  for (index_t i = 0; i < L.owned; ++i)
    for (int c = 0; c < 3; ++c) mine[3 * static_cast<Eigen::Index>(L.serial_of_owned[i]) + c] = owned[3 * i + c];
  Vector all(mine.size());
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  MPI_Allreduce(mine.data(), all.data(), static_cast<int>(mine.size()), MPI_DOUBLE, MPI_SUM, comm_);
  return all;
}

Vector RankHierarchy::local_part(const fem::DegreeHierarchy& serial, int level, const Vector& serial_full) const {
  require_serial(from_serial(), "local_part");
  const fem::BBSpace& S = serial.model(level).space();
  const fem::BBSpace& Sl = local_->model(level).space();
  if (serial_full.size() != 3 * static_cast<Eigen::Index>(S.num_nodes()))
    throw InputError("rank hierarchy: a full vector of " + std::to_string(serial_full.size()) + " entries for " +
                     std::to_string(3 * static_cast<long>(S.num_nodes())) + " unknowns");
  Vector out = Vector::Zero(3 * static_cast<Eigen::Index>(Sl.num_nodes()));
  const int n = S.nodes_per_element();
  for (size_t el = 0; el < elements_.size(); ++el)
    for (int a = 0; a < n; ++a)
      out.segment<3>(3 * static_cast<Eigen::Index>(Sl.node(static_cast<index_t>(el), a))) =
          serial_full.segment<3>(3 * static_cast<Eigen::Index>(S.node(elements_[el], a)));
  return out;
}

index_t RankHierarchy::local_element(index_t serial_element) const {
  const auto it = std::lower_bound(elements_.begin(), elements_.end(), serial_element);
  return it != elements_.end() && *it == serial_element ? static_cast<index_t>(it - elements_.begin()) : -1;
}

void RankHierarchy::bring_to(const fem::DegreeHierarchy& serial) {
  require_serial(from_serial(), "bring_to(serial)");
  const int top = serial.num_levels() - 1;
  const fem::Rotations* R = serial.last_rotations(top);
  const auto [mass_weight, stiffness_weight] = serial.last_weights(top);
  if (R) {
    rotations_.resize(elements_.size());
    for (size_t e = 0; e < elements_.size(); ++e) rotations_[e] = (*R)[elements_[e]];
  }
  bring_to(R ? &rotations_ : nullptr, mass_weight, stiffness_weight);
}

void RankHierarchy::bring_to(const fem::Rotations* rotations, double mass_weight, double stiffness_weight) {
  if (rotations && rotations->size() != static_cast<size_t>(mesh_->num_tets()))
    throw InputError("rank hierarchy: " + std::to_string(rotations->size()) + " rotations for " +
                     std::to_string(mesh_->num_tets()) + " elements");
  for (int l = 1; l < num_levels(); ++l) local_->update_matrix_free(l, rotations, mass_weight, stiffness_weight);
  local_->assemble_level(0, rotations, nullptr, mass_weight, stiffness_weight);
}

std::vector<petsc::RankLevel> RankHierarchy::rank_levels() {
  std::vector<petsc::RankLevel> out(num_levels());
  for (int l = 0; l < num_levels(); ++l) {
    petsc::RankLevel& R = out[l];
    R.name = local_->level_name(l);
    R.first = first(l);
    R.owned = owned(l);
    R.global = global(l);
    R.constrained = local_->constrained_dofs(l);
    if (l == 0) {
      R.matrix = &local_->matrix(0);
      R.coordinates = local_->node_coordinates(0);
    } else {
      const fem::ElasticityOperator& op = local_->matrix_free(l);
      R.op = &op;
      R.blocks = &op;
      R.prolongation = &local_->prolongation(l);
    }
  }
  return out;
}

}  // namespace pmg::dist
