#include "pmg/hypre/boomeramg.hpp"
#include "pmg/sparse/bcsr.hpp"
#include "pmg/sparse/layout.hpp"
#include "pmg/sparse/vector_ops.hpp"

#include "pmg/mpi/session.hpp"
#include "pmg/sparse/factory.hpp"

#include <HYPRE.h>
#include <HYPRE_parcsr_ls.h>
#include <_hypre_parcsr_ls.h>  // hypre_ParAMGData (the complexities); hypre_ParCSRMatrix, built here
#include <mpi.h>

#include <algorithm>
#include <cstdint>
#include <cmath>
#include <limits>
#include <mutex>
#include <sstream>
#include <string>

namespace pmg::hypre {

namespace {

void check(HYPRE_Int err, const char* what) {
  if (err) {
    char msg[256];
    HYPRE_DescribeError(err, msg);
    HYPRE_ClearAllErrors();
    throw Error(std::string("hypre: ") + what + " failed: " + msg);
  }
}

/// The rank's entries of an initialised IJ vector, written and read in place (hypre keeps them
/// contiguous, rows lower..upper).
double* local_data(HYPRE_IJVector v) {
  HYPRE_ParVector p;
  HYPRE_IJVectorGetObject(v, reinterpret_cast<void**>(&p));
  return hypre_VectorData(hypre_ParVectorLocalVector(reinterpret_cast<hypre_ParVector*>(p)));
}

}  // namespace

/// The rows of the system as hypre reads them: scalar row r's (column, value) pairs, in column
/// order, from a Csr or straight from a Bcsr's block row r / 3 (no scalar copy is made).
struct RowSource {
  const Csr* csr = nullptr;
  const Bcsr* bcsr = nullptr;

  index_t rows() const { return csr ? csr->rows() : bcsr->rows(); }
  /// f(column, value) for each entry of scalar row r, in column order.
  template <class F>
  void for_each(index_t r, F&& f) const {
    if (csr) {
      const CsrPattern& p = csr->pattern();
      const double* v = csr->values().data();
      for (offset_t k = p.row_ptr[r]; k < p.row_ptr[r + 1]; ++k) f(p.col_idx[k], v[k]);
      return;
    }
    constexpr int B = Bcsr::kBlock;
    const BlockPattern& p = bcsr->pattern();
    const double* v = bcsr->values().data();
    const index_t I = r / B;
    const int rr = static_cast<int>(r % B);
    for (offset_t k = p.row_ptr[I]; k < p.row_ptr[I + 1]; ++k)
      for (int c = 0; c < B; ++c) f(B * p.col_idx[k] + c, v[Bcsr::kBlockSize * k + B * rr + c]);
  }
  /// f(column, value) for each entry of scalar row r that hypre keeps, in column order: the
  /// diagonal and the nonzeros (the exact zeros inside a matrix's 3x3 blocks, which an
  /// axis-aligned mesh has many of, are left out: they cost hypre's products and add nothing).
  template <class F>
  void for_each_kept(index_t r, F&& f) const {
    for_each(r, [&](index_t j, double v) {
      if (v != 0.0 || j == r) f(j, v);
    });
  }
  /// Whether every stored value is finite.
  bool all_finite() const {
    const std::vector<double>& v = csr ? csr->values() : bcsr->values();
    return ops::all_finite(v.data(), static_cast<std::int64_t>(v.size()));
  }
};

struct BoomerAMG::Impl {
  BoomerAMGParams params;  // num_functions as resolved by the last build (requested_functions: as given)
  int requested_functions = 0;
  RowSource source;          // the matrix set up on (a reference: it outlives the set-up)
  hypre_ParCSRMatrix* A = nullptr;  // this rank's rows, built here (no IJ copy); owned
  HYPRE_IJVector b = nullptr, x = nullptr;
  HYPRE_Solver solver = nullptr;
  std::vector<double> coordinates;          // x, y, z per node
  std::vector<HYPRE_IJVector> rigid;        // the rotations (owned here; hypre keeps pointers)
  std::vector<HYPRE_ParVector> rigid_par;
  int levels = 0;
  double grid_complexity = 0, operator_complexity = 0;
  HYPRE_Int lower = 0, upper = -1;
  std::vector<int> counts, displs;  // rows per rank, for gathering results

