#include "pmg/fem/elasticity.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <string>

namespace pmg::fem {

void Material::check() const {
  if (!std::isfinite(young) || !(young > 0))
    throw InputError("material: Young's modulus must be a positive number, got " + std::to_string(young));
  if (!std::isfinite(poisson) || !(poisson > -1.0 && poisson < 0.5))
    throw InputError("material: Poisson's ratio must lie in (-1, 0.5), got " + std::to_string(poisson) +
                     (poisson == 0.5 ? " (an incompressible material needs the mixed displacement-pressure "
                                       "formulation: fem::MixedElasticity, pmg compare --formulation mixed)"
                                     : ""));
  if (!std::isfinite(density) || density < 0)
    throw InputError("material: density must be >= 0, got " + std::to_string(density));
}

Mat3 polar_rotation(const Mat3& F) {
  Eigen::JacobiSVD<Mat3> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 U = svd.matrixU();
  const Mat3 V = svd.matrixV();
  if ((U * V.transpose()).determinant() < 0) U.col(2) = -U.col(2);  // smallest singular value last
  return U * V.transpose();
}

namespace {
/// Every element's rest geometry, on the threads; MeshError names the first bad element.
std::shared_ptr<const std::vector<ElementGeometry>> rest_geometry(const TetMesh& mesh) {
  auto geometry = std::make_shared<std::vector<ElementGeometry>>(mesh.num_tets());
  constexpr std::int64_t none = std::numeric_limits<std::int64_t>::max();
  std::int64_t first_bad = none;
#pragma omp parallel for schedule(static) reduction(min : first_bad)
  for (index_t e = 0; e < mesh.num_tets(); ++e) {
    const Tet& t = mesh.tets[e];
    try {
      (*geometry)[e] = element_geometry(mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]],
                                        mesh.vertices[t[3]]);
    } catch (const MeshError&) {
      first_bad = std::min<std::int64_t>(first_bad, e);
    }
  }
  if (first_bad != none) {  // again, alone, for its message
    const Tet& t = mesh.tets[first_bad];
    try {
      element_geometry(mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]], mesh.vertices[t[3]]);
    } catch (const MeshError& err) {
      throw MeshError("element " + std::to_string(first_bad) + ": " + err.what());
    }
  }
  return geometry;
}
}  // namespace

ElasticityModel::ElasticityModel(const TetMesh& mesh, int degree, const Material& material)
    : ElasticityModel(mesh, degree, material, nullptr) {}

ElasticityModel::ElasticityModel(const TetMesh& mesh, int degree, const Material& material,
                                 std::shared_ptr<const std::vector<ElementGeometry>> geometry)
    : mesh_(mesh), space_(mesh, degree), material_(material), tables_(element_tables(degree)) {
  material_.check();
  if (geometry && static_cast<index_t>(geometry->size()) != mesh.num_tets())
    throw InputError("ElasticityModel: a shared geometry of " + std::to_string(geometry->size()) +
                     " elements for a mesh of " + std::to_string(mesh.num_tets()));
  geometry_ = geometry ? std::move(geometry) : rest_geometry(mesh);
  fixed_.assign(space_.num_nodes(), 0);
}

void ElasticityModel::fix_where(const std::function<bool(const Vec3&)>& predicate) {
  if (assembler_) throw Error("fix_where after the first assembly: the pattern is already built");
  for (index_t i = 0; i < space_.num_nodes(); ++i)
    if (predicate(space_.positions()[i])) fixed_[i] = 1;
}

void ElasticityModel::fix_nodes(const std::vector<index_t>& nodes) {
  if (assembler_) throw Error("fix_nodes after the first assembly: the pattern is already built");
  for (index_t i : nodes) {
    if (i < 0 || i >= space_.num_nodes()) throw InputError("fix_nodes: node " + std::to_string(i) + " does not exist");
    fixed_[i] = 1;
  }
}

