// Any solver on a component-major system (pmg/sparse/layout.hpp).
#include "pmg/sparse/layout.hpp"

#include "pmg/sparse/bcsr.hpp"
#include "pmg/sparse/factory.hpp"
#include "pmg/sparse/csr.hpp"

#include <algorithm>
#include <cstdio>

namespace pmg {

struct ComponentLayout::Copy {
  Csr csr;                      // the interleaved matrix
  std::unique_ptr<Bcsr> bcsr;   // its blocks, for block methods
  std::vector<offset_t> slot;   // given entry k -> entry of csr
};

WrappingSolver::WrappingSolver(std::unique_ptr<Solver> inner, const std::string& who) : inner_(std::move(inner)) {
  if (!inner_) throw InputError(who + ": no solver to wrap");
}

ComponentLayout::ComponentLayout(std::unique_ptr<Solver> inner, bool blocks)
    : WrappingSolver(std::move(inner), "layout=component"), blocks_(blocks) {}

ComponentLayout::~ComponentLayout() = default;

namespace {
/// The scalar CSR of a Csr or Bcsr (a copy for a Bcsr).
const Csr& scalar_of(const LinearOperator& A, Csr& scratch) {
  if (const Csr* c = A.csr_matrix()) return *c;
  if (const Bcsr* b = A.bcsr_matrix()) return scratch = b->to_csr();
  throw InputError("layout=component: the matrix must be CSR or BCSR (its entries are permuted)");
}
}  // namespace

void ComponentLayout::setup_impl(const LinearOperator& A) {
  Csr scratch;
  const Csr& given = scalar_of(A, scratch);
  const index_t n = given.rows();
  if (n % 3 != 0)
    throw InputError("layout=component: " + std::to_string(n) + " unknowns are not 3 per node");
  if (A.csr_matrix()) {  // a Bcsr stores whole blocks: its scalar pattern always reads interleaved
    const LayoutFit f = layout_fit(given);
    if (reads_as_blocks(given) && f.component < 0.9 && f.density <= 0.5) {
      char text[300];
      std::snprintf(text, sizeof text,
                    "layout=component: the matrix reads as interleaved (x0 y0 z0 x1 ...), not component-major: "
                    "the rows 3a, 3a+1, 3a+2 couple to the same nodes, and %.0f%% of the rows couple the three "
                    "components of node i mod n/3; leave layout out (interleaved is the default)",
                    100 * f.component);
      throw InputError(text);
    }
  }
  nodes_ = n / 3;
  auto interleaved = [&](index_t i) { return 3 * (i % nodes_) + i / nodes_; };
  const CsrPattern& p = given.pattern();
  std::vector<Triplet> t;
  t.reserve(static_cast<size_t>(given.nnz()));
  for (index_t i = 0; i < n; ++i)
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k) t.emplace_back(interleaved(i), interleaved(p.col_idx[k]), 0.0);
  auto copy = std::make_unique<Copy>();
  copy->csr = Csr::from_triplets(n, n, t);
  // The slot of each given entry in the copy (rows sorted: a binary search per entry, once).
  const CsrPattern& q = copy->csr.pattern();
  copy->slot.resize(static_cast<size_t>(given.nnz()));
  for (index_t i = 0; i < n; ++i) {
    const index_t r = interleaved(i);
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k) {
      const index_t c = interleaved(p.col_idx[k]);
      const auto begin = q.col_idx.begin() + q.row_ptr[r], end = q.col_idx.begin() + q.row_ptr[r + 1];
      copy->slot[k] = static_cast<offset_t>(std::lower_bound(begin, end, c) - q.col_idx.begin());
    }
  }
  copy_ = std::move(copy);
  refresh(A);
  if (blocks_) {
    copy_->bcsr = std::make_unique<Bcsr>(Bcsr::from_csr(copy_->csr));
    inner_->setup(*copy_->bcsr);
  } else {
    inner_->setup(copy_->csr);
  }
}

