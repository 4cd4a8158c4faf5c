#include "pmg/multigrid/user_levels.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace pmg::mg {

DofLayout parse_layout(const std::string& name) {
  if (name == "interleaved") return DofLayout::interleaved;
  if (name == "component") return DofLayout::component;
  throw InputError("layout: expected interleaved (x0 y0 z0 x1 ...) or component (x0 x1 ... y0 ...), got '" +
                   name + "'");
}

namespace {

constexpr int B = Bcsr::kBlock;

/// Given dof -> interleaved dof (3 * node + component) for a level of n nodes.
struct DofMap {
  DofLayout layout;
  index_t n;
  index_t operator()(index_t i) const { return layout == DofLayout::interleaved ? i : B * (i % n) + i / n; }
  index_t given(index_t node, int comp) const {
    return layout == DofLayout::interleaved ? B * node + comp : comp * n + node;
  }
};

std::string level_label(int l) { return "level " + std::to_string(l); }

/// A dof prolongation (fine dofs x coarse dofs) that is P ⊗ I₃ under the layout, as P per node.
Csr node_prolongation_of_dofs(const CsrView& P, index_t nf, index_t nc, DofLayout layout, int level) {
  const DofMap fm{layout, nf}, cm{layout, nc};
  struct E { index_t I, J; int comp; double v; };
  std::vector<E> e;
  e.reserve(P.nnz);
  for (index_t i = 0; i < P.rows; ++i)
    for (offset_t k = P.row_begin(i); k < P.row_end(i); ++k) {
      const index_t a = fm(i), b = cm(P.col(k));
      if (P.values[k] == 0.0) continue;
      if (a % B != b % B)
        throw InputError("prolongation " + std::to_string(level) + ": entry (" + std::to_string(i) + ", " +
                         std::to_string(P.col(k)) + ") couples different displacement components; a " +
                         "dof prolongation must be a node prolongation applied to each component (check layout=)");
      e.push_back({a / B, b / B, a % B, P.values[k]});
    }
  std::sort(e.begin(), e.end(), [](const E& x, const E& y) { return x.I != y.I ? x.I < y.I : x.J != y.J ? x.J < y.J : x.comp < y.comp; });
  std::vector<Triplet> t;
  for (size_t s = 0; s < e.size();) {
    size_t q = s;
    while (q < e.size() && e[q].I == e[s].I && e[q].J == e[s].J) ++q;
    const double v = e[s].v;
    const bool all_three = q - s == 3;
    bool same = all_three;
    for (size_t r = s; r < q && same; ++r) same = std::abs(e[r].v - v) <= 1e-12 * std::abs(v);
    if (!same)
      throw InputError("prolongation " + std::to_string(level) + ": node " + std::to_string(e[s].I) +
                       " takes different weights from coarse node " + std::to_string(e[s].J) +
                       " for its x, y, z components; the cycle needs one prolongation per node "
                       "applied to each component (check layout=)");
    t.emplace_back(e[s].I, e[s].J, v);
    s = q;
  }
  return Csr::from_triplets(nf, nc, t);
}

}  // namespace

