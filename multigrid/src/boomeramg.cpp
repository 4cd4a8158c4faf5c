#include "pmg/multigrid/boomeramg.hpp"

#include <HYPRE.h>
#include <HYPRE_parcsr_ls.h>
#include <mpi.h>

#include <chrono>
#include <cmath>
#include <limits>
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
  HYPRE_Int lower = 0, upper = -1;
  std::vector<int> counts, displs;  // rows per rank, for gathering results
  std::vector<HYPRE_Int> local_rows;

  void destroy() {
    if (solver) HYPRE_BoomerAMGDestroy(solver);
    if (ij) HYPRE_IJMatrixDestroy(ij);
    if (b) HYPRE_IJVectorDestroy(b);
    if (x) HYPRE_IJVectorDestroy(x);
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
  HYPRE_BoomerAMGSetPrintLevel(s, 0);
  HYPRE_BoomerAMGSetNumFunctions(s, d.params.num_functions);
  if (d.params.num_functions > 1) {
    HYPRE_BoomerAMGSetNodal(s, d.params.nodal);
    HYPRE_BoomerAMGSetNodalDiag(s, 1);
  }
  HYPRE_BoomerAMGSetStrongThreshold(s, d.params.strong_threshold);
  HYPRE_BoomerAMGSetCoarsenType(s, d.params.coarsen_type);
  HYPRE_BoomerAMGSetInterpType(s, d.params.interp_type);
  HYPRE_BoomerAMGSetPMaxElmts(s, d.params.p_max_elements);
  HYPRE_BoomerAMGSetRelaxType(s, d.params.relax_type);
  HYPRE_BoomerAMGSetAggNumLevels(s, 0);
  HYPRE_BoomerAMGSetMaxIter(s, d.params.cycles);
  HYPRE_BoomerAMGSetTol(s, 0.0);
  check(HYPRE_BoomerAMGSetup(s, parA, parb, parx), "BoomerAMGSetup");
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
