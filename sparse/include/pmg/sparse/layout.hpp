// pmg/sparse/layout.hpp — any solver on a component-major system (x0 x1 ... y0 y1 ... z0 z1 ...,
// MFEM's default vector ordering, deal.II after DoFRenumbering::component_wise). pmgkit's block
// methods read 3x3 blocks of interleaved unknowns (x0 y0 z0 x1 ...); handed a component-major
// matrix they would read mostly empty blocks and slow down without a word (block-Jacobi PCG took
// 2.4x the iterations, CHOLMOD's block ordering 4x the factor). The factory key `layout=component`
// wraps the method in ComponentLayout: the matrix is permuted to interleaved once at set-up (its
// values refreshed through the same map at update()), the right-hand side and solution at each
// solve. Multigrid levels take their layout where they are built (mg::UserLevels).
//
// Without the key, the block methods check a scalar matrix they are given (check_interleaved()):
// one whose rows couple the three components of the node i mod n/3 (component-major reading) but
// leave many 3x3 blocks of interleaved nodes unfilled is refused with a message naming
// layout=component. Elasticity couples every component of a node with every other, so the right
// reading fills every node's diagonal block (the wrong one 42% of them on a quadratic box).
#pragma once

#include "pmg/sparse/solver.hpp"

#include <memory>
#include <string>
#include <vector>

namespace pmg {

/// How a scalar matrix's pattern reads under each layout: the fraction of its rows (identity rows
/// left out) that store an entry in each of the three components of their own node — node
/// 3⌊i/3⌋ read interleaved, node i mod (n/3) read component-major — and the fraction of entries
/// stored. Structural: stored entries count whatever their value (an interleaved elasticity matrix
/// on a symmetric mesh has exact zeros inside its diagonal blocks).
struct LayoutFit {
  double interleaved = 1.0;  ///< rows storing their interleaved node's three columns
  double component = 0.0;    ///< rows storing their component-major node's three columns
  double density = 1.0;      ///< stored entries / n²
  index_t rows = 0;          ///< rows counted (more than their diagonal stored)
};
/// The fit of A (a size divisible by 3; {1, 0, 1, 0} otherwise). Cost: six binary searches per row.
LayoutFit layout_fit(const Csr& A);
/// Empty, or why A reads as component-major: component >= 0.9, interleaved < 0.9 and density
/// <= 0.5 (a dense matrix fits both readings). An interleaved elasticity matrix stores its nodes'
/// 3x3 blocks (interleaved 1). The one criterion of check_interleaved() and pmg compare's warning.
std::string component_major_reading(const Csr& A);
/// Whether a scalar matrix carries 3x3 blocks of interleaved unknowns (x0 y0 z0 x1 ...): its size
/// is divisible by 3 and, for at least 90% of the nodes a = ⌊i/3⌋ (nodes with an identity row left
/// out), the three rows 3a, 3a+1, 3a+2 couple to the same nodes ⌊j/3⌋. Elasticity and other
/// 3-component systems do, also with exact zeros dropped from the pattern (an axis-aligned mesh
/// has zero couplings inside its blocks); a scalar stencil whose size happens to be a multiple of 3
/// does not (the 5-point Laplacian's rows 3a and 3a+1 reach different neighbours), except where
/// the stencil happens to align with triples of unknowns (a grid exactly 3 points wide): there the
/// caller says so (`--block-size 1`, `format="csr"`). O(nnz), no values read. The one rule by
/// which pmgkit
/// chooses blocks for a matrix that does not declare them (format auto in Python and `pmg
/// compare`, block methods handed a Csr).
bool reads_as_blocks(const Csr& A);
/// The one check before a block method reads a scalar matrix as 3x3 blocks (BlockInput, studies,
/// Python): returns when A reads as blocks (reads_as_blocks()); throws InputError naming `who`
/// and layout=component when A reads as component-major (check_interleaved()), else naming the
/// scalar methods this build registers and layout=interleaved (which declares the blocks).
void check_block_reading(const Csr& A, const std::string& who);
/// Throws InputError naming `who`, the reading and the key layout=component when A is a Csr that
/// reads as component-major (component_major_reading()); block methods call it at set-up (not at
/// update(): the pattern is the same). A Bcsr is not judged: it declares its blocks, and its
/// structure cannot tell a component-major matrix from an interleaved one numbered in layers (a
/// thin plate couples node a with a + N/3); judge scalar input before Bcsr::from_csr (Python's
/// make_solver and pmg compare do).
void check_interleaved(const LinearOperator& A, const std::string& who);

/// A solver that does its work through another one, set up on a converted form of the matrix it
/// is given (BlockInput, ComponentLayout): what such a wrapper reports is the inner solver's.
class WrappingSolver : public Solver {
 public:
  std::string name() const override { return inner_->name(); }
  bool is_linear() const override { return inner_->is_linear(); }
  bool is_symmetric() const override { return inner_->is_symmetric(); }
  SolverNeeds needs() const override { return inner_->needs(); }
  TimingBreakdown timings() const override { return inner_->timings(); }
  void reset_timings() const override { inner_->reset_timings(); }
  TimingBreakdown setup_timings() const override { return inner_->setup_timings(); }
  /// The wrapped solver.
  const Solver& inner() const { return *inner_; }