UserLevels::UserLevels(const std::vector<CsrView>& matrices, const std::vector<CsrView>& given_prolongations,
                       const UserLevelOptions& options)
    : options_(options) {
  // Prolongations in any column order, with duplicates: a canonical copy (they are read once).
  std::vector<Csr> canonical;
  canonical.reserve(given_prolongations.size());  // views into it stay valid
  std::vector<CsrView> prolongations = given_prolongations;
  for (size_t l = 0; l < prolongations.size(); ++l) {
    prolongations[l].validate("prolongation " + std::to_string(l + 1), false);
    if (!prolongations[l].is_canonical()) {
      canonical.push_back(to_csr(prolongations[l], "prolongation " + std::to_string(l + 1)));
      prolongations[l] = view_of(canonical.back());
    }
  }
  const int L = static_cast<int>(prolongations.size()) + 1;
  if (matrices.empty()) throw InputError("multigrid levels: no level matrices");
  if (options.galerkin_only && matrices.size() != 1)
    throw InputError("multigrid levels: with Galerkin coarse levels give the finest matrix only, got " +
                     std::to_string(matrices.size()));
  if (!options.galerkin_only && static_cast<int>(matrices.size()) != L)
    throw InputError("multigrid levels: " + std::to_string(matrices.size()) + " level matrices need " +
                     std::to_string(matrices.size() - 1) + " prolongations, got " +
                     std::to_string(prolongations.size()));
  for (size_t l = 0; l < matrices.size(); ++l) {
    const std::string who = options.galerkin_only ? "finest matrix" : "level matrix " + std::to_string(l);
    matrices[l].validate(who, false);  // any column order, duplicates summed
    if (matrices[l].rows != matrices[l].cols || matrices[l].rows % B != 0 || matrices[l].rows == 0)
      throw InputError(who + " is " + std::to_string(matrices[l].rows) + "x" + std::to_string(matrices[l].cols) +
                       ": a level matrix must be square with 3 unknowns per node");
  }
  levels_.resize(L);
  std::vector<const CsrView*> given(L, nullptr);
  for (int l = 0; l < L; ++l)
    given[l] = options.galerkin_only ? (l == L - 1 ? &matrices[0] : nullptr) : &matrices[l];
  levels_[L - 1].given_nodes = matrices.back().rows / B;
  const std::vector<Csr> node_P = node_prolongations(prolongations, given);
  const std::vector<std::vector<char>> identity_of = find_identity_rows(given);
  keep_nodes(node_P);
  for (int l = 0; l < L; ++l) build_level(l, given[l], identity_of[l]);
  full_size_ = matrices.back().rows;
  number_finest_dofs();
  fixed_diag_.resize(fixed_dof_.size());
  given_matrices_ = matrices.size();
  refresh_values(matrices);
}

std::vector<Csr> UserLevels::node_prolongations(const std::vector<CsrView>& prolongations,
                                                const std::vector<const CsrView*>& given) {
  const int L = static_cast<int>(levels_.size());
  std::vector<Csr> node_P(L > 1 ? L - 1 : 0);
  for (int l = L - 1; l >= 1; --l) {
    const CsrView& P = prolongations[l - 1];
    const index_t nf = levels_[l].given_nodes;
    const CsrView* Ac = given[l - 1];
    const std::string who = "prolongation " + std::to_string(l);
    if (P.rows == nf) {
      if (Ac && P.cols != Ac->rows / B)
        throw InputError(who + " is " + std::to_string(P.rows) + "x" + std::to_string(P.cols) + ", levels " +
                         std::to_string(l - 1) + " and " + std::to_string(l) + " need " + std::to_string(nf) +
                         "x" + std::to_string(Ac->rows / B) + " (nodes) or " + std::to_string(B * nf) + "x" +
                         std::to_string(Ac->rows) + " (dofs)");
      node_P[l - 1] = to_csr(P, who);
    } else if (P.rows == B * nf && P.cols % B == 0 && (!Ac || P.cols == Ac->rows)) {
      node_P[l - 1] = node_prolongation_of_dofs(P, nf, P.cols / B, options_.layout, l);
    } else {
      throw InputError(who + " is " + std::to_string(P.rows) + "x" + std::to_string(P.cols) + "; level " +
                       std::to_string(l) + " has " + std::to_string(nf) + " nodes (" + std::to_string(B * nf) +
                       " dofs): give fine nodes x coarse nodes, or fine dofs x coarse dofs");
    }
    levels_[l - 1].given_nodes = node_P[l - 1].cols();
  }
  return node_P;
}

