#include "pmg/multigrid/boomeramg.hpp"

#include <HYPRE.h>
#include <HYPRE_parcsr_ls.h>
#include <_hypre_parcsr_ls.h>  // hypre_ParAMGData: the hierarchy, for the complexities
#include <mpi.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

namespace pmg::mg {

namespace {

/// Initialises MPI once; finalises it at exit if we initialised it.
struct MpiSession {
  bool owned = false;
  MpiSession() {
    int initialized = 0;
    MPI_Initialized(&initialized);
    if (!initialized) {
      MPI_Init(nullptr, nullptr);
      owned = true;
    }
  }
  ~MpiSession() {
    int finalized = 0;
    MPI_Finalized(&finalized);
    if (owned && !finalized) MPI_Finalize();
  }
};

MpiSession& mpi() {
  static MpiSession session;
  return session;
}

void check(HYPRE_Int err, const char* what) {
  if (err) {
    char msg[256];
    HYPRE_DescribeError(err, msg);
    HYPRE_ClearAllErrors();
    throw Error(std::string("hypre: ") + what + " failed: " + msg);
  }
}

}  // namespace

int mpi_rank() {
  mpi();
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}

int mpi_size() {
  mpi();
  int s = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &s);
  return s;
}

struct BoomerAMG::Impl {
  BoomerAMGParams params;
  HYPRE_IJMatrix ij = nullptr;
  HYPRE_IJVector b = nullptr, x = nullptr;
  HYPRE_Solver solver = nullptr;
  std::vector<double> coordinates;          // x, y, z per node
  std::vector<HYPRE_IJVector> rigid;        // the rotations (owned here; hypre keeps pointers)
  std::vector<HYPRE_ParVector> rigid_par;
  int levels = 0;
  double grid_complexity = 0, operator_complexity = 0;
  HYPRE_Int lower = 0, upper = -1;
  std::vector<int> counts, displs;  // rows per rank, for gathering results
  std::vector<HYPRE_Int> local_rows;

  void destroy() {
    if (solver) HYPRE_BoomerAMGDestroy(solver);
    if (ij) HYPRE_IJMatrixDestroy(ij);
    if (b) HYPRE_IJVectorDestroy(b);
    if (x) HYPRE_IJVectorDestroy(x);
    for (HYPRE_IJVector v : rigid) HYPRE_IJVectorDestroy(v);
    rigid.clear();
    rigid_par.clear();
    solver = nullptr, ij = nullptr, b = nullptr, x = nullptr;
  }
  ~Impl() { destroy(); }
};

BoomerAMG::BoomerAMG(const BoomerAMGParams& params) : impl_(std::make_unique<Impl>()) {
  impl_->params = params;
  if (params.num_functions < 1) throw InputError("BoomerAMG: num_functions must be >= 1");
  if (params.cycles < 1) throw InputError("BoomerAMG: cycles must be >= 1");
  if (!(params.strong_threshold > 0 && params.strong_threshold < 1))
    throw InputError("BoomerAMG: strong_threshold must lie in (0, 1)");
  if (params.interp_vectors != 0 && params.interp_vectors != 3)
    throw InputError("BoomerAMG: interp_vectors must be 0 (none) or 3 (the rigid-body rotations)");
  if (params.interp_vectors > 0 && params.num_functions != 3)
    throw InputError("BoomerAMG: rigid-body interpolation vectors need num_functions=3");
  if (params.interp_vectors > 0 && params.nodal == 0)
    throw InputError("BoomerAMG: rigid-body interpolation vectors need nodal coarsening (hypre supports "
                     "them only there): set nodal=1..6, e.g. nodal=4");
}

std::string to_string(const BoomerAMGParams& p) {
  std::ostringstream s;
  s << "num_functions=" << p.num_functions << " nodal=" << p.nodal;
  if (p.nodal) s << " nodal_diag=" << p.nodal_diag;
  s << " coarsen_type=" << p.coarsen_type << " strong_threshold=" << p.strong_threshold
    << " interp_type=" << p.interp_type << " p_max=" << p.p_max_elements
    << " trunc_factor=" << p.trunc_factor << " relax_type=" << p.relax_type
    << " relax_coarse=" << p.relax_coarse << " relax_order=" << p.relax_order
    << " sweeps=" << p.sweeps << " agg_levels=" << p.agg_levels;
  if (p.agg_levels) s << " agg_interp_type=" << p.agg_interp_type;
  s << " max_levels=" << p.max_levels << " max_coarse_size=" << p.max_coarse_size
    << " interp_vectors=" << (p.interp_vectors ? "rigid" : "none");
  if (p.interp_vectors) s << " interp_vec_variant=" << p.interp_vec_variant;
  s << " cycles=" << p.cycles;
  return s.str();
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
  scalar_.setup(A, "BoomerAMG");
  build(scalar_.csr());
}