void ElasticityModel::fix_vertices(const std::vector<char>& clamped) {
  if (assembler_) throw Error("fix_vertices after the first assembly: the pattern is already built");
  if (clamped.size() != mesh_.vertices.size())
    throw InputError("fix_vertices: " + std::to_string(clamped.size()) + " flags for " +
                     std::to_string(mesh_.vertices.size()) + " vertices");
  const auto& alpha = multi_indices(space_.degree());
  for (index_t e = 0; e < mesh_.num_tets(); ++e) {
    const Tet& t = mesh_.tets[e];
    for (int a = 0; a < space_.nodes_per_element(); ++a) {
      bool all = true;
      for (int i = 0; i < 4; ++i) all = all && (alpha[a][i] == 0 || clamped[t[i]]);
      if (all) fixed_[space_.node(e, a)] = 1;
    }
  }
}

void ElasticityModel::constrain_components(const std::vector<char>& masks) {
  if (assembler_) throw Error("constrain_components after the first assembly: the pattern is already built");
  if (masks.size() != mesh_.vertices.size())
    throw InputError("constrain_components: " + std::to_string(masks.size()) + " masks for " +
                     std::to_string(mesh_.vertices.size()) + " vertices");
  for (size_t v = 0; v < masks.size(); ++v)
    if (masks[v] < 0 || masks[v] > 7)
      throw InputError("constrain_components: vertex " + std::to_string(v) + " has mask " +
                       std::to_string(int(masks[v])) + " (bits 1, 2, 4 for x, y, z)");
  if (components_.empty()) components_.assign(space_.num_nodes(), 0);
  const auto& alpha = multi_indices(space_.degree());
  for (index_t e = 0; e < mesh_.num_tets(); ++e) {
    const Tet& t = mesh_.tets[e];
    for (int a = 0; a < space_.nodes_per_element(); ++a) {
      int bits = 7;
      for (int i = 0; i < 4; ++i)
        if (alpha[a][i] != 0) bits &= masks[t[i]];
      const index_t node = space_.node(e, a);
      components_[node] = static_cast<char>(components_[node] | bits);
      if (components_[node] == 7) fixed_[node] = 1;
    }
  }
}

const std::vector<char>& ElasticityModel::constrained_free_dofs() const {
  assembler();  // builds the list with the free numbering
  return constrained_free_;
}

void ElasticityModel::constrain(Bcsr& A) const {
  const std::vector<char>& c = constrained_free_dofs();
  if (c.empty()) return;
  if (3 * static_cast<size_t>(A.block_rows()) != c.size())
    throw InputError("constrain: the matrix has " + std::to_string(A.block_rows()) + " block rows, the model " +
                     std::to_string(c.size() / 3) + " free nodes");
  const BlockPattern& p = A.pattern();
  for (index_t I = 0; I < p.rows; ++I)
    for (offset_t k = p.row_ptr[I]; k < p.row_ptr[I + 1]; ++k) {
      const index_t J = p.col_idx[k];
      auto blk = A.block(k);
      for (int r = 0; r < 3; ++r)
        for (int s = 0; s < 3; ++s)
          if (c[3 * I + r] || c[3 * J + s]) blk(r, s) = (I == J && r == s) ? 1.0 : 0.0;
    }
}

void ElasticityModel::constrain(Vector& reduced) const {
  const std::vector<char>& c = constrained_free_dofs();
  if (!c.empty() && static_cast<size_t>(reduced.size()) != c.size())
    throw InputError("constrain: the vector has " + std::to_string(reduced.size()) + " entries, the model " +
                     std::to_string(c.size()) + " free dofs");
  for (size_t i = 0; i < c.size(); ++i)
    if (c[i]) reduced[static_cast<Eigen::Index>(i)] = 0.0;
}

int clamped_dimension(const TetMesh& mesh, const std::vector<char>& clamped) {
  std::vector<Vec3> X;
  for (size_t v = 0; v < clamped.size() && v < mesh.vertices.size(); ++v)
    if (clamped[v]) X.push_back(mesh.vertices[v]);
  if (X.empty()) return -1;
  Vec3 c = Vec3::Zero();
  for (const auto& x : X) c += x;
  c /= static_cast<double>(X.size());
  Mat3 C = Mat3::Zero();
  double scale = 0;
  for (const auto& x : X) C += (x - c) * (x - c).transpose();
  for (const auto& v : mesh.vertices) scale = std::max(scale, (v - c).squaredNorm());
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(C);
  int dim = 0;
  for (int i = 0; i < 3; ++i) dim += eig.eigenvalues()[i] > 1e-12 * scale ? 1 : 0;
  return dim;
}