std::vector<std::vector<char>> UserLevels::find_identity_rows(const std::vector<const CsrView*>& given) {
  // Level matrices: identity rows found; whole clamped nodes removed, nodes with some components
  // constrained (symmetry planes, rollers) kept with those components flagged.
  const int L = static_cast<int>(levels_.size());
  std::vector<std::vector<char>> identity_of(L);
  for (int l = 0; l < L; ++l) {
    Level& lv = levels_[l];
    const CsrView* A = given[l];
    lv.has_matrix = A != nullptr;
    lv.node_of.assign(lv.given_nodes, 0);
    if (!A) continue;  // kept nodes decided from the finer level below
    const index_t n = lv.given_nodes;
    const DofMap map{options_.layout, n};
    const std::string who = level_label(l);
    std::vector<char> identity(B * n, 0);
    for (index_t i = 0; i < A->rows; ++i) {
      double d = 0.0;
      bool off = false;
      for (offset_t k = A->row_begin(i); k < A->row_end(i); ++k) {
        if (A->col(k) == i) d += A->values[k];
        else if (A->values[k] != 0.0) off = true;
      }
      const bool diag = d > 0.0;
      if (!diag && !off)
        throw InputError(who + ": row " + std::to_string(i) + " is zero: the matrix is singular");
      if (diag && !off) identity[map(i)] = 1;
    }
    for (index_t I = 0; I < n; ++I) {
      const int c = identity[B * I] + identity[B * I + 1] + identity[B * I + 2];
      lv.node_of[I] = c == B ? -1 : 0;
    }
    identity_of[l] = std::move(identity);
  }
  return identity_of;
}

void UserLevels::keep_nodes(const std::vector<Csr>& node_P) {
  const int L = static_cast<int>(levels_.size());
  // Kept nodes, finest first: a Galerkin level keeps the coarse nodes some kept fine node takes from.
  for (int l = L - 1; l >= 0; --l) {
    Level& lv = levels_[l];
    if (!lv.has_matrix) {
      const Csr& P = node_P[l];  // level l -> l+1
      std::vector<char> used(lv.given_nodes, 0);
      const CsrPattern& p = P.pattern();
      for (index_t I = 0; I < P.rows(); ++I)
        if (levels_[l + 1].node_of[I] >= 0)
          for (offset_t k = p.row_ptr[I]; k < p.row_ptr[I + 1]; ++k)
            if (P.values()[k] != 0.0) used[p.col_idx[k]] = 1;
      for (index_t J = 0; J < lv.given_nodes; ++J) lv.node_of[J] = used[J] ? 0 : -1;
    }
    index_t kept = 0;
    for (auto& v : lv.node_of) v = v < 0 ? -1 : kept++;
    if (kept == 0) throw InputError(level_label(l) + ": every node is clamped (identity rows only)");
    removed_.push_back(lv.given_nodes - kept);
  }
  std::reverse(removed_.begin(), removed_.end());

  // Prolongations between the kept nodes.
  for (int l = 1; l < L; ++l) {
    const Csr& P = node_P[l - 1];
    const auto& fine = levels_[l].node_of;
    const auto& coarse = levels_[l - 1].node_of;
    std::vector<Triplet> t;
    const CsrPattern& p = P.pattern();
    for (index_t I = 0; I < P.rows(); ++I) {
      if (fine[I] < 0) continue;
      for (offset_t k = p.row_ptr[I]; k < p.row_ptr[I + 1]; ++k)
        if (coarse[p.col_idx[k]] >= 0 && P.values()[k] != 0.0)
          t.emplace_back(fine[I], coarse[p.col_idx[k]], P.values()[k]);
    }
    const index_t nf = *std::max_element(fine.begin(), fine.end()) + 1;
    const index_t nc = *std::max_element(coarse.begin(), coarse.end()) + 1;
    prolongations_.push_back(Csr::from_triplets(nf, nc, t));
  }
}

