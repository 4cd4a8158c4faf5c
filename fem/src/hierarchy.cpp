#include "pmg/fem/hierarchy.hpp"

#include <algorithm>
#include <chrono>
#include <map>

namespace pmg::fem {

namespace {

void check_pair(const BBSpace& fine, const BBSpace& coarse) {
  if (&fine.mesh() != &coarse.mesh() || fine.degree() != coarse.degree() + 1)
    throw InputError("degree transfer: spaces must share the mesh and differ by one degree");
}

/// Collects (row, col, weight) entries that several elements may set identically.
Csr from_entries(index_t rows, index_t cols, const std::map<std::pair<index_t, index_t>, double>& e) {
  std::vector<Triplet> t;
  t.reserve(e.size());
  for (const auto& [ij, w] : e) t.emplace_back(ij.first, ij.second, w);
  return Csr::from_triplets(rows, cols, t);
}

index_t count_free(const std::vector<index_t>& f) {
  index_t n = 0;
  for (index_t i : f) n = std::max(n, i + 1);
  return n;
}

}  // namespace

Csr degree_elevation(const BBSpace& fine, const std::vector<index_t>& fine_free,
                     const BBSpace& coarse, const std::vector<index_t>& coarse_free) {
  check_pair(fine, coarse);
  const int p = fine.degree();
  const auto& alpha = multi_indices(p);
  // A fine node's row reads only its own entity's closure: any element holding the node gives the
  // whole row, so each row is written once, from the first element that meets it.
  const index_t rows = count_free(fine_free);
  std::vector<char> done(rows, 0);
  std::vector<Triplet> t;
  t.reserve(4 * static_cast<size_t>(rows));
  for (index_t e = 0; e < fine.mesh().num_tets(); ++e)
    for (int a = 0; a < fine.nodes_per_element(); ++a) {
      const index_t I = fine_free[fine.node(e, a)];
      if (I < 0 || done[I]) continue;
      done[I] = 1;
      for (int k = 0; k < 4; ++k) {
        if (alpha[a][k] == 0) continue;
        MultiIndex beta = alpha[a];
        --beta[k];
        const index_t J = coarse_free[coarse.node(e, local_index(beta))];
        if (J >= 0) t.emplace_back(I, J, static_cast<double>(alpha[a][k]) / p);
      }
    }
  return Csr::from_triplets(rows, count_free(coarse_free), t);
}

Csr interpolating_restriction(const BBSpace& fine, const std::vector<index_t>& fine_free,
                              const BBSpace& coarse, const std::vector<index_t>& coarse_free) {
  check_pair(fine, coarse);
  const int q = coarse.degree();
  const auto& beta = multi_indices(q);
  std::map<std::pair<index_t, index_t>, double> entries;
  auto fine_node = [&](index_t e, const MultiIndex& a) { return fine_free[fine.node(e, local_index(a))]; };
  for (index_t e = 0; e < fine.mesh().num_tets(); ++e)
    for (int b = 0; b < coarse.nodes_per_element(); ++b) {
      const index_t J = coarse_free[coarse.node(e, b)];
      if (J < 0) continue;
      int support[4], n = 0;
      for (int i = 0; i < 4; ++i)
        if (beta[b][i] > 0) support[n++] = i;
      if (n == 1) {  // vertex: copy
        MultiIndex a{0, 0, 0, 0};
        a[support[0]] = q + 1;
        const index_t I = fine_node(e, a);
        if (I >= 0) entries[{J, I}] = 1.0;
      } else if (n == 2 && q == 2) {  // quadratic edge node from the cubic edge
        const int i = support[0], j = support[1];
        const int w[4][2] = {{3, 0}, {2, 1}, {1, 2}, {0, 3}};
        const double weight[4] = {-0.25, 0.75, 0.75, -0.25};
        for (int m = 0; m < 4; ++m) {
          MultiIndex a{0, 0, 0, 0};
          a[i] = w[m][0];
          a[j] = w[m][1];
          const index_t I = fine_node(e, a);
          if (I >= 0) entries[{J, I}] = weight[m];
        }
      } else {
        throw InputError("interpolating restriction: only cubic->quadratic and quadratic->linear");
      }
    }
  return from_entries(count_free(coarse_free), count_free(fine_free), entries);
}

DegreeHierarchy::DegreeHierarchy(const TetMesh& mesh, int degree, const Material& material,
                                 const std::function<bool(const Vec3&)>& fixed, std::vector<char> components)
    : DegreeHierarchy(mesh, degree, material, [&] {
        std::vector<char> clamped(mesh.vertices.size());
        for (size_t v = 0; v < mesh.vertices.size(); ++v) clamped[v] = fixed(mesh.vertices[v]) ? 1 : 0;
        return clamped;
      }(), std::move(components)) {}

DegreeHierarchy::DegreeHierarchy(const TetMesh& mesh, int degree, const Material& material,
                                 std::vector<char> clamped, std::vector<char> components)
    : clamped_(std::move(clamped)), components_(std::move(components)) {
  if (clamped_.size() != mesh.vertices.size())
    throw InputError("hierarchy: " + std::to_string(clamped_.size()) + " clamp flags for " +
                     std::to_string(mesh.vertices.size()) + " vertices");
  for (int p = 1; p <= degree; ++p) {
    // The degrees share the mesh's rest geometry (computed once, by the first).
    models_.push_back(models_.empty() ? std::make_unique<ElasticityModel>(mesh, p, material)
                                      : std::make_unique<ElasticityModel>(mesh, p, material,
                                                                          models_.front()->shared_geometry()));
    models_.back()->fix_vertices(clamped_);
    if (!components_.empty()) models_.back()->constrain_components(components_);
    matrices_.emplace_back();
  }
  state_.resize(models_.size());
  operators_.resize(models_.size());
  for (int l = 1; l < num_levels(); ++l)
    prolongations_.push_back(degree_elevation(models_[l]->space(), models_[l]->assembler().free_index(),
                                              models_[l - 1]->space(),
                                              models_[l - 1]->assembler().free_index()));
}

Csr DegreeHierarchy::interpolating_restriction(int level) const {
  return fem::interpolating_restriction(models_[level]->space(), models_[level]->assembler().free_index(),
                                        models_[level - 1]->space(),
                                        models_[level - 1]->assembler().free_index());
}

void DegreeHierarchy::assemble(const Rotations* R, Vector* rhs, double mass_weight,
                               double stiffness_weight) {
  for (int l = 0; l < num_levels(); ++l)
    assemble_level(l, R, l == num_levels() - 1 ? rhs : nullptr, mass_weight, stiffness_weight);
}

const Bcsr& DegreeHierarchy::mass(int l) {
  if (l < 0 || l >= num_levels()) throw InputError("hierarchy: no level " + std::to_string(l));
  if (masses_.size() != models_.size()) masses_.resize(models_.size());
  if (masses_[l].values().empty()) {
    masses_[l] = models_[l]->assembler().make_matrix();
    models_[l]->assemble_mass(masses_[l]);
  }
  return masses_[l];
}

void DegreeHierarchy::assemble_level(int l, const Rotations* R, Vector* rhs, double mass_weight,
                                     double stiffness_weight) {
  Vector correction;
  if (rhs) correction = Vector::Zero(rhs->size());
  const Vector none;
  ElasticityModel::ElementPass pass;
  pass.R = R;
  pass.rhs = rhs ? &correction : nullptr;
  pass.prescribed = &none;
  assemble_level(l, pass, mass_weight, stiffness_weight);
  if (rhs) *rhs += stiffness_weight * correction;
}

void DegreeHierarchy::assemble_level(int l, const Rotations* R, double mass_weight,
                                     double stiffness_weight, const Vector& u, Vector* force,
                                     double* energy) {
  ElasticityModel::ElementPass pass;
  pass.u = &u;
  pass.R = R;
  pass.force = force;
  pass.energy = energy;
  assemble_level(l, pass, mass_weight, stiffness_weight);
}

void DegreeHierarchy::assemble_level(int l, ElasticityModel::ElementPass pass, double mass_weight,
                                     double stiffness_weight) {
  if (l < 0 || l >= num_levels()) throw InputError("hierarchy: no level " + std::to_string(l));
  // mass_weight M written first, stiffness_weight K_R added during the element pass: the matrix
  // is swept once more, not three times (zero, scatter, combine).
  std::vector<double>& a = matrix_storage(l).values();
  if (mass_weight != 0.0) {
    const std::vector<double>& m = mass(l).values();
#pragma omp parallel for schedule(static)
    for (size_t k = 0; k < a.size(); ++k) a[k] = mass_weight * m[k];
  }
  pass.stiffness = &matrices_[l];
  pass.stiffness_weight = stiffness_weight;
  pass.add_to_stiffness = mass_weight != 0.0;
  models_[l]->evaluate(pass);
  record(l, pass.R, mass_weight, stiffness_weight);
}

const Csr& DegreeHierarchy::prolongation(int level) const {
  if (level < 1 || level >= num_levels())
    throw InputError("hierarchy: no prolongation into level " + std::to_string(level) + " (levels 1 to " +
                     std::to_string(num_levels() - 1) + " have one)");
  return prolongations_[level - 1];
}

Bcsr& DegreeHierarchy::matrix_storage(int l) const {
  if (l < 0 || l >= num_levels()) throw InputError("hierarchy: no level " + std::to_string(l));
  Bcsr& A = matrices_[l];
  if (A.values().empty()) A = models_[l]->assembler().make_matrix();
  return A;
}

void DegreeHierarchy::record(int l, const Rotations* R, double mass_weight, double stiffness_weight) {
  LevelState& s = state_[l];
  s.rotated = R != nullptr;
  if (R && R != &rotations_) rotations_ = *R;
  s.mass_weight = mass_weight;
  s.stiffness_weight = stiffness_weight;
  if (auto& op = operators_[l]) {
    op->update(R ? &rotations_ : nullptr);
    op->set_weights(mass_weight, stiffness_weight);
  }
}

const LinearOperator* DegreeHierarchy::matrix_free_operator(int l) const {
  if (l < 0 || l >= num_levels()) throw InputError("hierarchy: no level " + std::to_string(l));
  if (l == 0) return nullptr;
  return &matrix_free(l);
}

const std::vector<std::vector<index_t>>* DegreeHierarchy::vertex_patches(int l) const {
  if (l < 0 || l >= num_levels()) throw InputError("hierarchy: no level " + std::to_string(l));
  if (l == 0) return nullptr;
  if (patches_.size() != models_.size()) patches_.resize(models_.size());
  std::vector<std::vector<index_t>>& patches = patches_[l];
  if (!patches.empty()) return &patches;
  const ElasticityModel& model = *models_[l];
  const BBSpace& space = model.space();
  const std::vector<index_t>& free = model.assembler().free_index();
  const std::vector<MultiIndex>& alpha = multi_indices(space.degree());
  const int n = space.nodes_per_element();
  const TetMesh& mesh = space.mesh();
  // Node a of an element lies on the sub-simplex of its multi-index's nonzero entries, which holds
  // local vertex i exactly when alpha_a[i] > 0: the element's share of vertex i's open star.
  std::vector<std::vector<index_t>> star(mesh.vertices.size());
  for (index_t e = 0; e < mesh.num_tets(); ++e) {
    const index_t* nodes = space.element_nodes(e);
    for (int i = 0; i < 4; ++i) {
      std::vector<index_t>& s = star[mesh.tets[e][i]];
      for (int a = 0; a < n; ++a)
        if (alpha[a][i] > 0 && free[nodes[a]] >= 0) s.push_back(free[nodes[a]]);
    }
  }
  for (std::vector<index_t>& s : star) {
    if (s.empty()) continue;
    std::sort(s.begin(), s.end());
    s.erase(std::unique(s.begin(), s.end()), s.end());
    patches.push_back(std::move(s));
  }
  return &patches;
}

const ElasticityOperator& DegreeHierarchy::matrix_free(int l) const {
  if (l < 1 || l >= num_levels())
    throw InputError("hierarchy: no matrix-free operator on level " + std::to_string(l));
  auto& op = operators_[l];
  if (!op) {
    op = std::make_unique<ElasticityOperator>(*models_[l]);
    const LevelState& s = state_[l];
    if (s.rotated) op->update(&rotations_);
    op->set_weights(s.mass_weight, s.stiffness_weight);
  }
  return *op;
}

void DegreeHierarchy::update_matrix_free(int l, const Rotations* R, double mass_weight,
                                         double stiffness_weight) {
  matrix_free(l);  // built if needed
  record(l, R, mass_weight, stiffness_weight);
}

BoundSystem DegreeHierarchy::bind(Solver& solver) { return BoundSystem(*this, solver); }

}  // namespace pmg::fem

