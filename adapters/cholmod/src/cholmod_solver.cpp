#include "pmg/cholmod/cholmod_solver.hpp"

#include "pmg/sparse/bcsr.hpp"
#include "pmg/sparse/timer.hpp"

#include <cholmod.h>
#include <dlfcn.h>
#include <omp.h>

#include <chrono>
#include <cstdio>
#include <cmath>
#include <mutex>
#include <string>

namespace pmg {

namespace {

// OpenBLAS's thread count, found at run time in the BLAS that CHOLMOD's library resolves dgemm_
// to (a build against another BLAS, or none loaded, finds nothing and changes nothing).
struct BlasThreadControl {
  using SetFn = void (*)(int);
  using GetFn = int (*)();
  using ShutdownFn = int (*)();
  SetFn set = nullptr;
  GetFn get = nullptr;
  ShutdownFn shutdown = nullptr;  // ends the worker threads (re-created by the next threaded call)

  static const BlasThreadControl& instance() {
    static const BlasThreadControl control = [] {
      BlasThreadControl c;
      Dl_info cholmod_lib{}, blas_lib{};
      if (!dladdr(reinterpret_cast<void*>(&cholmod_l_start), &cholmod_lib) || !cholmod_lib.dli_fname)
        return c;
      // RTLD_NOLOAD: only libraries already loaded; the handles stay open (they are in use).
      void* cholmod_handle = dlopen(cholmod_lib.dli_fname, RTLD_LAZY | RTLD_NOLOAD);
      void* dgemm = cholmod_handle ? dlsym(cholmod_handle, "dgemm_") : nullptr;
      if (!dgemm || !dladdr(dgemm, &blas_lib) || !blas_lib.dli_fname) return c;
      void* blas = dlopen(blas_lib.dli_fname, RTLD_LAZY | RTLD_NOLOAD);
      if (!blas) return c;
      c.set = reinterpret_cast<SetFn>(dlsym(blas, "openblas_set_num_threads"));
      c.get = reinterpret_cast<GetFn>(dlsym(blas, "openblas_get_num_threads"));
      if (!c.set || !c.get) c.set = nullptr, c.get = nullptr;
      // OpenBLAS's own pthread_atfork handler uses it: safe while no BLAS call runs.
      if (c.set) c.shutdown = reinterpret_cast<ShutdownFn>(dlsym(blas, "blas_thread_shutdown_"));
      return c;
    }();
    return control;
  }
};

// The threads of one CHOLMOD call, restored after it (threads <= 0: untouched): OpenBLAS's thread
// count and, on one thread, CHOLMOD's own OpenMP regions too. CHOLMOD 3's supernodal factorisation
// (SuiteSparse 5.12, Debian 12) copies each large supernode's columns in a parallel region whose
// thread count is fixed when CHOLMOD is compiled (CHOLMOD_OMP_NUM_THREADS, 4), whatever the
// machine: on few cores, and between pmgkit's OpenMP kernels, waking and waiting for those threads
// at every supernode costs a refactorisation about twice its CPU time in wall time (measured in
// CHANGELOG.md's history). With no active parallel
// level allowed, those regions run on the calling thread. libgomp (GCC 12) and LLVM's libomp keep
// that setting per thread, so calls on other threads are not affected.
class ScopedCholmodThreads {
 public:
  explicit ScopedCholmodThreads(int threads) {
    if (threads == 1) {
      previous_levels_ = omp_get_max_active_levels();
      omp_set_max_active_levels(0);
    }
    const BlasThreadControl& c = BlasThreadControl::instance();
    if (threads <= 0 || !c.set) return;
    previous_blas_ = c.get();
    if (previous_blas_ != threads) c.set(threads);
    else previous_blas_ = 0;
  }
  ~ScopedCholmodThreads() {
    if (previous_blas_ > 0) BlasThreadControl::instance().set(previous_blas_);
    if (previous_levels_ >= 0) omp_set_max_active_levels(previous_levels_);
  }
  ScopedCholmodThreads(const ScopedCholmodThreads&) = delete;
  ScopedCholmodThreads& operator=(const ScopedCholmodThreads&) = delete;