 protected:
  /// Takes `inner` (not set up); InputError naming `who` when it is null.
  WrappingSolver(std::unique_ptr<Solver> inner, const std::string& who);
  /// The wrapped solver, set up by the derived class on its converted matrix.
  std::unique_ptr<Solver> inner_;
};

/// A block method handed whatever the caller has (what make_solver() returns for a method that
/// reads 3x3 blocks, set up without multigrid levels). A scalar Csr is judged once: one that reads
/// as interleaved blocks (reads_as_blocks()) is copied into a Bcsr at set-up (its values refreshed
/// at update()), so the method runs at its block speed on the matrix a user naturally passes; one
/// that reads as component-major is refused naming layout=component (check_interleaved()); one
/// that reads as a scalar system is refused naming the scalar methods (layout=interleaved, given
/// explicitly, declares the blocks instead). Any other operator (Bcsr,
/// BIN-BCSR, matrix-free) is passed through unchanged. The copy costs the Bcsr's memory (about
/// two thirds of the Csr's for elasticity: one column index per 3x3 block).
class BlockInput final : public WrappingSolver {
 public:
  /// Wraps `inner` (not set up), which reads 3x3 blocks; `who` names it in messages ("method mcg").
  /// `declared`: the caller said the unknowns are interleaved (layout=interleaved given): a Csr is
  /// read as blocks without judging its pattern.
  BlockInput(std::unique_ptr<Solver> inner, std::string who, bool declared = false);
  ~BlockInput() override;
  bool multiply_with(const LinearOperator* op) override { return inner_->multiply_with(op); }
  /// "scalar CSR input read as 3x3 blocks; " (when copied) and the inner solver's description.
  std::string describe() const override;

 private:
  void setup_impl(const LinearOperator& A) override;
  void update_impl() override;
  SolveResult solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const override;
  void apply_impl(const Vector& b, Vector& x) const override;

  std::string who_;
  bool declared_ = false;
  std::unique_ptr<Bcsr> blocks_;  // the copy of a scalar input; null when passed through
};

/// A solver of interleaved systems applied to a component-major one (see the file comment).
class ComponentLayout final : public WrappingSolver {
 public:
  /// Wraps `inner` (not set up); `blocks`: give it the permuted matrix as 3x3 BCSR (methods that
  /// read blocks), else as scalar CSR.
  ComponentLayout(std::unique_ptr<Solver> inner, bool blocks);
  ~ComponentLayout() override;
  /// "component-major input, permuted to interleaved; " and the inner solver's description.
  std::string describe() const override;

 private:
  void setup_impl(const LinearOperator& A) override;
  void update_impl() override;
  SolveResult solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const override;
  void apply_impl(const Vector& b, Vector& x) const override;
  void to_interleaved(const Vector& in, Vector& out) const;
  void to_component(const Vector& in, Vector& out) const;
  /// The given matrix's scalar CSR values into the interleaved copy (and its blocks).
  void refresh(const LinearOperator& A);

  bool blocks_;
  index_t nodes_ = 0;
  struct Copy;
  std::unique_ptr<Copy> copy_;
};

}  // namespace pmg