index_t ElasticityModel::num_fixed() const {
  index_t n = 0;
  for (char f : fixed_) n += f;
  return n;
}

const BlockAssembler& ElasticityModel::assembler() const {
  if (!assembler_) {
    std::vector<index_t> free_index(space_.num_nodes(), -1);
    index_t next = 0;
    for (index_t i = 0; i < space_.num_nodes(); ++i)
      if (!fixed_[i]) free_index[i] = next++;
    constrained_free_.clear();
    bool any = false;
    for (index_t i = 0; i < space_.num_nodes() && !components_.empty(); ++i)
      any = any || (free_index[i] >= 0 && components_[i] != 0);
    if (any) {
      constrained_free_.assign(3 * static_cast<size_t>(next), 0);
      for (index_t i = 0; i < space_.num_nodes(); ++i)
        if (free_index[i] >= 0)
          for (int c = 0; c < 3; ++c) constrained_free_[3 * free_index[i] + c] = (components_[i] >> c) & 1;
    }
    assembler_ = std::make_unique<BlockAssembler>(space_, std::move(free_index));
  }
  return *assembler_;
}

Vector ElasticityModel::restrict_to_free(const Vector& full) const {
  const auto& fi = assembler().free_index();
  Vector r(num_free_dofs());
  for (index_t i = 0; i < space_.num_nodes(); ++i)
    if (fi[i] >= 0) r.segment<3>(3 * fi[i]) = full.segment<3>(3 * i);
  constrain(r);
  return r;
}

Vector ElasticityModel::free_positions() const {
  const auto& fi = assembler().free_index();
  Vector r(num_free_dofs());
  for (index_t i = 0; i < space_.num_nodes(); ++i)
    if (fi[i] >= 0) r.segment<3>(3 * fi[i]) = space_.positions()[i];
  return r;
}

Vector ElasticityModel::expand(const Vector& free, const Vector& prescribed) const {
  const auto& fi = assembler().free_index();
  Vector u = Vector::Zero(num_dofs());
  for (index_t i = 0; i < space_.num_nodes(); ++i) {
    if (fi[i] >= 0) u.segment<3>(3 * i) = free.segment<3>(3 * fi[i]);
    else if (prescribed.size()) u.segment<3>(3 * i) = prescribed.segment<3>(3 * i);
  }
  return u;
}

Rotations ElasticityModel::rotations(const Vector& u) const {
  Rotations R(mesh_.num_tets());
#pragma omp parallel for schedule(static)
  for (index_t e = 0; e < mesh_.num_tets(); ++e) {
    const Tet& t = mesh_.tets[e];
    Mat3 F = Mat3::Zero();
    for (int i = 0; i < 4; ++i)
      F += (mesh_.vertices[t[i]] + u.segment<3>(3 * t[i])) * (*geometry_)[e].grad.row(i);
    R[e] = polar_rotation(F);
  }
  return R;
}

void ElasticityModel::set_stiffness_scale(std::vector<double> scale) {
  if (!scale.empty() && scale.size() != static_cast<size_t>(mesh_.num_tets()))
    throw InputError("stiffness scale: " + std::to_string(scale.size()) + " factors for " +
                     std::to_string(mesh_.num_tets()) + " elements");
  for (size_t e = 0; e < scale.size(); ++e)
    if (!std::isfinite(scale[e]) || !(scale[e] > 0))
      throw InputError("stiffness scale: element " + std::to_string(e) + " has factor " +
                       std::to_string(scale[e]) + " (must be positive)");
  stiffness_scale_ = std::move(scale);
}

namespace {
/// Assembly writes blocks by the assembler's pattern: the matrix must share it (make_matrix() and
/// copies of its matrices do) or hold an equal one. Builds the pattern on first use.
void check_pattern(const BlockAssembler& as, const Bcsr& K, const char* who) {
  const BlockPattern* p = K.shared_pattern().get();
  const BlockPattern& q = *as.pattern();
  if (!p || (p != &q && (p->row_ptr != q.row_ptr || p->col_idx != q.col_idx)))
    throw InputError(std::string(who) +
                     ": matrix does not have the assembler's pattern (make it with assembler().make_matrix())");
}
}  // namespace