 private:
  int previous_blas_ = 0;     // > 0: OpenBLAS's count to restore
  int previous_levels_ = -1;  // >= 0: the calling thread's max-active-levels to restore
};

// Factorisations of fewer flops run on the solves' BLAS threads (factor_threads is ignored).
constexpr double kThreadedFactorFlops = 1e9;

// The entries of a symmetric pattern's rows on or left of the diagonal: row r's are column r of
// the upper triangle in CSC (p, i); `from` (when given) receives their positions in the pattern.
void upper_triangle(const CsrPattern& pat, std::vector<SuiteSparse_long>& p, std::vector<SuiteSparse_long>& i,
                    std::vector<offset_t>* from) {
  p.assign(static_cast<std::size_t>(pat.rows) + 1, 0);
  i.clear();
  i.reserve((pat.nnz() + pat.rows) / 2);
  if (from) from->clear(), from->reserve((pat.nnz() + pat.rows) / 2);
  for (index_t r = 0; r < pat.rows; ++r) {
    for (offset_t k = pat.row_ptr[r]; k < pat.row_ptr[r + 1] && pat.col_idx[k] <= r; ++k) {
      i.push_back(pat.col_idx[k]);
      if (from) from->push_back(k);
    }
    p[r + 1] = static_cast<SuiteSparse_long>(i.size());
  }
}

// CHOLMOD's view of such an upper triangle (no copy); values nullptr: the pattern alone.
cholmod_sparse upper_view(std::vector<SuiteSparse_long>& p, std::vector<SuiteSparse_long>& i, double* values) {
  cholmod_sparse A{};
  A.nrow = A.ncol = p.size() - 1;
  A.nzmax = i.size();
  A.p = p.data();
  A.i = i.data();
  A.x = values;
  A.stype = 1;
  A.itype = CHOLMOD_LONG;
  A.xtype = values ? CHOLMOD_REAL : CHOLMOD_PATTERN;
  A.dtype = CHOLMOD_DOUBLE;
  A.sorted = 1;
  A.packed = 1;
  return A;
}

}  // namespace

// CHOLMOD's long-integer interface (cholmod_l_*): our row pointers are 64-bit. CHOLMOD reads one
// triangle of a symmetric matrix, so it is handed only that one: analyze() keeps the pattern of the
// CSR rows' entries on or left of the diagonal (as CSC: the upper triangle, stype = 1) and where
// they sit in the full values; factorize() gathers those values. Handing it both triangles (as
// before) made its permuted transposes in analysis and factorisation read twice the entries.
struct CholmodSolver::Impl {
  cholmod_common common;
  cholmod_factor* factor = nullptr;
  std::shared_ptr<const CsrPattern> pattern;
  std::vector<SuiteSparse_long> p, i;  // the triangle's pattern
  std::vector<offset_t> from;          // its entries' positions in the full CSR values
  std::vector<double> x;               // its values
  bool factorized = false;
  bool block_ordering = false;         // the ordering was computed on the 3x3 blocks' graph
  double flops = 0;                    // of one numeric factorisation, from the analysis
  double analyze_seconds = 0, factorize_seconds = 0;
  // cholmod_l_solve2's result and workspaces, kept from one solve to the next: cholmod_l_solve
  // allocated the result (and freed its workspace) on every call, fresh pages each time (a lowest
  // level is solved once per cycle). Concurrent calls on one solver are serialised by the Solver's
  // own lock (pmg/sparse/solver.hpp).
  cholmod_dense* X = nullptr;
  cholmod_dense* Y = nullptr;
  cholmod_dense* E = nullptr;