void UserLevels::build_level(int l, const CsrView* A, const std::vector<char>& identity_of_level) {
  Level& lv = levels_[l];
  const index_t nk = *std::max_element(lv.node_of.begin(), lv.node_of.end()) + 1;
  if (!A) {
    lv.A = Bcsr::from_block_triplets(nk, nk, {});
    return;
  }
  const DofMap map{options_.layout, lv.given_nodes};
  // Given rows of each kept node (3 per node; in place for interleaved, gathered otherwise).
  std::vector<index_t> row_of(B * nk);
  for (index_t i = 0; i < A->rows; ++i) {
    const index_t ri = map(i), R = lv.node_of[ri / B];
    if (R >= 0) row_of[B * R + ri % B] = i;
  }
  // Pattern: per block row, the kept block columns of its three rows (marker array, then sort).
  auto pat = std::make_shared<BlockPattern>();
  pat->rows = pat->cols = nk;
  pat->row_ptr.assign(nk + 1, 0);
  pat->col_idx.reserve(static_cast<size_t>(A->nnz / (B * B)) + nk);
  std::vector<index_t> mark(nk, -1), row_cols, seen(B * nk, -1);
  const std::vector<char>& is_identity = identity_of_level;
  offset_t stored = 0;  // distinct entries between free components (for the layout check)
  for (index_t R = 0; R < nk; ++R) {
    row_cols.clear();
    for (int a = 0; a < B; ++a) {
      const index_t i = row_of[B * R + a];
      for (offset_t k = A->row_begin(i); k < A->row_end(i); ++k) {
        const index_t cj = map(A->col(k)), C = lv.node_of[cj / B];
        if (C < 0) continue;
        if (!is_identity[map(i)] && !is_identity[cj] && seen[B * C + cj % B] != B * R + a)
          seen[B * C + cj % B] = B * R + a, ++stored;
        if (mark[C] != R) mark[C] = R, row_cols.push_back(C);
      }
    }
    std::sort(row_cols.begin(), row_cols.end());
    pat->col_idx.insert(pat->col_idx.end(), row_cols.begin(), row_cols.end());
    pat->row_ptr[R + 1] = static_cast<offset_t>(pat->col_idx.size());
  }
  lv.A = Bcsr(pat, std::vector<double>(Bcsr::kBlockSize * pat->nnz(), 0.0));
  lv.row_of = std::move(row_of);
  for (index_t i = 0; i < A->rows; ++i)
    if (lv.node_of[map(i) / B] < 0) lv.clamped_rows.push_back(i);
  // The constrained components of kept nodes, in the cycle's numbering.
  const std::vector<char>& identity = identity_of_level;
  for (index_t i = 0; i < A->rows; ++i) {
    const index_t ri = map(i), R = lv.node_of[ri / B];
    if (R < 0 || !identity[ri]) continue;
    if (lv.constrained.empty()) lv.constrained.assign(B * nk, 0);
    lv.constrained[B * R + ri % B] = 1;
    lv.clamped_rows.push_back(i);  // stays an identity row: checked at every refresh
  }
  // Layout check: elasticity couples all three components of every pair of coupled nodes, so
  // under the right layout the 3x3 blocks are (nearly) full.
  // Entries the blocks can hold between free components (constrained ones have zero couplings).
  std::vector<int> free_of(nk, B);
  for (index_t i = 0; i < A->rows; ++i)
    if (lv.node_of[map(i) / B] >= 0 && is_identity[map(i)]) --free_of[lv.node_of[map(i) / B]];
  double capacity = 0.0;
  for (index_t R = 0; R < nk; ++R)
    for (offset_t q = pat->row_ptr[R]; q < pat->row_ptr[R + 1]; ++q) capacity += free_of[R] * free_of[pat->col_idx[q]];
  if (capacity > 0 && stored < 0.5 * capacity)
    throw InputError(level_label(l) + ": only " +
                     std::to_string(static_cast<int>(100.0 * stored / capacity)) +
                     "% of the entries of its 3x3 blocks are stored under the " +
                     (options_.layout == DofLayout::interleaved
                          ? "interleaved layout (x0 y0 z0 x1 ...): is it component-major (x0 x1 ... y0 ...)? "
                            "Give the component layout (Python layout='component', pmg compare --layout "
                            "component, C++ DofLayout::component)"
                          : "component-major layout: is it interleaved (x0 y0 z0 x1 ...)? Give the interleaved "
                            "layout (Python layout='interleaved', pmg compare --layout interleaved, C++ "
                            "DofLayout::interleaved)"));
}