void ElasticityModel::evaluate(const ElementPass& pass) const {
  const BlockAssembler& as = assembler();
  if (pass.stiffness) check_pattern(as, *pass.stiffness, "assemble");
  if (pass.R && pass.R->size() != static_cast<size_t>(mesh_.num_tets()))
    throw InputError("assemble: one rotation per element expected");
  if (pass.u && pass.u->size() != num_dofs())
    throw InputError("elastic state: the displacement has " + std::to_string(pass.u->size()) +
                     " entries for " + std::to_string(num_dofs()) + " unknowns");
  if (pass.rhs && pass.rhs->size() != num_free_dofs()) throw InputError("assemble: rhs has the wrong size");
  if (pass.stiffness && !pass.add_to_stiffness)
    std::fill(pass.stiffness->values().begin(), pass.stiffness->values().end(), 0.0);
  const double weight = pass.stiffness_weight;
  if (pass.force) pass.force->setZero(num_dofs());
  const int n = space_.nodes_per_element();
  const auto& fi = as.free_index();
  const auto& X = space_.positions();
  const bool has_prescribed = pass.rhs && pass.prescribed && pass.prescribed->size() == num_dofs() &&
                              pass.prescribed->cwiseAbs().maxCoeff() > 0;
  // The element's state enters only through y = x_e - R X_e (zero at rest for R = I).
  const bool need_y = pass.force || pass.energy || (pass.rhs && pass.R);
  // Degree 1 without the element's state: the 10 blocks a ≤ b in fixed-size storage, no 12x12
  // element matrix.
  const bool direct = tables_.p == 1 && !need_y;
  if (direct && pass.stiffness && !pass.rhs && !pass.force && !pass.energy) return assemble_linear_by_rows(pass);
  if (pass.stiffness || pass.rhs) as.build_slots();
  // Per thread: the element matrix, the element's state and force, and its share of the energy.
  struct Scratch {
    Eigen::MatrixXd Ke;
    Mat3 K1[16];  ///< degree 1 without the state: blocks (a, b), a ≤ b, at 4a + b
    Eigen::VectorXd y, g;
    ElementGeometry geo;
  };
  std::vector<Scratch> scratch(static_cast<size_t>(as.ranges().threads()));
  const double energy = as.ranges().for_each([&](int thread, index_t e, const ElementRanges::Writes& writes, bool) {
    Scratch& sc = scratch[static_cast<size_t>(thread)];
    const index_t* nodes = space_.element_nodes(e);
    // R K_e Rᵀ is the stiffness of the element with rotated gradients ∇λ_k → R ∇λ_k.
    sc.geo = (*geometry_)[e];
    if (pass.R) sc.geo.grad = sc.geo.grad * (*pass.R)[e].transpose();
    const double s = stiffness_scale_.empty() ? 1.0 : stiffness_scale_[e];
    const double lambda = s * material_.lambda(), mu = s * material_.mu();
    if (direct) {
      for (int a = 0; a < 4; ++a)
        for (int b = a; b < 4; ++b) sc.K1[4 * a + b] = linear_element_block(sc.geo, lambda, mu, a, b);
    } else {
      element_stiffness(tables_, sc.geo, lambda, mu, sc.Ke);
    }
    const Eigen::MatrixXd& Ke = sc.Ke;
    // Block (a, b) of the element matrix.
    auto Kab = [&](int a, int b) -> Mat3 {
      if (!direct) return Ke.block<3, 3>(3 * a, 3 * b);
      return a <= b ? sc.K1[4 * a + b] : Mat3(sc.K1[4 * b + a].transpose());
    };
    double element_energy = 0.0;
    if (need_y) {
      sc.y.resize(3 * n);
      for (int a = 0; a < n; ++a) {
        const Vec3& Xa = X[nodes[a]];
        const Vec3 x = pass.u ? Vec3(Xa + pass.u->segment<3>(3 * nodes[a])) : Xa;
        sc.y.segment<3>(3 * a) = pass.R ? Vec3(x - (*pass.R)[e] * Xa) : Vec3(x - Xa);
      }
      sc.g.noalias() = Ke * sc.y;
      element_energy = 0.5 * sc.y.dot(sc.g);
    }
    for (int a = 0; a < n; ++a) {
      const index_t ia = nodes[a];
      if (!writes(ia)) continue;
      if (pass.force) pass.force->segment<3>(3 * ia) -= sc.g.segment<3>(3 * a);
      const index_t I = fi[ia];
      if (I < 0 || !(pass.stiffness || pass.rhs)) continue;
      Vec3 r = Vec3::Zero();
      for (int b = 0; b < n; ++b) {
        const offset_t slot = as.slot(e, a, b);
        if (slot >= 0) {
          if (pass.stiffness) pass.stiffness->block(slot) += weight * Kab(a, b);
        } else if (has_prescribed) {
          r -= Kab(a, b) * pass.prescribed->segment<3>(3 * nodes[b]);
        }
      }
      if (pass.rhs) {
        if (need_y) r -= sc.g.segment<3>(3 * a);
        pass.rhs->segment<3>(3 * I) += r;
      }
    }
    return element_energy;
  });
  if (pass.energy) *pass.energy = energy;
  if (pass.stiffness) constrain(*pass.stiffness);
  if (pass.rhs) constrain(*pass.rhs);
}