void ComponentLayout::refresh(const LinearOperator& A) {
  Csr scratch;
  const Csr& given = scalar_of(A, scratch);
  if (given.nnz() != static_cast<offset_t>(copy_->slot.size()))
    throw InputError("layout=component: the matrix's pattern changed (set the solver up again)");
  std::vector<double>& v = copy_->csr.values();
  std::fill(v.begin(), v.end(), 0.0);
  for (size_t k = 0; k < copy_->slot.size(); ++k) v[copy_->slot[k]] += given.values()[k];
  if (copy_->bcsr) copy_->bcsr->set_values(copy_->csr);
}

void ComponentLayout::update_impl() {
  refresh(system());
  inner_->update();
}

void ComponentLayout::to_interleaved(const Vector& in, Vector& out) const {
  out.resize(in.size());
  for (index_t i = 0; i < in.size(); ++i) out[3 * (i % nodes_) + i / nodes_] = in[i];
}

void ComponentLayout::to_component(const Vector& in, Vector& out) const {
  out.resize(in.size());
  for (index_t i = 0; i < in.size(); ++i) out[i] = in[3 * (i % nodes_) + i / nodes_];
}

SolveResult ComponentLayout::solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const {
  Vector bi, xi;
  to_interleaved(b, bi);
  to_interleaved(x, xi);
  SolveResult r;
  try {
    r = inner_->solve(bi, xi, monitor);
  } catch (...) {
    to_component(xi, x);  // the state the inner solver left, in the caller's order
    throw;
  }
  to_component(xi, x);
  return r;
}

void ComponentLayout::apply_impl(const Vector& b, Vector& x) const {
  Vector bi, xi;
  to_interleaved(b, bi);
  inner_->apply(bi, xi);
  to_component(xi, x);
}

namespace {
/// Whether row i of A stores an entry in each of columns c0, c0 + step, c0 + 2 step.
bool row_covers(const Csr& A, index_t i, index_t c0, index_t step) {
  const CsrPattern& p = A.pattern();
  const auto begin = p.col_idx.begin() + p.row_ptr[i], end = p.col_idx.begin() + p.row_ptr[i + 1];
  for (int c = 0; c < 3; ++c)
    if (!std::binary_search(begin, end, c0 + c * step)) return false;
  return true;
}
}  // namespace

LayoutFit layout_fit(const Csr& A) {
  LayoutFit f;
  const index_t n = A.rows(), m = n / 3;
  if (n % 3 != 0 || n != A.cols() || n == 0) return f;
  const CsrPattern& p = A.pattern();
  index_t inter = 0, comp = 0;
  for (index_t i = 0; i < n; ++i) {
    if (p.row_ptr[i + 1] - p.row_ptr[i] <= 1) continue;  // an identity row
    ++f.rows;
    inter += row_covers(A, i, 3 * (i / 3), 1);
    comp += row_covers(A, i, i % m, m);
  }
  if (f.rows > 0) f.interleaved = double(inter) / double(f.rows), f.component = double(comp) / double(f.rows);
  f.density = static_cast<double>(A.nnz()) / (static_cast<double>(n) * static_cast<double>(n));
  return f;
}

std::string component_major_reading(const Csr& A) {
  const LayoutFit f = layout_fit(A);
  if (!(f.component >= 0.9 && f.interleaved < 0.9 && f.density <= 0.5)) return "";
  char text[300];
  std::snprintf(text, sizeof text,
                "the matrix reads as component-major (x0 x1 ... y0 y1 ... z0 ...): %.0f%% of the rows couple the "
                "three components of node i mod n/3, %.0f%% those of their interleaved node 3*floor(i/3)",
                100 * f.component, 100 * f.interleaved);
  return text;
}

void check_interleaved(const LinearOperator& A, const std::string& who) {
  // A BCSR matrix declares its blocks: its interleaved reading is always full, and a component
  // reading alone cannot tell a component-major matrix from an interleaved one numbered in layers
  // (a plate one element thick couples node a with a + N/3 too). Only scalar input is judged.
  const Csr* c = A.csr_matrix();
  if (!c) return;
  const std::string reading = component_major_reading(*c);
  if (!reading.empty())
    throw InputError(who + ": " + reading + "; this method reads 3x3 blocks of interleaved unknowns (x0 y0 z0 x1 "
                     "...): give the key layout=component (the matrix is permuted once), or renumber the unknowns");
}