  void destroy() {
    if (solver) HYPRE_BoomerAMGDestroy(solver);
    for (HYPRE_IJVector v : rigid) HYPRE_IJVectorDestroy(v);
    rigid.clear();
    rigid_par.clear();
    solver = nullptr;
    if (A) hypre_ParCSRMatrixDestroy(A);
    if (b) HYPRE_IJVectorDestroy(b);
    if (x) HYPRE_IJVectorDestroy(x);
    A = nullptr, b = nullptr, x = nullptr;
  }
  ~Impl() {
    std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
    destroy();
  }
  /// Everything from the source's current values: hypre's matrix and vectors, then BoomerAMG's
  /// set-up (the steps below, in order). Throws InputError for NaN/Inf entries.
  void build();
  /// Contiguous row blocks of whole nodes per rank (counts, displs, lower, upper).
  void distribute_rows(index_t n);
  /// The rank's rows of the source as a ParCSR matrix (the diagonal first in each row of its
  /// diagonal part, as hypre's relaxations read it), filled on the threads; the IJ vectors b and
  /// x. Throws InputError for a row without a diagonal entry.
  void set_matrix();
  /// The kept entries' columns and values into A's arrays, sized by set_matrix().
  void fill_entries();
  /// The BoomerAMG keys onto the solver.
  void set_parameters(HYPRE_Solver s) const;
  /// The rigid-body rotations e_k x (X - c) as interpolation vectors (interp_vectors=3).
  void set_rigid_body_vectors(HYPRE_Solver s, index_t n);
  /// BoomerAMG's set-up on A (the solver made anew).
  void setup_solver(index_t n);
  /// Levels and complexities of the set-up hierarchy, from hypre's AMG data.
  void record_hierarchy(HYPRE_Solver s);
};

BoomerAMG::BoomerAMG(const BoomerAMGParams& params) : impl_(std::make_unique<Impl>()) {
  impl_->params = params;
  impl_->requested_functions = params.num_functions;
  if (params.num_functions < 0) throw InputError("BoomerAMG: num_functions must be >= 0 (0: from the matrix)");
  if (params.cycles < 1) throw InputError("BoomerAMG: cycles must be >= 1");
  if (!(params.strong_threshold > 0 && params.strong_threshold < 1))
    throw InputError("BoomerAMG: strong_threshold must lie in (0, 1)");
  if (params.interp_vectors != 0 && params.interp_vectors != 3)
    throw InputError("BoomerAMG: interp_vectors must be 0 (none) or 3 (the rigid-body rotations)");
  if (params.interp_vectors > 0 && params.num_functions != 3 && params.num_functions != 0)
    throw InputError("BoomerAMG: rigid-body interpolation vectors need num_functions=3");
  if (params.interp_vectors > 0 && params.nodal == 0)
    throw InputError("BoomerAMG: rigid-body interpolation vectors need nodal coarsening (hypre supports "
                     "them only there): set nodal=1..6, e.g. nodal=4");
}

void BoomerAMGParams::visit(ParamVisitor& v) {
  v.integer("cycles", cycles, 1, 1000, "V-cycles per application");
  v.integer("num_functions", num_functions, 0, 64,
            "unknowns per node (systems AMG), interleaved; 0: 3 where the matrix carries 3x3 blocks (BCSR, or a "
            "CSR whose three rows per node couple to the same nodes), else 1");
  v.integer("nodal", nodal, 0, 6, "0: unknown-based coarsening; 1-6: nodal, on a norm of each node's block");
  v.integer("nodal_diag", nodal_diag, 0, 2, "nodal: 1 = the nodal matrix's diagonal is minus its row sum");
  v.real("strong_threshold", strong_threshold, 1e-6, 1 - 1e-6, "strength of connection");
  v.integer("coarsen_type", coarsen_type, 0, 22, "10 HMIS, 8 PMIS, 6 Falgout, ...");
  v.integer("interp_type", interp_type, 0, 100, "6 extended+i, 0 classical, ...");
  v.integer("p_max", p_max_elements, 0, 1000, "interpolation entries per row (0: no limit)");
  v.real("trunc_factor", trunc_factor, 0.0, 1.0, "interpolation truncation factor");
  v.integer("relax_type", relax_type, 0, 100, "8 l1-symmetric Gauss-Seidel, 6 hybrid symmetric GS, 16 Chebyshev, ...");
  v.integer("relax_coarse", relax_coarse, 0, 100, "relaxation on the coarsest level (9: Gaussian elimination)");
  v.integer("relax_order", relax_order, 0, 1, "0 natural order, 1 C/F order");
  v.integer("sweeps", sweeps, 1, 100, "relaxation sweeps per level, down and up");
  v.integer("agg_levels", agg_levels, 0, 100, "levels of aggressive coarsening");
  v.integer("agg_interp_type", agg_interp_type, 1, 8, "interpolation on aggressive levels (4: multipass)");
  v.integer("max_levels", max_levels, 2, 100, "levels at most");
  v.integer("max_coarse_size", max_coarse_size, 1, 1000000, "coarsest level size at most");
  std::string vectors = interp_vectors > 0 ? "rigid" : "none";
  v.choice("interp_vectors", vectors, {"none", "rigid"},
           "rigid: the rotations from node coordinates as interpolation vectors (needs nodal)");
  interp_vectors = vectors == "rigid" ? 3 : 0;
  v.integer("interp_vec_variant", interp_vec_variant, 1, 3, "1, 2: GM approaches, 3: LN approach");
  v.integer("q_max", interp_vec_q_max, 0, 1000, "rigid: entries per row of each vector's interpolation (0: no limit)");
  v.integer("smooth_interp_vectors", smooth_interp_vectors, 0, 1, "rigid: 1 smooths the vectors on each level");
}

std::string to_string(const BoomerAMGParams& p) {
  std::string s;
  for (const KeyInfo& k : list_params(p)) s += (s.empty() ? "" : " ") + k.key + "=" + k.default_value;
  return s;
}

void BoomerAMG::set_coordinates(std::vector<double> xyz) { impl_->coordinates = std::move(xyz); }

int BoomerAMG::num_levels() const { return impl_->levels; }
double BoomerAMG::grid_complexity() const { return impl_->grid_complexity; }
double BoomerAMG::operator_complexity() const { return impl_->operator_complexity; }

std::string BoomerAMG::describe() const {
  std::ostringstream s;
  s << "BoomerAMG " << to_string(impl_->params);
  if (impl_->solver)
    s << "; " << impl_->levels << " levels, grid complexity " << impl_->grid_complexity
      << ", operator complexity " << impl_->operator_complexity;
  return s.str();
}

BoomerAMG::~BoomerAMG() = default;

const BoomerAMGParams& BoomerAMG::params() const { return impl_->params; }

void BoomerAMG::setup_impl(const LinearOperator& A) {
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  RowSource src{A.csr_matrix(), A.bcsr_matrix()};
  if (!src.csr && !src.bcsr)
    throw InputError("BoomerAMG needs the matrix entries as CSR or BCSR (convert BIN-BCSR or a "
                     "matrix-free operator first)");
  if (src.csr) src.bcsr = nullptr;
  Impl& d = *impl_;
  const int requested = d.requested_functions;
  const int functions = requested > 0 ? requested : src.bcsr || reads_as_blocks(*src.csr) ? 3 : 1;
  const index_t n = src.rows();
  if (n % functions != 0)
    throw InputError("BoomerAMG: the size " + std::to_string(n) + " is not a multiple of num_functions=" +
                     std::to_string(functions));
  if (d.params.interp_vectors > 0 && functions != 3)
    throw InputError("BoomerAMG: rigid-body interpolation vectors need 3x3 blocks (num_functions=3); this matrix "
                     "reads as a scalar system");
  d.params.num_functions = functions;
  d.source = src;
  d.build();
}

void BoomerAMG::update_impl() {
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  // New values may have new zeros (or lose them) and BoomerAMG's set-up depends on the values:
  // everything is built again.
  impl_->build();
}

void BoomerAMG::Impl::build() {
  if (!source.all_finite()) throw InputError("BoomerAMG: matrix has NaN/Inf entries");
  destroy();
  // hypre's error flag is global: clear what an earlier object's calls left (a Destroy of a nodal
  // hierarchy can flag an argument), so that this set-up reports only its own errors.
  HYPRE_ClearAllErrors();
  distribute_rows(source.rows());
  set_matrix();
  setup_solver(source.rows());
}

void BoomerAMG::Impl::distribute_rows(index_t n) {
  Impl& d = *this;
  const int size = mpi::size(), rank = mpi::rank();
  // Contiguous row blocks, whole nodes per rank.
  const index_t nodes = n / d.params.num_functions;
  d.counts.assign(size, 0);
  d.displs.assign(size, 0);
  for (int r = 0; r < size; ++r) {
    const index_t first = static_cast<index_t>(static_cast<long long>(nodes) * r / size);
    const index_t last = static_cast<index_t>(static_cast<long long>(nodes) * (r + 1) / size);
    d.displs[r] = d.params.num_functions * first;
    d.counts[r] = d.params.num_functions * (last - first);
  }
  d.lower = d.displs[rank];
  d.upper = d.displs[rank] + d.counts[rank] - 1;
}

void BoomerAMG::Impl::set_matrix() {
  Impl& d = *this;
  const RowSource& src = d.source;
  const index_t n = src.rows();
  const HYPRE_Int nlocal = d.upper - d.lower + 1;
  const HYPRE_Int lo = d.lower, hi = d.upper;
  // Entries per local row in the diagonal part (columns lower..upper) and the off-diagonal part.
  std::vector<offset_t> diag_len(nlocal), offd_len(nlocal);
  constexpr std::int64_t none = std::numeric_limits<std::int64_t>::max();
  std::int64_t no_diagonal = none;  // the first row without one
#pragma omp parallel for schedule(static) reduction(min : no_diagonal)
  for (HYPRE_Int i = 0; i < nlocal; ++i) {
    offset_t in = 0, out = 0;
    bool has_diagonal = false;
    src.for_each_kept(lo + i, [&](index_t j, double) {
      if (j >= lo && j <= hi) ++in; else ++out;
      has_diagonal = has_diagonal || j == lo + i;
    });
    diag_len[i] = in, offd_len[i] = out;
    if (!has_diagonal) no_diagonal = std::min<std::int64_t>(no_diagonal, lo + i);
  }
  // Every rank throws, or none does (the construction below is collective).
  if (mpi::size() > 1) MPI_Allreduce(MPI_IN_PLACE, &no_diagonal, 1, MPI_INT64_T, MPI_MIN, MPI_COMM_WORLD);
  if (no_diagonal != none)
    throw InputError("BoomerAMG: row " + std::to_string(no_diagonal) +
                     " has no diagonal entry (its relaxations divide by the diagonal)");
  offset_t nnz_diag = 0, nnz_offd = 0;
  for (HYPRE_Int i = 0; i < nlocal; ++i) nnz_diag += diag_len[i], nnz_offd += offd_len[i];
  if (nnz_diag > std::numeric_limits<HYPRE_Int>::max() || nnz_offd > std::numeric_limits<HYPRE_Int>::max())
    throw InputError("BoomerAMG: " + std::to_string(nnz_diag + nnz_offd) +
                     " entries on one rank exceed hypre's 32-bit index (this build has no HYPRE_BIGINT)");
  // The off-diagonal part's columns, sorted (hypre's col_map_offd).
  std::vector<HYPRE_BigInt> col_map;
  if (nnz_offd > 0) {
    col_map.reserve(nnz_offd);
    for (HYPRE_Int i = 0; i < nlocal; ++i)
      src.for_each_kept(lo + i, [&](index_t j, double) { if (j < lo || j > hi) col_map.push_back(j); });
    std::sort(col_map.begin(), col_map.end());
    col_map.erase(std::unique(col_map.begin(), col_map.end()), col_map.end());
  }
  HYPRE_BigInt starts[2] = {lo, hi + 1};
  d.A = hypre_ParCSRMatrixCreate(MPI_COMM_WORLD, n, n, starts, starts, static_cast<HYPRE_Int>(col_map.size()),
                                 static_cast<HYPRE_Int>(nnz_diag), static_cast<HYPRE_Int>(nnz_offd));
  check(hypre_ParCSRMatrixInitialize(d.A), "ParCSRMatrixInitialize");
  std::copy(col_map.begin(), col_map.end(), hypre_ParCSRMatrixColMapOffd(d.A));
  HYPRE_Int* di = hypre_CSRMatrixI(hypre_ParCSRMatrixDiag(d.A));
  HYPRE_Int* oi = hypre_CSRMatrixI(hypre_ParCSRMatrixOffd(d.A));
  di[0] = 0, oi[0] = 0;
  for (HYPRE_Int i = 0; i < nlocal; ++i) {
    di[i + 1] = di[i] + static_cast<HYPRE_Int>(diag_len[i]);
    oi[i + 1] = oi[i] + static_cast<HYPRE_Int>(offd_len[i]);
  }
  fill_entries();
  hypre_ParCSRMatrixSetNumNonzeros(d.A);
  check(hypre_MatvecCommPkgCreate(d.A), "MatvecCommPkgCreate");
  for (HYPRE_IJVector* v : {&d.b, &d.x}) {
    check(HYPRE_IJVectorCreate(MPI_COMM_WORLD, d.lower, d.upper, v), "IJVectorCreate");
    check(HYPRE_IJVectorSetObjectType(*v, HYPRE_PARCSR), "IJVectorSetObjectType");
    check(HYPRE_IJVectorInitialize(*v), "IJVectorInitialize");
    check(HYPRE_IJVectorAssemble(*v), "IJVectorAssemble");
  }
}

void BoomerAMG::Impl::fill_entries() {
  Impl& d = *this;
  const RowSource& src = d.source;
  const HYPRE_Int nlocal = d.upper - d.lower + 1;
  const HYPRE_Int lo = d.lower, hi = d.upper;
  hypre_CSRMatrix* diag = hypre_ParCSRMatrixDiag(d.A);
  hypre_CSRMatrix* offd = hypre_ParCSRMatrixOffd(d.A);
  const HYPRE_Int* di = hypre_CSRMatrixI(diag);
  HYPRE_Int* dj = hypre_CSRMatrixJ(diag);
  HYPRE_Complex* dv = hypre_CSRMatrixData(diag);
  const HYPRE_Int* oi = hypre_CSRMatrixI(offd);
  HYPRE_Int* oj = hypre_CSRMatrixJ(offd);
  HYPRE_Complex* ov = hypre_CSRMatrixData(offd);
  const HYPRE_BigInt* map = hypre_ParCSRMatrixColMapOffd(d.A);
  const HYPRE_Int nmap = hypre_CSRMatrixNumCols(offd);
  // Each row: the diagonal at its first position, the other columns after it in column order;
  // written on the threads (first touch of hypre's arrays where they will be read).
#pragma omp parallel for schedule(static)
  for (HYPRE_Int i = 0; i < nlocal; ++i) {
    HYPRE_Int pd = di[i] + 1, po = oi[i];
    src.for_each_kept(lo + i, [&](index_t j, double v) {
      if (j == lo + i) {
        dj[di[i]] = i, dv[di[i]] = v;
      } else if (j >= lo && j <= hi) {
        dj[pd] = j - lo, dv[pd] = v, ++pd;
      } else {
        oj[po] = static_cast<HYPRE_Int>(std::lower_bound(map, map + nmap, static_cast<HYPRE_BigInt>(j)) - map);
        ov[po] = v, ++po;
      }
    });
  }
}

void BoomerAMG::Impl::set_parameters(HYPRE_Solver s) const {
  const BoomerAMGParams& q = params;
  HYPRE_BoomerAMGSetPrintLevel(s, 0);
  HYPRE_BoomerAMGSetNumFunctions(s, q.num_functions);
  if (q.num_functions > 1 && q.nodal > 0) {
    HYPRE_BoomerAMGSetNodal(s, q.nodal);
    HYPRE_BoomerAMGSetNodalDiag(s, q.nodal_diag);
  }
  HYPRE_BoomerAMGSetStrongThreshold(s, q.strong_threshold);
  HYPRE_BoomerAMGSetCoarsenType(s, q.coarsen_type);
  HYPRE_BoomerAMGSetInterpType(s, q.interp_type);
  HYPRE_BoomerAMGSetPMaxElmts(s, q.p_max_elements);
  HYPRE_BoomerAMGSetTruncFactor(s, q.trunc_factor);
  HYPRE_BoomerAMGSetRelaxType(s, q.relax_type);        // every level, down and up
  HYPRE_BoomerAMGSetCycleRelaxType(s, q.relax_coarse, 3);  // then the coarsest level
  HYPRE_BoomerAMGSetRelaxOrder(s, q.relax_order);
  HYPRE_BoomerAMGSetNumSweeps(s, q.sweeps);
  HYPRE_BoomerAMGSetCycleNumSweeps(s, 1, 3);
  HYPRE_BoomerAMGSetAggNumLevels(s, q.agg_levels);
  HYPRE_BoomerAMGSetAggInterpType(s, q.agg_interp_type);
  HYPRE_BoomerAMGSetMaxLevels(s, q.max_levels);
  HYPRE_BoomerAMGSetMaxCoarseSize(s, q.max_coarse_size);
  HYPRE_BoomerAMGSetMaxIter(s, q.cycles);
  HYPRE_BoomerAMGSetTol(s, 0.0);
}

void BoomerAMG::Impl::set_rigid_body_vectors(HYPRE_Solver s, index_t n) {
  Impl& d = *this;
  const BoomerAMGParams& q = d.params;
  const HYPRE_Int nlocal = d.upper - d.lower + 1;
  // The rotations about the three axes, e_k x (X - c), from each node's position; the
  // translations are already in the unknown-based interpolation.
  if (static_cast<index_t>(d.coordinates.size()) != n)
    throw InputError("BoomerAMG: interp_vectors=rigid needs the node coordinates of the system (" +
                     std::to_string(n / 3) + " nodes); this system has " +
                     (d.coordinates.empty() ? std::string("none (only FEM scenes provide them)")
                                            : std::to_string(d.coordinates.size() / 3)));
  double c[3] = {0, 0, 0};
  for (index_t i = 0; i < n; ++i) c[i % 3] += d.coordinates[i] / static_cast<double>(n / 3);
  for (int k = 0; k < 3; ++k) {
    HYPRE_IJVector v;
    check(HYPRE_IJVectorCreate(MPI_COMM_WORLD, d.lower, d.upper, &v), "IJVectorCreate");
    d.rigid.push_back(v);
    check(HYPRE_IJVectorSetObjectType(v, HYPRE_PARCSR), "IJVectorSetObjectType");
    check(HYPRE_IJVectorInitialize(v), "IJVectorInitialize");
    double* values = local_data(v);
    for (HYPRE_Int i = 0; i < nlocal; ++i) {
      const index_t row = d.lower + i, node = row / 3;
      const int comp = static_cast<int>(row % 3);
      const double x[3] = {d.coordinates[3 * node] - c[0], d.coordinates[3 * node + 1] - c[1],
                           d.coordinates[3 * node + 2] - c[2]};
      // (e_k x x)_comp: rotation about axis k
      const int a = (k + 1) % 3, b = (k + 2) % 3;
      values[i] = comp == a ? -x[b] : comp == b ? x[a] : 0.0;
    }
    check(HYPRE_IJVectorAssemble(v), "IJVectorAssemble");
    HYPRE_ParVector pv;
    HYPRE_IJVectorGetObject(v, reinterpret_cast<void**>(&pv));
    d.rigid_par.push_back(pv);
  }
  HYPRE_BoomerAMGSetInterpVectors(s, 3, d.rigid_par.data());
  HYPRE_BoomerAMGSetInterpVecVariant(s, q.interp_vec_variant);
  HYPRE_BoomerAMGSetInterpVecQMax(s, q.interp_vec_q_max);
  HYPRE_BoomerAMGSetSmoothInterpVectors(s, q.smooth_interp_vectors);
}

void BoomerAMG::Impl::record_hierarchy(HYPRE_Solver s) {
  Impl& d = *this;
  // The hierarchy's sizes, from hypre's AMG data (no public getter for the complexities).
  auto* amg = reinterpret_cast<hypre_ParAMGData*>(s);
  d.levels = hypre_ParAMGDataNumLevels(amg);
  double rows0 = 0, nnz0 = 0, rows_sum = 0, nnz_sum = 0;
  for (int l = 0; l < d.levels; ++l) {
    hypre_ParCSRMatrix* Al = hypre_ParAMGDataAArray(amg)[l];
    hypre_ParCSRMatrixSetDNumNonzeros(Al);
    const double r = static_cast<double>(hypre_ParCSRMatrixGlobalNumRows(Al));
    const double z = hypre_ParCSRMatrixDNumNonzeros(Al);
    if (l == 0) rows0 = r, nnz0 = z;
    rows_sum += r, nnz_sum += z;
  }
  d.grid_complexity = rows0 > 0 ? rows_sum / rows0 : 0;
  d.operator_complexity = nnz0 > 0 ? nnz_sum / nnz0 : 0;
}

void BoomerAMG::Impl::setup_solver(index_t n) {
  Impl& d = *this;
  HYPRE_ParVector parb, parx;
  HYPRE_IJVectorGetObject(d.b, reinterpret_cast<void**>(&parb));
  HYPRE_IJVectorGetObject(d.x, reinterpret_cast<void**>(&parx));
  HYPRE_Solver s;
  check(HYPRE_BoomerAMGCreate(&s), "BoomerAMGCreate");
  d.solver = s;
  d.set_parameters(s);
  const BoomerAMGParams& q = d.params;
  if (q.interp_vectors > 0) d.set_rigid_body_vectors(s, n);
  const HYPRE_Int setup_error =
      HYPRE_BoomerAMGSetup(s, reinterpret_cast<HYPRE_ParCSRMatrix>(d.A), parb, parx);
  if (setup_error && q.interp_vectors > 0 && q.interp_vec_variant > 1) {
    HYPRE_ClearAllErrors();
    // Measured with hypre 2.26: the GM-2 and LN variants fail ("Error in argument 1") on the
    // Homer P3 system of docs/performance.md (any p_max) and on a 6x2x2 quadratic bar with p_max=4; GM-1 sets up.
    throw Error("hypre: BoomerAMGSetup failed with rigid-body interpolation vectors of variant " +
                std::to_string(q.interp_vec_variant) + " (p_max=" + std::to_string(q.p_max_elements) +
                "), which hypre does not manage on this matrix: try interp_vec_variant=1, or p_max=0");
  }
  check(setup_error, "BoomerAMGSetup");
  d.record_hierarchy(s);
}

void BoomerAMG::apply_impl(const Vector& r, Vector& z) const {
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  Impl& d = *impl_;
  const HYPRE_Int nlocal = d.upper - d.lower + 1;
  HYPRE_ParVector parb, parx;
  HYPRE_IJVectorGetObject(d.b, reinterpret_cast<void**>(&parb));
  HYPRE_IJVectorGetObject(d.x, reinterpret_cast<void**>(&parx));
  double* b = local_data(d.b);
  double* x = local_data(d.x);
  std::copy(r.data() + d.lower, r.data() + d.lower + nlocal, b);
  std::fill(x, x + nlocal, 0.0);
  check(HYPRE_BoomerAMGSolve(d.solver, reinterpret_cast<HYPRE_ParCSRMatrix>(d.A), parb, parx), "BoomerAMGSolve");
  if (mpi::size() == 1) {
    std::copy(x, x + nlocal, z.data());
  } else {
    MPI_Allgatherv(x, nlocal, MPI_DOUBLE, z.data(), d.counts.data(), d.displs.data(), MPI_DOUBLE, MPI_COMM_WORLD);
  }
}


namespace {

/// BoomerAMG with the context's node coordinates (for rigid-body interpolation vectors).
std::unique_ptr<BoomerAMG> make_boomeramg(const Config& c, const SolverContext& ctx) {
  auto amg = std::make_unique<BoomerAMG>(read_params<BoomerAMGParams>(c));
  if (amg->params().interp_vectors > 0) {
    if (!ctx.coordinates)
      c.fail("interp_vectors", "rigid needs node coordinates: an FEM scene (--box or --mesh) provides "
                               "them; a matrix read from a file does not");
    amg->set_coordinates(*ctx.coordinates);
  }
  return amg;
}

}  // namespace

void register_solvers() {
  static std::once_flag once;
  std::call_once(once, [] {
    const std::vector<KeyInfo> amg = list_params<BoomerAMGParams>();
    auto start = [] { mpi::start(); };
    register_builtin_solver({"boomeramg-pcg", "CG preconditioned by hypre BoomerAMG V-cycles", krylov_keys() + amg, false,
                     false, "hypre", start},
                    [](const Config& c, const SolverContext& ctx) -> std::unique_ptr<Solver> {
                      const KrylovParams k = read_krylov(c);
                      return std::make_unique<Cg>(k, make_boomeramg(c, ctx));
                    });
    register_builtin_solver({"boomeramg", "hypre BoomerAMG V-cycles (a fixed symmetric operator)", amg, false, false,
                     "hypre", start},
                    [](const Config& c, const SolverContext& ctx) -> std::unique_ptr<Solver> {
                      return make_boomeramg(c, ctx);
                    });
  });
}

}  // namespace pmg::hypre