void ElasticityModel::assemble_linear_by_rows(const ElementPass& pass) const {
  const BlockAssembler& as = assembler();
  const auto& fi = as.free_index();
  const double weight = pass.stiffness_weight;
  // Degree 1, the matrix only: row by row, each free node's block row from its elements
  // (row_entries(), in element order), so that a row's blocks are written from one thread while
  // they sit in cache; each element's blocks are formed once per node it holds (its geometry
  // read four times instead of its 16 blocks' read-modify-write across the matrix).
  // A block's slot is found among the row's sorted columns (no slot map is built).
  const std::vector<offset_t>& start = as.row_start();
  const std::vector<offset_t>& entries = as.row_entries();
  Bcsr& K = *pass.stiffness;
  const BlockPattern& pattern = *as.pattern();
  const index_t* cols = pattern.col_idx.data();
  const std::ptrdiff_t rows = as.num_free();
  constexpr int n = 4;  // degree 1: entries are e n + a
#pragma omp parallel for schedule(dynamic, 512)
  for (std::ptrdiff_t I = 0; I < rows; ++I) {
    const index_t* first = cols + pattern.row_ptr[I];
    const index_t* last = cols + pattern.row_ptr[I + 1];
    for (offset_t q = start[I]; q < start[I + 1]; ++q) {
      const index_t e = static_cast<index_t>(entries[q] / n);
      const int a = static_cast<int>(entries[q] % n);
      const index_t* nodes = space_.element_nodes(e);
      ElementGeometry geo = (*geometry_)[e];
      if (pass.R) geo.grad = geo.grad * (*pass.R)[e].transpose();
      const double s = stiffness_scale_.empty() ? 1.0 : stiffness_scale_[e];
      const double lambda = s * material_.lambda(), mu = s * material_.mu();
      for (int b = 0; b < n; ++b) {
        const index_t J = fi[nodes[b]];
        if (J < 0) continue;
        const offset_t slot = std::lower_bound(first, last, J) - cols;
        K.block(slot) += weight * (a <= b ? linear_element_block(geo, lambda, mu, a, b)
                                          : Mat3(linear_element_block(geo, lambda, mu, b, a).transpose()));
      }
    }
  }
  constrain(K);
}

void ElasticityModel::assemble(const Rotations* R, const Vector& prescribed, Bcsr& K,
                               Vector* rhs) const {
  // rhs -= K_fd u_d + Σ_e R K_e (Rᵀ X_e - X_e): the rest state's force is -Σ_e K_R,e (X_e - R X_e).
  ElementPass pass;
  pass.R = R;
  pass.stiffness = &K;
  pass.rhs = rhs;
  pass.prescribed = &prescribed;
  evaluate(pass);
}