namespace {
/// The nodes ⌊j/3⌋ of row i's columns, in order and without repeats (columns are sorted).
void column_nodes(const CsrPattern& p, index_t i, std::vector<index_t>& out) {
  out.clear();
  for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k)
    if (out.empty() || out.back() != p.col_idx[k] / 3) out.push_back(p.col_idx[k] / 3);
}
}  // namespace

bool reads_as_blocks(const Csr& A) {
  const index_t n = A.rows();
  if (n % 3 != 0 || n == 0 || n != A.cols()) return false;
  const CsrPattern& p = A.pattern();
  std::vector<index_t> first, other;
  index_t counted = 0, alike = 0;
  for (index_t a = 0; a < n / 3; ++a) {
    bool identity = false;  // a constrained component (diagonal only) says nothing of the coupling
    for (int c = 0; c < 3; ++c) identity |= p.row_ptr[3 * a + c + 1] - p.row_ptr[3 * a + c] <= 1;
    if (identity) continue;
    ++counted;
    column_nodes(p, 3 * a, first);
    bool same = true;
    for (int c = 1; c < 3 && same; ++c) {
      column_nodes(p, 3 * a + c, other);
      same = other == first;
    }
    alike += same;
  }
  return counted > 0 && alike >= 0.9 * static_cast<double>(counted);
}

void check_block_reading(const Csr& A, const std::string& who) {
  check_interleaved(A, who);  // component-major first: its message names layout=component
  if (reads_as_blocks(A)) return;
  std::string scalar;  // this build's methods for a scalar matrix
  for (const SolverInfo& s : registered_solvers())
    if (!s.needs_blocks && !s.uses_levels && !s.across_ranks) scalar += (scalar.empty() ? "" : ", ") + s.name;
  throw InputError(who + " reads 3x3 blocks of interleaved unknowns (x0 y0 z0 x1 ...), and this " +
                   std::to_string(A.rows()) + "x" + std::to_string(A.cols()) + " matrix reads as a scalar system (" +
                   (A.rows() % 3 ? "its size " + std::to_string(A.rows()) + " is not divisible by 3"
                                 : std::string("the three rows of its nodes do not couple to the same nodes")) +
                   "): choose a method for scalar matrices (" + scalar +
                   "), layout=component for component-major 3-component unknowns (x0 x1 ... y0 ...), or "
                   "layout=interleaved to declare interleaved ones");
}

BlockInput::BlockInput(std::unique_ptr<Solver> inner, std::string who, bool declared)
    : WrappingSolver(std::move(inner), who), who_(std::move(who)), declared_(declared) {}

BlockInput::~BlockInput() = default;

void BlockInput::setup_impl(const LinearOperator& A) {
  const Csr* c = A.csr_matrix();
  if (!c) {
    inner_->setup(A);
    blocks_.reset();  // after the inner set-up: it no longer reads the old copy
    return;
  }
  if (!declared_) {
    check_block_reading(*c, who_);
  } else if (c->rows() % 3 != 0) {
    throw InputError(who_ + ": layout=interleaved, but the size " + std::to_string(c->rows()) +
                     " is not divisible by 3");
  }
  auto b = std::make_unique<Bcsr>(Bcsr::from_csr(*c));
  inner_->setup(*b);
  blocks_ = std::move(b);  // the old copy goes only once the inner solver reads the new one
}

void BlockInput::update_impl() {
  if (blocks_) {
    const Csr* c = system().csr_matrix();
    blocks_->set_values(*c);
  }
  inner_->update();
}

SolveResult BlockInput::solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const {
  return inner_->solve(b, x, monitor);
}

void BlockInput::apply_impl(const Vector& b, Vector& x) const { inner_->apply(b, x); }

std::string BlockInput::describe() const {
  const std::string d = inner_->describe();
  if (!blocks_) return d;
  return "scalar CSR input read as 3x3 blocks" + (d.empty() ? std::string() : "; " + d);
}

std::string ComponentLayout::describe() const {
  const std::string d = inner_->describe();
  return "component-major input, permuted to interleaved" + (d.empty() ? std::string() : "; " + d);
}

}  // namespace pmg