  Impl() {
    cholmod_l_start(&common);
    common.supernodal = CHOLMOD_SUPERNODAL;
    common.print = 0;  // errors are reported by exceptions, not printed by CHOLMOD
  }
  ~Impl() {
    for (cholmod_dense** w : {&X, &Y, &E})
      if (*w) cholmod_l_free_dense(w, &common);
    if (factor) cholmod_l_free_factor(&factor, &common);
    cholmod_l_finish(&common);
  }
  cholmod_sparse view(const double* values) { return upper_view(p, i, const_cast<double*>(values)); }
};

CholmodSolver::CholmodSolver(const std::string& ordering, int blas_threads, int factor_threads)
    : impl_(std::make_unique<Impl>()),
      blas_threads_(blas_threads),
      factor_threads_(factor_threads < 0 ? blas_threads : factor_threads) {
  if (blas_threads < 0) throw InputError("CHOLMOD: blas_threads must be >= 0 (0: the BLAS's own setting)");
  if (factor_threads < -1)
    throw InputError("CHOLMOD: factor_threads must be >= -1 (-1: blas_threads, 0: the BLAS's own setting)");
  cholmod_common& c = impl_->common;
  if (ordering == "auto") return;
  int method = 0;
  if (ordering == "amd")
    method = CHOLMOD_AMD;
  else if (ordering == "metis")
    method = CHOLMOD_METIS;
  else if (ordering == "nesdis")
    method = CHOLMOD_NESDIS;
  else
    throw InputError("CHOLMOD: unknown ordering '" + ordering + "' (auto, amd, metis, nesdis)");
  c.nmethods = 1;
  c.method[0].ordering = method;
}
CholmodSolver::~CholmodSolver() = default;

namespace {

/// CHOLMOD's status code in words.
std::string status_text(int status) {
  switch (status) {
    case CHOLMOD_OK: return "status 0, ok";
    case CHOLMOD_NOT_INSTALLED: return "status -1: a CHOLMOD module is not installed";
    case CHOLMOD_OUT_OF_MEMORY: return "status -2: out of memory";
    case CHOLMOD_TOO_LARGE: return "status -3: the problem is too large for CHOLMOD's integers";
    case CHOLMOD_INVALID: return "status -4: CHOLMOD found its input invalid";
    case CHOLMOD_NOT_POSDEF: return "status 1: the matrix is not positive definite";
    case CHOLMOD_DSMALL: return "status 2: a diagonal entry of the factor is tiny (nearly singular)";
    default: return "status " + std::to_string(status);
  }
}

/// A symmetric positive definite matrix has a diagonal entry in every row (checked on the pattern
/// at analysis) and a positive one (checked with `values` at factorisation): a missing, zero or
/// negative one, an all-zero matrix included, is named before CHOLMOD sees it ("status -4").
void check_diagonal(const Csr& A, bool values) {
  const auto& rp = A.pattern().row_ptr;
  const auto& ci = A.pattern().col_idx;
  for (index_t i = 0; i < A.rows(); ++i) {
    double d = 0.0;
    bool found = false;
    for (auto k = rp[i]; k < rp[i + 1]; ++k)
      if (ci[k] == i) d += A.values()[k], found = true;
    if (!found || (values && !(d > 0.0)))
      throw InputError("CHOLMOD: the matrix is not positive definite: its diagonal entry at row " + std::to_string(i) +
                       (found ? " is " + std::to_string(d) : " is missing") +
                       (A.nnz() == 0 ? " (the matrix has no nonzero entries)" : ""));
  }
}

}  // namespace

void CholmodSolver::analyze(const Csr& A, const CsrPattern* blocks) {
  if (A.rows() != A.cols()) throw InputError("CHOLMOD: matrix is not square");
  check_diagonal(A, /*values=*/false);
  Impl& d = *impl_;
  if (d.factor) cholmod_l_free_factor(&d.factor, &d.common);
  d.factorized = false;
  const auto t0 = Clock::now();
  d.pattern = A.shared_pattern();
  const CsrPattern& pat = A.pattern();
  n_ = A.rows();
  upper_triangle(pat, d.p, d.i, &d.from);
  d.x.resize(d.i.size());
  cholmod_sparse view = d.view(nullptr);
  d.block_ordering = blocks && d.common.nmethods == 1 && d.common.method[0].ordering == CHOLMOD_METIS &&
                     Bcsr::kBlock * static_cast<offset_t>(blocks->rows) == n_;
  if (d.block_ordering) {
    // METIS on the graph of the nodes (the blocks' upper triangle, as CSC), expanded to the
    // unknowns; CHOLMOD then analyses with that ordering (its elimination-tree postordering kept).
    const index_t nb = blocks->rows;
    std::vector<SuiteSparse_long> bp, bi;
    upper_triangle(*blocks, bp, bi, nullptr);
    cholmod_sparse B = upper_view(bp, bi, nullptr);
    std::vector<SuiteSparse_long> node_perm(static_cast<std::size_t>(nb)), perm(static_cast<std::size_t>(n_));
    if (!cholmod_l_metis(&B, nullptr, 0, 0, node_perm.data(), &d.common))
      throw Error("CHOLMOD: METIS ordering of the blocks failed (" + status_text(d.common.status) + ")");
    for (index_t k = 0; k < nb; ++k)
      for (int c = 0; c < Bcsr::kBlock; ++c) perm[Bcsr::kBlock * k + c] = Bcsr::kBlock * node_perm[k] + c;
    d.common.method[0].ordering = CHOLMOD_GIVEN;
    d.factor = cholmod_l_analyze_p(&view, perm.data(), nullptr, 0, &d.common);
    d.common.method[0].ordering = CHOLMOD_METIS;
  } else {
    d.factor = cholmod_l_analyze(&view, &d.common);
  }
  d.analyze_seconds = seconds_since(t0);
  d.flops = d.common.fl;
  if (!d.factor || d.common.status < CHOLMOD_OK)
    throw Error("CHOLMOD: symbolic analysis failed (" + status_text(d.common.status) + ")");
}

void CholmodSolver::factorize(const Csr& A) {
  Impl& d = *impl_;
  if (!d.factor) throw Error("CHOLMOD: factorize() before analyze()");
  if (A.shared_pattern() != d.pattern && (A.pattern().row_ptr != d.pattern->row_ptr ||
                                          A.pattern().col_idx != d.pattern->col_idx))
    throw InputError("CHOLMOD: factorize() with a pattern other than the analysed one");
  for (double v : A.values())
    if (!std::isfinite(v)) throw InputError("CHOLMOD: matrix has NaN/Inf entries");
  check_diagonal(A, /*values=*/true);
  d.factorized = false;
  const auto t0 = Clock::now();
  const double* values = A.values().data();
  const std::size_t m = d.from.size();
  for (std::size_t k = 0; k < m; ++k) d.x[k] = values[d.from[k]];
  cholmod_sparse view = d.view(d.x.data());
  // A small factorisation runs with the solves' threads: starting and ending workers would cost
  // more than they save (the twisted Homer's linear level, 4.5e7 flops, is refactorised every step).
  const int threads = d.flops < kThreadedFactorFlops ? blas_threads_ : factor_threads_;
  {
    ScopedCholmodThreads scoped(threads);
    cholmod_l_factorize(&view, d.factor, &d.common);
  }
  // Threaded factorisation, serial solves: the workers would otherwise spin on for a while after
  // the factorisation, beside the caller's OpenMP kernels.
  if (blas_threads_ == 1 && threads != 1 && BlasThreadControl::instance().shutdown)
    BlasThreadControl::instance().shutdown();
  d.factorize_seconds = seconds_since(t0);
  if (d.common.status == CHOLMOD_NOT_POSDEF || d.factor->minor < d.factor->n) {
    // CHOLMOD reads one triangle: a matrix that is not symmetric (Dirichlet rows replaced by
    // identity rows, their columns kept) fails here, and says so only when checked (on failure).
    const bool symmetric = A.is_symmetric(1e-12);
    throw Error("CHOLMOD: matrix is not positive definite (factorisation fails at column " +
                std::to_string(d.factor->minor) + " of " + std::to_string(d.factor->n) + ")" +
                (symmetric ? ""
                           : "; it is not symmetric either: CHOLMOD reads one triangle only; if Dirichlet rows "
                             "were replaced by identity rows, zero their columns too (a symmetric elimination)"));
  }
  if (d.common.status < CHOLMOD_OK)
    throw Error("CHOLMOD: numeric factorisation failed (" + status_text(d.common.status) + ")");
  d.factorized = true;
}

double CholmodSolver::factor_nnz() const {
  return impl_->factorized ? impl_->common.lnz : 0.0;
}

namespace {
const char* ordering_name(int ordering) {
  switch (ordering) {
    case CHOLMOD_NATURAL: return "natural";
    case CHOLMOD_GIVEN: return "given";
    case CHOLMOD_AMD: return "AMD";
    case CHOLMOD_METIS: return "METIS";
    case CHOLMOD_NESDIS: return "NESDIS";
    case CHOLMOD_COLAMD: return "COLAMD";
    case CHOLMOD_POSTORDERED: return "postordered";
    default: return "unknown";
  }
}
}  // namespace

std::string CholmodSolver::ordering() const {
  if (!impl_->factor) return "";
  return impl_->block_ordering ? "METIS" : ordering_name(impl_->factor->ordering);
}

std::string CholmodSolver::describe() const {
  const Impl& d = *impl_;
  if (!d.factor) return "CHOLMOD";
  std::string tried;
  const cholmod_common& c = d.common;
  for (int k = 0; k < CHOLMOD_MAXMETHODS; ++k) {
    if (!(c.method[k].lnz > 0)) continue;  // not tried
    tried += std::string(tried.empty() ? "" : ", ") + ordering_name(c.method[k].ordering) + " " +
             std::to_string(static_cast<long long>(c.method[k].lnz));
  }
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "CHOLMOD %s, ordering %s, factor nonzeros %.4g, flops %.4g, analysis %.3f s, "
                "factorisation %.3f s",
                d.factor->is_super ? "supernodal" : "simplicial",
                d.block_ordering ? "METIS (on the 3x3 blocks)" : ordering_name(d.factor->ordering),
                c.lnz, c.fl, d.analyze_seconds, d.factorize_seconds);
  std::string out = buf;
  if (blas_threads_ > 0) out += ", BLAS threads " + std::to_string(blas_threads_);
  if (factor_threads_ != blas_threads_)
    out += ", factorisation BLAS threads " + (factor_threads_ > 0 ? std::to_string(factor_threads_) : "default");
  return out + (tried.empty() ? "" : " (orderings tried, factor nonzeros: " + tried + ")");
}

