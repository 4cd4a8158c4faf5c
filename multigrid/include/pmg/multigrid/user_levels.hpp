// pmg/multigrid/user_levels.hpp — multigrid levels as FEM codes produce them.
//
// A FEM code (FEniCSx, MFEM, deal.II, scikit-fem, ...) hands over its level matrices as scalar CSR
// arrays and its interpolation matrices as prolongations. UserLevels turns them into the form the
// cycle reads (3x3-block BCSR with interleaved x, y, z per node, scalar node prolongations) and
// takes care of what such matrices usually carry:
//   - layout: interleaved (x0 y0 z0 x1 ...) or component-major (x0 x1 ... y0 y1 ... z0 ...);
//     a matrix whose 3x3 blocks are mostly empty under the layout given is refused (it is almost
//     certainly the other layout), with the option to use named;
//   - prolongations per node (fine nodes x coarse nodes, applied to each component) or per dof
//     (fine dofs x coarse dofs), the latter checked to be a node prolongation applied to each
//     component (P ⊗ I₃) and reduced to it;
//   - Dirichlet conditions kept as identity rows (a row whose only non-zero is its diagonal, the
//     column zeroed as well: a symmetric elimination): whole clamped nodes are removed from the
//     levels and from the prolongations (rows of the fine and columns of the coarse level), so
//     the cycle works on the free dofs only, as on pmgkit's own hierarchies. A node with some but
//     not all of its components constrained (a symmetry plane, a roller) stays, with those
//     components listed (constrained_dofs()): the cycle's transfers keep them out of every coarse
//     correction and restricted residual. A non-symmetric matrix (rows replaced but columns
//     kept) is refused;
//   - only the finest matrix (galerkin_only): the lower levels are then the Galerkin products the
//     cycle forms (coarse_operator=galerkin), with the coarse nodes that no free fine node
//     interpolates from dropped.
// The caller's arrays are read in place (32- or 64-bit indices, rows in any column order, duplicate
// entries summed: deal.II's diagonal-first rows need no sorting copy) and not kept: set_values()
// takes new values on the same patterns (a Newton or corotational step) without symbolic work.
//
//   mg::UserLevels levels({A1, A2, A3}, {P1, P2}, {});  // CsrViews, coarsest first
//   auto solver = make_solver(config, {&levels});
//   solver->setup(levels.matrix(levels.num_levels() - 1));
//   Vector rb(levels.reduced_size()), rx = Vector::Zero(levels.reduced_size());  // kept across solves
//   levels.reduce(Eigen::Map<const Vector>(b, n), rb);    // the caller's b, read in place
//   solver->solve(rb, rx);
//   levels.expand(rx, Eigen::Map<const Vector>(b, n), Eigen::Map<Vector>(x, n));  // into the caller's x
#pragma once

#include "pmg/multigrid/levels.hpp"
#include "pmg/sparse/csr_view.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace pmg::mg {

/// Order of the unknowns in a caller's vectors and matrices: interleaved (x0 y0 z0 x1 ...) or
/// component-major (x0 x1 ... y0 y1 ... z0 ...).
enum class DofLayout { interleaved, component };

/// "interleaved" | "component"; InputError otherwise.
DofLayout parse_layout(const std::string& name);

/// How UserLevels reads the caller's matrices.
struct UserLevelOptions {
  /// Layout of the unknowns in the given matrices (and vectors).
  DofLayout layout = DofLayout::interleaved;
  /// Only the finest matrix is given: the lower levels come from Galerkin products.
  bool galerkin_only = false;
};

/// A FEM code's level matrices and prolongations, converted to the cycle's form with clamped nodes
/// removed (see the file comment).
class UserLevels final : public LevelProvider {
 public:
  /// `matrices`: one per level, coarsest first (just the finest with galerkin_only);
  /// `prolongations`: level l-1 -> l for l = 1..L-1, per node or per dof.
  UserLevels(const std::vector<CsrView>& matrices, const std::vector<CsrView>& prolongations,
             const UserLevelOptions& options);

  int num_levels() const override { return static_cast<int>(levels_.size()); }
  /// Level `level`'s matrix (0 <= level < num_levels(); else InputError naming it).
  const Bcsr& matrix(int level) const override;
  /// The prolongation into `level` (1 <= level < num_levels(); else InputError naming it).
  const Csr& prolongation(int level) const override;
  bool has_matrix(int level) const override;
  /// The components of kept nodes given as identity rows on a level (nullptr: none; Galerkin
  /// levels derive theirs in the cycle).
  const std::vector<char>* constrained_dofs(int level) const override {
    const auto& c = levels_.at(level).constrained;
    return c.empty() ? nullptr : &c;
  }