Vector ElasticityModel::elastic_force(const Vector& u, const Rotations* R) const {
  Vector f;
  ElementPass pass;
  pass.u = &u;
  pass.R = R;
  pass.force = &f;
  evaluate(pass);
  return f;
}

double ElasticityModel::elastic_energy(const Vector& u, const Rotations* R) const {
  double energy = 0.0;
  ElementPass pass;
  pass.u = &u;
  pass.R = R;
  pass.energy = &energy;
  evaluate(pass);
  return energy;
}

void ElasticityModel::assemble_mass(Bcsr& M) const {
  const BlockAssembler& as = assembler();
  check_pattern(as, M, "assemble_mass");
  as.build_slots();
  std::fill(M.values().begin(), M.values().end(), 0.0);
  const int n = space_.nodes_per_element();
  as.ranges().for_each([&](int, index_t e, const ElementRanges::Writes& writes, bool) {
    const double scale = material_.density * 6.0 * (*geometry_)[e].volume;
    const index_t* nodes = space_.element_nodes(e);
    for (int a = 0; a < n; ++a) {
      if (!writes(nodes[a])) continue;
      for (int b = 0; b < n; ++b) {
        const offset_t s = as.slot(e, a, b);
        if (s < 0) continue;
        const double m = scale * tables_.mass(a, b);
        auto blk = M.block(s);
        blk(0, 0) += m;
        blk(1, 1) += m;
        blk(2, 2) += m;
      }
    }
    return 0.0;
  });
  constrain(M);
}

Vector ElasticityModel::lumped_mass() const {
  Vector m = Vector::Zero(space_.num_nodes());
  for (index_t e = 0; e < mesh_.num_tets(); ++e) {
    const double me = material_.density * 6.0 * (*geometry_)[e].volume * tables_.load;
    for (int a = 0; a < space_.nodes_per_element(); ++a) m[space_.node(e, a)] += me;
  }
  return m;
}

Vector ElasticityModel::gravity(const Vec3& g) const {
  Vector f = Vector::Zero(num_dofs());
  const int n = space_.nodes_per_element();
  for (index_t e = 0; e < mesh_.num_tets(); ++e) {
    const Vec3 fa = material_.density * 6.0 * (*geometry_)[e].volume * tables_.load * g;
    for (int a = 0; a < n; ++a) f.segment<3>(3 * space_.node(e, a)) += fa;
  }
  return f;
}

std::pair<index_t, Eigen::Vector4d> ElasticityModel::locate(const Vec3& X) const {
  const double tol = 1e-10;
  index_t best = -1;
  double best_min = -1e300;
  Eigen::Vector4d best_l;
  for (index_t e = 0; e < mesh_.num_tets(); ++e) {
    const Eigen::Vector4d l = barycentric((*geometry_)[e], mesh_.vertices[mesh_.tets[e][0]], X);
    if (l.minCoeff() > best_min) {
      best_min = l.minCoeff();
      best = e;
      best_l = l;
    }
  }
  if (best < 0 || best_min < -tol)
    throw InputError("point (" + std::to_string(X.x()) + ", " + std::to_string(X.y()) + ", " +
                     std::to_string(X.z()) + ") lies outside the mesh");
  return {best, best_l};
}

void ElasticityModel::add_point_force(Vector& f, const Vec3& x, const Vec3& F) const {
  const auto [e, l] = locate(x);
  const auto& alpha = multi_indices(space_.degree());
  for (int a = 0; a < space_.nodes_per_element(); ++a)
    f.segment<3>(3 * space_.node(e, a)) += bernstein(alpha[a], l) * F;
}