void CholmodSolver::setup_impl(const LinearOperator& A) {
  scalar_.setup(A, "CHOLMOD");
  analyze(scalar_.csr(), scalar_.block() ? &scalar_.block()->pattern() : nullptr);
  factorize(scalar_.csr());
}

bool CholmodSolver::update_is_serial() const {
  const Impl& d = *impl_;
  return d.factor && (d.flops < kThreadedFactorFlops ? blas_threads_ : factor_threads_) == 1;
}

void CholmodSolver::update_impl() {
  scalar_.refresh();
  factorize(scalar_.csr());
}

void CholmodSolver::apply_impl(const Vector& b, Vector& x) const {
  Impl& d = *impl_;
  if (!d.factorized) throw Error("CHOLMOD: solve before a successful factorize()");
  cholmod_dense B{};
  B.nrow = B.d = B.nzmax = static_cast<size_t>(b.size());
  B.ncol = 1;
  B.x = const_cast<double*>(b.data());
  B.xtype = CHOLMOD_REAL;
  B.dtype = CHOLMOD_DOUBLE;
  int ok;
  {
    ScopedCholmodThreads scoped(blas_threads_);
    ok = cholmod_l_solve2(CHOLMOD_A, d.factor, &B, nullptr, &d.X, nullptr, &d.Y, &d.E, &d.common);
  }
  if (!ok || !d.X) throw Error("CHOLMOD: solve failed (" + status_text(d.common.status) + ")");
  x = Eigen::Map<const Vector>(static_cast<const double*>(d.X->x), b.size());
}

}  // namespace pmg