void UserLevels::number_finest_dofs() {
  // Finest level: free and fixed dofs in the caller's numbering.
  const Level& fl = levels_.back();
  const DofMap fmap{options_.layout, fl.given_nodes};
  free_dof_.assign(B * fl.A.block_rows(), 0);
  for (index_t I = 0; I < fl.given_nodes; ++I)
    for (int a = 0; a < B; ++a) {
      if (fl.node_of[I] >= 0) free_dof_[B * fl.node_of[I] + a] = fmap.given(I, a);
      else fixed_dof_.push_back(fmap.given(I, a));
    }
}

void UserLevels::check_symmetric(int l) const {
  const Bcsr& A = levels_[l].A;
  const BlockPattern& p = A.pattern();
  double max_abs = 0.0;
  for (double v : A.values()) max_abs = std::max(max_abs, std::abs(v));
  const double tol = 1e-12 * max_abs;
  // One pass: for block rows R in increasing order, the transposed blocks (C, R) of the blocks
  // (R, C), C >= R, lie at increasing positions of row C, so a cursor per row finds each in
  // amortised O(1); blocks of row C skipped by its cursor have no partner (R, C) and must be zero.
  std::vector<offset_t> cursor(p.row_ptr.begin(), p.row_ptr.end() - 1);
  bool symmetric = true;
  for (index_t R = 0; R < p.rows && symmetric; ++R)
    for (offset_t k = p.row_ptr[R]; k < p.row_ptr[R + 1] && symmetric; ++k) {
      const index_t C = p.col_idx[k];
      if (C < R) continue;  // checked from row C
      offset_t& q = cursor[C];
      for (; q < p.row_ptr[C + 1] && p.col_idx[q] < R; ++q)
        symmetric = symmetric && A.block(q).cwiseAbs().maxCoeff() <= tol;  // (C, j < R) without (j, C)
      const bool found = q < p.row_ptr[C + 1] && p.col_idx[q] == R;
      const Block3 t = found ? Block3(A.block(q).transpose()) : Block3::Zero();
      symmetric = symmetric && (A.block(k) - t).cwiseAbs().maxCoeff() <= tol;
      if (found) ++q;
    }
  for (index_t C = 0; C < p.rows && symmetric; ++C)  // lower blocks no row reached
    for (offset_t q = cursor[C]; q < p.row_ptr[C + 1] && p.col_idx[q] < C; ++q)
      symmetric = symmetric && A.block(q).cwiseAbs().maxCoeff() <= tol;
  if (!symmetric)
    throw InputError(level_label(l) + ": the matrix is not symmetric (the solvers need a symmetric "
                     "positive definite matrix); if Dirichlet rows were replaced by identity rows, "
                     "zero their columns too (a symmetric elimination, the known values moved to "
                     "the right-hand side)");
}

bool UserLevels::has_matrix(int level) const { return levels_.at(level).has_matrix; }

void UserLevels::set_values(const std::vector<CsrView>& matrices) {
  if (matrices.size() != given_matrices_)
    throw InputError("multigrid levels: new values for " + std::to_string(matrices.size()) +
                     " matrices, the levels have " + std::to_string(given_matrices_));
  const int L = num_levels();
  for (size_t m = 0; m < matrices.size(); ++m) {
    const int l = options_.galerkin_only ? L - 1 : static_cast<int>(m);
    const CsrView& A = matrices[m];
    if (A.rows != B * levels_[l].given_nodes || A.cols != A.rows)
      throw InputError(level_label(l) + ": new values must come on the pattern the levels were built "
                       "on (same rows, columns and stored entries); build new levels for a new pattern");
    A.validate(level_label(l), false);  // entries in any order: the walk checks each against the pattern
  }
  refresh_values(matrices);
}