double ElasticityModel::add_traction(Vector& f, const std::function<bool(const Vec3&)>& on_face,
                                     const Vec3& t) const {
  // Boundary faces: faces of exactly one element. Key: sorted vertex ids -> (element, opposite).
  std::map<std::array<index_t, 3>, std::pair<index_t, int>> once;
  std::map<std::array<index_t, 3>, int> count;
  for (index_t e = 0; e < mesh_.num_tets(); ++e)
    for (int skip = 0; skip < 4; ++skip) {
      std::array<index_t, 3> key;
      for (int i = 0, k = 0; i < 4; ++i)
        if (i != skip) key[k++] = mesh_.tets[e][i];
      std::sort(key.begin(), key.end());
      if (++count[key] == 1) once[key] = {e, skip};
    }
  const int p = space_.degree();
  const double share = 2.0 / ((p + 1.0) * (p + 2.0));  // ∫_face B_a dA / A = 1 / C(p+2,2)
  const auto& alpha = multi_indices(p);
  double area_total = 0.0;
  for (const auto& [key, c] : count) {
    if (c != 1) continue;
    const Vec3 &A = mesh_.vertices[key[0]], &B = mesh_.vertices[key[1]], &C = mesh_.vertices[key[2]];
    if (!on_face(A) || !on_face(B) || !on_face(C)) continue;
    const double area = 0.5 * (B - A).cross(C - A).norm();
    area_total += area;
    const auto [e, skip] = once[key];
    for (int a = 0; a < space_.nodes_per_element(); ++a)
      if (alpha[a][skip] == 0) f.segment<3>(3 * space_.node(e, a)) += share * area * t;
  }
  return area_total;
}

Vector ElasticityModel::body_force(const std::function<Vec3(const Vec3&)>& b,
                                   int quadrature_degree) const {
  const QuadratureRule& q = tet_quadrature(quadrature_degree + space_.degree());
  const auto& alpha = multi_indices(space_.degree());
  Vector f = Vector::Zero(num_dofs());
  for (index_t e = 0; e < mesh_.num_tets(); ++e) {
    const Tet& t = mesh_.tets[e];
    for (size_t k = 0; k < q.points.size(); ++k) {
      const Eigen::Vector4d& l = q.points[k];
      Vec3 x = Vec3::Zero();
      for (int i = 0; i < 4; ++i) x += l[i] * mesh_.vertices[t[i]];
      const Vec3 bx = q.weights[k] * (*geometry_)[e].volume * b(x);
      for (int a = 0; a < space_.nodes_per_element(); ++a)
        f.segment<3>(3 * space_.node(e, a)) += bernstein(alpha[a], l) * bx;
    }
  }
  return f;
}

Vec3 ElasticityModel::displacement_at(const Vector& u, const Vec3& X) const {
  const auto [e, l] = locate(X);
  return displacement_at(u, e, l);
}

Vec3 ElasticityModel::displacement_at(const Vector& u, index_t e, const Eigen::Vector4d& l) const {
  if (e < 0 || e >= mesh_.num_tets()) throw InputError("displacement_at: no element " + std::to_string(e));
  const auto& alpha = multi_indices(space_.degree());
  Vec3 v = Vec3::Zero();
  for (int a = 0; a < space_.nodes_per_element(); ++a)
    v += bernstein(alpha[a], l) * u.segment<3>(3 * space_.node(e, a));
  return v;
}

Vector ElasticityModel::interpolate(const std::function<Vec3(const Vec3&)>& u) const {
  const int p = space_.degree(), n = space_.nodes_per_element();
  const auto& alpha = multi_indices(p);
  // Collocation at the domain points λ = β/p: C(β, α) = B_α(β/p), the same for every element.
  Eigen::MatrixXd C(n, n);
  for (int b = 0; b < n; ++b) {
    Eigen::Vector4d l;
    for (int i = 0; i < 4; ++i) l[i] = static_cast<double>(alpha[b][i]) / p;
    for (int a = 0; a < n; ++a) C(b, a) = bernstein(alpha[a], l);
  }
  const Eigen::PartialPivLU<Eigen::MatrixXd> lu(C);
  Vector out = Vector::Zero(num_dofs());
  Eigen::MatrixXd values(n, 3);
  for (index_t e = 0; e < mesh_.num_tets(); ++e) {
    for (int b = 0; b < n; ++b) values.row(b) = u(space_.positions()[space_.node(e, b)]).transpose();
    const Eigen::MatrixXd coeff = lu.solve(values);
    for (int a = 0; a < n; ++a) out.segment<3>(3 * space_.node(e, a)) = coeff.row(a).transpose();
  }
  return out;
}

}  // namespace pmg::fem