// ---- the factory method -------------------------------------------------------------------------

#include "pmg/sparse/factory.hpp"

namespace pmg {

void CholmodParams::visit(ParamVisitor& v) {
  v.choice("ordering", ordering, {"metis", "auto", "amd", "nesdis"},
           "fill-reducing ordering (metis on a BCSR matrix orders the graph of its 3x3 blocks)");
  v.integer("blas_threads", blas_threads, 0, 4096,
            "BLAS threads in factorisations and solves (0: the BLAS's own; a multigrid's lowest level: 1)");
  v.integer("factor_threads", factor_threads, -1, 4096,
            "BLAS threads of factorisations of >= 1e9 flops (-1: blas_threads, 0: the BLAS's own; "
            "a multigrid's lowest level: 0)");
  check.visit(v);
}

namespace cholmod {

void register_solvers() {
  static std::once_flag once;
  std::call_once(once, [] {
    register_builtin_solver({"cholmod", "sparse Cholesky (CHOLMOD, supernodal): symbolic once, numeric per update",
                     list_params<CholmodParams>(), false, false, "cholmod"},
                    [](const Config& c, const SolverContext&) {
                      return std::make_unique<CholmodSolver>(read_params<CholmodParams>(c));
                    });
  });
}

}  // namespace cholmod
}  // namespace pmg