  /// New values on the patterns of construction (each matrix as given, coarsest first; its entries
  /// in any order, duplicates summed). InputError for an entry outside the pattern, or a clamped
  /// node's or constrained component's row that is no longer an identity row.
  void set_values(const std::vector<CsrView>& matrices);

  /// Unknowns of the finest matrix as given, and after the clamped nodes are removed.
  index_t full_size() const { return full_size_; }
  /// Unknowns of the finest level after the clamped nodes are removed.
  index_t reduced_size() const { return matrix(num_levels() - 1).rows(); }
  /// Clamped nodes removed per level (0 when the matrix had no identity rows).
  const std::vector<index_t>& removed_nodes() const { return removed_; }
  /// b (finest, as given) restricted to the free dofs, in the cycle's interleaved order.
  Vector reduce(const Vector& full) const;
  /// The same into the caller's storage, allocating nothing: `full` (full_size() entries) gathered
  /// into `reduced` (reduced_size() entries). Either may view the caller's memory
  /// (Eigen::Map<const Vector>(dealii_vector.data(), n)): the one pass a reduction needs.
  /// InputError naming the sizes when they do not match, or the entry when one of an identity row
  /// (dropped here, so no solver would see it) is NaN or Inf.
  void reduce(Eigen::Ref<const Vector> full, Eigen::Ref<Vector> reduced) const;
  /// The full solution: x on the free dofs, b / diagonal on the identity rows.
  Vector expand(const Vector& reduced, const Vector& full_rhs) const;
  /// The same into `full` (full_size() entries, e.g. a Map of the caller's solution vector),
  /// allocating nothing. InputError naming the sizes when they do not match.
  void expand(Eigen::Ref<const Vector> reduced, Eigen::Ref<const Vector> full_rhs, Eigen::Ref<Vector> full) const;

 private:
  struct Level {
    Bcsr A;
    index_t given_nodes = 0;          ///< nodes of the matrix as given
    std::vector<index_t> node_of;     ///< given node -> kept node, or -1 (clamped)
    std::vector<index_t> row_of;      ///< given row of each kept dof (3 per kept node)
    std::vector<index_t> clamped_rows;  ///< given identity rows: clamped nodes and constrained components
    std::vector<char> constrained;      ///< per kept dof: 1 for a constrained component (or empty)
    bool has_matrix = true;
  };
  /// Values of matrices known to be on the levels' patterns into the BCSR levels; on an error the
  /// levels keep the values they had.
  void refresh_values(const std::vector<CsrView>& matrices);
  /// refresh_values' work, without the roll-back.
  void write_values(const std::vector<CsrView>& matrices);
  void check_symmetric(int level) const;
  // The steps of the constructor; `given` holds each level's matrix as given (nullptr: a Galerkin
  // level formed by the cycle).
  /// Node counts (levels_[l].given_nodes) and node prolongations, finest first.
  std::vector<Csr> node_prolongations(const std::vector<CsrView>& prolongations,
                                      const std::vector<const CsrView*>& given);
  /// Each given matrix's identity rows (per dof, interleaved); nodes with three are clamped.
  std::vector<std::vector<char>> find_identity_rows(const std::vector<const CsrView*>& given);
  /// Kept nodes per level, finest first (removed_), and the prolongations between kept nodes.
  void keep_nodes(const std::vector<Csr>& node_P);
  /// Level l's block pattern, entry slots, clamped rows and constrained components; refuses a
  /// matrix whose blocks are mostly empty under the layout (the wrong layout).
  void build_level(int l, const CsrView* A, const std::vector<char>& identity);
  /// The finest level's free and fixed dofs in the caller's numbering.
  void number_finest_dofs();

  std::vector<Level> levels_;
  std::vector<Csr> prolongations_;
  UserLevelOptions options_;
  index_t full_size_ = 0;
  std::vector<index_t> removed_;
  std::vector<index_t> free_dof_;     ///< reduced dof -> given dof (finest)
  std::vector<index_t> fixed_dof_;    ///< given dofs of identity rows (finest)
  std::vector<double> fixed_diag_;
  size_t given_matrices_ = 0;         ///< matrices given at construction
};

}  // namespace pmg::mg