const Bcsr& UserLevels::matrix(int level) const {
  if (level < 0 || level >= num_levels())
    throw InputError("multigrid levels: no level " + std::to_string(level) + " (levels 0 to " +
                     std::to_string(num_levels() - 1) + ")");
  return levels_[level].A;
}

const Csr& UserLevels::prolongation(int level) const {
  if (level < 1 || level >= num_levels())
    throw InputError("multigrid levels: no prolongation into level " + std::to_string(level) + " (levels 1 to " +
                     std::to_string(num_levels() - 1) + " have one)");
  return prolongations_[level - 1];
}

void UserLevels::refresh_values(const std::vector<CsrView>& matrices) {
  // All or nothing: a refused update leaves the values it found (a later solve must not run on
  // matrices that were refused).
  const int L = num_levels();
  std::vector<std::vector<double>> kept(levels_.size());
  for (size_t m = 0; m < matrices.size(); ++m) {
    const int l = options_.galerkin_only ? L - 1 : static_cast<int>(m);
    kept[l] = levels_[l].A.values();
  }
  const std::vector<double> kept_diag = fixed_diag_;
  try {
    write_values(matrices);
  } catch (...) {
    for (size_t l = 0; l < kept.size(); ++l)
      if (!kept[l].empty()) levels_[l].A.values() = std::move(kept[l]);
    fixed_diag_ = kept_diag;
    throw;
  }
}

void UserLevels::write_values(const std::vector<CsrView>& matrices) {
  const int L = num_levels();
  for (size_t m = 0; m < matrices.size(); ++m) {
    const int l = options_.galerkin_only ? L - 1 : static_cast<int>(m);
    const CsrView& A = matrices[m];
    Level& lv = levels_[l];
    const DofMap map{options_.layout, lv.given_nodes};
    // Block row by block row: scatter the row's block positions, then copy its three given rows'
    // values into their blocks (no per-entry map is stored: the walk is the map).
    const BlockPattern& p = lv.A.pattern();
    std::vector<double>& val = lv.A.values();
    std::string error;
#pragma omp parallel
    {
      std::vector<index_t> pos(p.rows, -1), stamp(p.rows, -1);  // stamp: the row pos was set for
#pragma omp for schedule(static)
      for (index_t R = 0; R < p.rows; ++R) {
        for (offset_t q = p.row_ptr[R]; q < p.row_ptr[R + 1]; ++q)
          pos[p.col_idx[q]] = static_cast<index_t>(q), stamp[p.col_idx[q]] = R;
        std::fill(val.begin() + Bcsr::kBlockSize * p.row_ptr[R], val.begin() + Bcsr::kBlockSize * p.row_ptr[R + 1], 0.0);
        for (int a = 0; a < B; ++a) {
          const index_t i = lv.row_of[B * R + a];
          for (offset_t k = A.row_begin(i); k < A.row_end(i); ++k) {
            const index_t cj = map(A.col(k)), C = lv.node_of[cj / B];
            const double v = A.values[k];
            if (C >= 0 && stamp[C] == R) {
              val[Bcsr::kBlockSize * pos[C] + B * a + cj % B] += v;  // duplicates summed
            } else if (C >= 0) {
#pragma omp critical(pmg_user_levels_error)
              error = level_label(l) + ": entry (" + std::to_string(i) + ", " + std::to_string(A.col(k)) +
                      ") lies outside the pattern the levels were built on; build new levels for a new pattern";
            } else if (v != 0.0) {
#pragma omp critical(pmg_user_levels_error)
              error = level_label(l) + ": row " + std::to_string(i) + " couples to column " +
                      std::to_string(A.col(k)) + ", an identity row (a clamped node): the columns of "
                      "identity rows must be zero too (a symmetric elimination, the known values "
                      "moved to the right-hand side)";
            }
          }
        }
      }
    }
    if (!error.empty()) throw InputError(error);
    for (index_t i : lv.clamped_rows)
      for (offset_t k = A.row_begin(i); k < A.row_end(i); ++k)
        if (A.values[k] != 0.0 && A.col(k) != i)
          throw InputError(level_label(l) + ": row " + std::to_string(i) + " was an identity row (a " +
                           "clamped node or a constrained component) and now has off-diagonal entries; build new levels");
    for (size_t r = 0; r < lv.constrained.size(); ++r)
      if (lv.constrained[r] && !(val[Bcsr::kBlockSize * lv.A.find_block(static_cast<index_t>(r / B), static_cast<index_t>(r / B)) + (r % B) * (B + 1)] > 0.0))
        throw InputError(level_label(l) + ": a constrained component's identity row has a diagonal <= 0");
    for (double v : val)
      if (!std::isfinite(v)) throw InputError(level_label(l) + ": non-finite values");
    check_symmetric(l);
  }
  // The diagonal of the finest identity rows, for expand().
  const CsrView& F = matrices.back();
  for (size_t k = 0; k < fixed_dof_.size(); ++k) {
    const index_t i = fixed_dof_[k];
    double d = 0.0;
    for (offset_t q = F.row_begin(i); q < F.row_end(i); ++q)
      if (F.col(q) == i) d += F.values[q];
    if (!(d > 0.0)) throw InputError("finest matrix: identity row " + std::to_string(i) + " has diagonal " + std::to_string(d));
    fixed_diag_[k] = d;
  }
}