namespace pmg::fem {

void DegreeHierarchy::set_refinements(const std::vector<Refinement>& refinements) {
  below_ = refinements.empty() ? nullptr : std::make_shared<const CoarseMeshLevels>(*this, refinements);
}

std::shared_ptr<const LevelProvider> DegreeHierarchy::levels_below() const { return below_; }

CoarseMeshLevels::CoarseMeshLevels(const DegreeHierarchy& hierarchy, const std::vector<Refinement>& refinements)
    : hierarchy_(hierarchy) {
  const index_t V = hierarchy.model(0).space().mesh().num_vertices();
  const int K = static_cast<int>(refinements.size());
  for (int r = 0; r < K; ++r) {
    const Refinement& ref = refinements[r];
    const index_t next = r + 1 < K ? refinements[r + 1].coarse_vertices : V;
    if (ref.fine_vertices() != next)
      throw InputError("coarse meshes: refinement " + std::to_string(r + 1) + " of " + std::to_string(K) + " makes " +
                       std::to_string(ref.fine_vertices()) + " vertices, but the " +
                       (r + 1 < K ? "next refinement starts from " : "hierarchy's mesh has ") + std::to_string(next));
    for (const auto& [a, b] : ref.midpoints)
      if (a < 0 || b < 0 || a >= ref.coarse_vertices || b >= ref.coarse_vertices || a == b)
        throw InputError("coarse meshes: refinement " + std::to_string(r + 1) + " halves an edge (" + std::to_string(a) +
                         ", " + std::to_string(b) + ") that is not one of its " +
                         std::to_string(ref.coarse_vertices) + " coarse vertices'");
  }
  // Node numbers per level, by vertex: the top level's are the linear level's own; below it, the
  // vertices it leaves free, in vertex order.
  const std::vector<index_t>& top = hierarchy.model(0).assembler().free_index();
  std::vector<std::vector<index_t>> node(K + 1);
  node[K] = top;
  vertex_of_.resize(K);
  empty_.resize(K);
  for (int l = 0; l < K; ++l) {
    node[l].assign(refinements[l].coarse_vertices, -1);
    for (index_t v = 0; v < refinements[l].coarse_vertices; ++v)
      if (top[v] >= 0) {
        node[l][v] = static_cast<index_t>(vertex_of_[l].size());
        vertex_of_[l].push_back(v);
      }
    auto pattern = std::make_shared<BlockPattern>();
    pattern->rows = pattern->cols = static_cast<index_t>(vertex_of_[l].size());
    pattern->row_ptr.assign(vertex_of_[l].size() + 1, 0);
    empty_[l] = Bcsr(pattern, {});
  }
  for (int l = 1; l <= K; ++l) {
    const Refinement& ref = refinements[l - 1];
    const std::vector<index_t>& fine = node[l];
    const std::vector<index_t>& coarse = node[l - 1];
    std::vector<Triplet> t;
    for (index_t v = 0; v < ref.fine_vertices(); ++v) {
      const index_t I = fine[v];
      if (I < 0) continue;
      if (v < ref.coarse_vertices) {
        t.emplace_back(I, coarse[v], 1.0);
      } else {
        for (index_t parent : ref.midpoints[v - ref.coarse_vertices])
          if (coarse[parent] >= 0) t.emplace_back(I, coarse[parent], 0.5);
      }
    }
    const index_t rows = l == K ? hierarchy.model(0).assembler().num_free() : static_cast<index_t>(vertex_of_[l].size());
    prolongations_.push_back(Csr::from_triplets(rows, static_cast<index_t>(vertex_of_[l - 1].size()), t));
  }
}

const Bcsr& CoarseMeshLevels::matrix(int level) const {
  if (level == num_levels() - 1) return hierarchy_.matrix(0);
  return empty_.at(level);
}

std::vector<double> CoarseMeshLevels::node_coordinates(int level) const {
  if (level == num_levels() - 1) return hierarchy_.node_coordinates(0);
  const std::vector<Vec3>& X = hierarchy_.model(0).space().mesh().vertices;
  std::vector<double> xyz;
  xyz.reserve(3 * vertex_of_.at(level).size());
  for (index_t v : vertex_of_[level]) xyz.insert(xyz.end(), {X[v].x(), X[v].y(), X[v].z()});
  return xyz;
}

const std::vector<char>* CoarseMeshLevels::constrained_dofs(int level) const {
  return level == num_levels() - 1 ? hierarchy_.constrained_dofs(0) : nullptr;
}

std::string CoarseMeshLevels::level_name(int level) const {
  const int coarser = num_levels() - 1 - level;
  return coarser == 0 ? hierarchy_.level_name(0) : "degree 1, mesh coarser by " + std::to_string(coarser);
}

}  // namespace pmg::fem