void BoomerAMG::update_impl() {
  scalar_.refresh();
  build(scalar_.csr());
}

void BoomerAMG::build(const Csr& A) {
  if (A.rows() % impl_->params.num_functions != 0)
    throw InputError("BoomerAMG: size is not a multiple of the number of functions");
  for (double v : A.values())
    if (!std::isfinite(v)) throw InputError("BoomerAMG: matrix has NaN/Inf entries");
  Impl& d = *impl_;
  d.destroy();
  // hypre's error flag is global: clear what an earlier object's calls left (a Destroy of a nodal
  // hierarchy can flag an argument), so that this set-up reports only its own errors.
  HYPRE_ClearAllErrors();
  const index_t n = A.rows();
  const int size = mpi_size(), rank = mpi_rank();
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
  const CsrPattern& p = A.pattern();

  check(HYPRE_IJMatrixCreate(MPI_COMM_WORLD, d.lower, d.upper, d.lower, d.upper, &d.ij), "IJMatrixCreate");
  check(HYPRE_IJMatrixSetObjectType(d.ij, HYPRE_PARCSR), "IJMatrixSetObjectType");
  check(HYPRE_IJMatrixInitialize(d.ij), "IJMatrixInitialize");
  const HYPRE_Int nlocal = d.upper - d.lower + 1;
  std::vector<HYPRE_Int> ncols(nlocal), rows(nlocal), cols;
  std::vector<double> vals;
  for (HYPRE_Int i = 0; i < nlocal; ++i) {
    const index_t row = d.lower + i;
    rows[i] = row;
    ncols[i] = static_cast<HYPRE_Int>(p.row_ptr[row + 1] - p.row_ptr[row]);
    cols.insert(cols.end(), p.col_idx.begin() + p.row_ptr[row], p.col_idx.begin() + p.row_ptr[row + 1]);
    vals.insert(vals.end(), A.values().begin() + p.row_ptr[row], A.values().begin() + p.row_ptr[row + 1]);
  }
  if (nlocal > 0)
    check(HYPRE_IJMatrixSetValues(d.ij, nlocal, ncols.data(), rows.data(), cols.data(), vals.data()),
          "IJMatrixSetValues");
  check(HYPRE_IJMatrixAssemble(d.ij), "IJMatrixAssemble");
  d.local_rows = rows;
  for (HYPRE_IJVector* v : {&d.b, &d.x}) {
    check(HYPRE_IJVectorCreate(MPI_COMM_WORLD, d.lower, d.upper, v), "IJVectorCreate");
    check(HYPRE_IJVectorSetObjectType(*v, HYPRE_PARCSR), "IJVectorSetObjectType");
    check(HYPRE_IJVectorInitialize(*v), "IJVectorInitialize");
    check(HYPRE_IJVectorAssemble(*v), "IJVectorAssemble");
  }
  HYPRE_ParCSRMatrix parA;
  HYPRE_ParVector parb, parx;
  HYPRE_IJMatrixGetObject(d.ij, reinterpret_cast<void**>(&parA));
  HYPRE_IJVectorGetObject(d.b, reinterpret_cast<void**>(&parb));
  HYPRE_IJVectorGetObject(d.x, reinterpret_cast<void**>(&parx));

  HYPRE_Solver s;
  check(HYPRE_BoomerAMGCreate(&s), "BoomerAMGCreate");
  d.solver = s;
  const BoomerAMGParams& q = d.params;
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
  if (q.interp_vectors > 0) {
    // The rotations about the three axes, e_k x (X - c), from each node's position; the
    // translations are already in the unknown-based interpolation.
    if (static_cast<index_t>(d.coordinates.size()) != n)
      throw InputError("BoomerAMG: interp_vectors=rigid needs the node coordinates of the system (" +
                       std::to_string(n / 3) + " nodes); this system has " +
                       (d.coordinates.empty() ? std::string("none (only FEM scenes provide them)")
                                              : std::to_string(d.coordinates.size() / 3)));
    double c[3] = {0, 0, 0};
    for (index_t i = 0; i < n; ++i) c[i % 3] += d.coordinates[i] / static_cast<double>(n / 3);
    std::vector<double> values(nlocal);
    for (int k = 0; k < 3; ++k) {
      HYPRE_IJVector v;
      check(HYPRE_IJVectorCreate(MPI_COMM_WORLD, d.lower, d.upper, &v), "IJVectorCreate");
      d.rigid.push_back(v);
      check(HYPRE_IJVectorSetObjectType(v, HYPRE_PARCSR), "IJVectorSetObjectType");
      check(HYPRE_IJVectorInitialize(v), "IJVectorInitialize");
      for (HYPRE_Int i = 0; i < nlocal; ++i) {
        const index_t row = d.lower + i, node = row / 3;
        const int comp = static_cast<int>(row % 3);
        const double x[3] = {d.coordinates[3 * node] - c[0], d.coordinates[3 * node + 1] - c[1],
                             d.coordinates[3 * node + 2] - c[2]};
        // (e_k x x)_comp: rotation about axis k
        const int a = (k + 1) % 3, b = (k + 2) % 3;
        values[i] = comp == a ? -x[b] : comp == b ? x[a] : 0.0;
      }
      if (nlocal > 0) check(HYPRE_IJVectorSetValues(v, nlocal, rows.data(), values.data()), "IJVectorSetValues");
      check(HYPRE_IJVectorAssemble(v), "IJVectorAssemble");
      HYPRE_ParVector pv;
      HYPRE_IJVectorGetObject(v, reinterpret_cast<void**>(&pv));
      d.rigid_par.push_back(pv);
    }
    HYPRE_BoomerAMGSetInterpVectors(s, 3, d.rigid_par.data());
    HYPRE_BoomerAMGSetInterpVecVariant(s, q.interp_vec_variant);
  }
  const HYPRE_Int setup_error = HYPRE_BoomerAMGSetup(s, parA, parb, parx);
  if (setup_error && q.interp_vectors > 0 && q.interp_vec_variant > 1) {
    HYPRE_ClearAllErrors();
    // Measured with hypre 2.26: the GM-2 and LN variants fail ("Error in argument 1") on the
    // README's Homer P3 (any p_max) and on a 6x2x2 quadratic bar with p_max=4; GM-1 sets up.
    throw Error("hypre: BoomerAMGSetup failed with rigid-body interpolation vectors of variant " +
                std::to_string(q.interp_vec_variant) + " (p_max=" + std::to_string(q.p_max_elements) +
                "), which hypre does not manage on this matrix: try interp_vec_variant=1, or p_max=0");
  }
  check(setup_error, "BoomerAMGSetup");
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

void BoomerAMG::apply_impl(const Vector& r, Vector& z) const {
  Impl& d = *impl_;
  const HYPRE_Int nlocal = d.upper - d.lower + 1;
  std::vector<double> zeros(nlocal, 0.0);
  if (nlocal > 0) {
    HYPRE_IJVectorSetValues(d.b, nlocal, d.local_rows.data(), r.data() + d.lower);
    HYPRE_IJVectorSetValues(d.x, nlocal, d.local_rows.data(), zeros.data());
  }
  HYPRE_IJVectorAssemble(d.b);
  HYPRE_IJVectorAssemble(d.x);
  HYPRE_ParCSRMatrix parA;
  HYPRE_ParVector parb, parx;
  HYPRE_IJMatrixGetObject(d.ij, reinterpret_cast<void**>(&parA));
  HYPRE_IJVectorGetObject(d.b, reinterpret_cast<void**>(&parb));
  HYPRE_IJVectorGetObject(d.x, reinterpret_cast<void**>(&parx));
  check(HYPRE_BoomerAMGSolve(d.solver, parA, parb, parx), "BoomerAMGSolve");
  std::vector<double> local(nlocal);
  if (nlocal > 0) HYPRE_IJVectorGetValues(d.x, nlocal, d.local_rows.data(), local.data());
  if (mpi_size() == 1) {
    std::copy(local.begin(), local.end(), z.data());
  } else {
    MPI_Allgatherv(local.data(), nlocal, MPI_DOUBLE, z.data(), d.counts.data(), d.displs.data(),
                   MPI_DOUBLE, MPI_COMM_WORLD);
  }
}

double start_mpi_for_hypre(const Config& config) {
  bool hypre = false;
  for (const auto& kv : config.items()) hypre |= kv.second.rfind("boomeramg", 0) == 0;
  if (!hypre) return -1.0;
  const auto t0 = std::chrono::steady_clock::now();
  mpi_size();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace pmg::mg