void UserLevels::reduce(Eigen::Ref<const Vector> full, Eigen::Ref<Vector> reduced) const {
  if (full.size() != full_size_)
    throw InputError("multigrid levels: reduce: the right-hand side has " + std::to_string(full.size()) +
                     " entries, the finest matrix as given " + std::to_string(full_size_) + " rows");
  if (reduced.size() != static_cast<Eigen::Index>(free_dof_.size()))
    throw InputError("multigrid levels: reduce: the output has " + std::to_string(reduced.size()) +
                     " entries, the reduced system " + std::to_string(free_dof_.size()) + " (reduced_size())");
  // The removed rows' entries never reach the solver's own checks: non-finite ones are refused here.
  for (const index_t i : fixed_dof_)
    if (!std::isfinite(full[i]))
      throw InputError("multigrid levels: entry " + std::to_string(i) +
                       " (an identity row: a clamped node or constrained component) is NaN or Inf");
  for (size_t k = 0; k < free_dof_.size(); ++k) reduced[static_cast<Eigen::Index>(k)] = full[free_dof_[k]];
}

Vector UserLevels::reduce(const Vector& full) const {
  Vector r(free_dof_.size());
  reduce(full, r);
  return r;
}

void UserLevels::expand(Eigen::Ref<const Vector> reduced, Eigen::Ref<const Vector> full_rhs,
                        Eigen::Ref<Vector> full) const {
  if (reduced.size() != static_cast<Eigen::Index>(free_dof_.size()) || full_rhs.size() != full_size_ ||
      full.size() != full_size_)
    throw InputError("multigrid levels: expand: sizes " + std::to_string(reduced.size()) + ", " +
                     std::to_string(full_rhs.size()) + ", " + std::to_string(full.size()) + " given, " +
                     std::to_string(free_dof_.size()) + " (reduced), " + std::to_string(full_size_) + " and " +
                     std::to_string(full_size_) + " (as given) expected");
  for (size_t k = 0; k < free_dof_.size(); ++k) full[free_dof_[k]] = reduced[static_cast<Eigen::Index>(k)];
  for (size_t k = 0; k < fixed_dof_.size(); ++k) full[fixed_dof_[k]] = full_rhs[fixed_dof_[k]] / fixed_diag_[k];
}

Vector UserLevels::expand(const Vector& reduced, const Vector& full_rhs) const {
  Vector x(full_size_);
  expand(reduced, full_rhs, x);
  return x;
}

}  // namespace pmg::mg
