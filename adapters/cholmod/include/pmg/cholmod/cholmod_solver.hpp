// pmg/cholmod/cholmod_solver.hpp — sparse Cholesky through CHOLMOD (supernodal), with the symbolic
// analysis (ordering, elimination tree, supernodes: once per pattern) separate from the numeric
// factorisation (once per change of values), as Eigen's analyzePattern/factorize. The one adapter
// of CHOLMOD in pmgkit: as a Solver (setup(A) analyses and factorises, update() refactorises
// numerically with the pattern kept) or through analyze/factorize directly.
#pragma once

#include "pmg/sparse/csr.hpp"
#include "pmg/sparse/params.hpp"
#include "pmg/sparse/solver.hpp"

#include <memory>
#include <string>

namespace pmg {

/// The options of the `cholmod` method (see CholmodSolver's constructor).
struct CholmodParams {
  std::string ordering = "metis";  ///< metis, auto, amd or nesdis
  int blas_threads = 0;            ///< BLAS threads of factorisations and solves (0: BLAS's own)
  int factor_threads = -1;         ///< BLAS threads of large factorisations (-1: blas_threads)
  DirectSolveParams check;         ///< how solve() checks (and refines) its answer
  /// The keys ordering, blas_threads and factor_threads, and the check's tol, refinement_steps and
  /// throw_on_failure.
  void visit(ParamVisitor& v);
};

/// CHOLMOD's supernodal Cholesky as a Solver (see the file comment).
class CholmodSolver final : public Solver {
 public:
  std::string name() const override { return "cholmod"; }
  /// True where the factorisation runs on one BLAS thread (below 1e9 flops, or factor_threads 1).
  bool update_is_serial() const override;
  /// ordering: "metis" (the default: METIS nested dissection alone), "auto" (CHOLMOD's default:
  /// AMD, and METIS too when AMD's factor is costly; the better one is kept), "amd", or "nesdis"
  /// (CHOLMOD's nested dissection). On 3-D elasticity systems METIS gives the smallest factor
  /// (docs/performance.md), so "auto" only adds AMD's analysis time.
  ///
  /// blas_threads: threads of the BLAS under CHOLMOD's supernodes during this solver's
  /// factorisations and solves (restored after each call); 0 leaves the BLAS's own setting. Only
  /// OpenBLAS is steered (found at run time; other BLAS libraries ignore it). OpenBLAS's pthreads
  /// build keeps its own worker threads, which spin for a while after every call: next to
  /// pmgkit's OpenMP kernels they take a core from them, so a multigrid's lowest level, factorised
  /// and solved between those kernels, gets 1 from the factory. With one BLAS thread, CHOLMOD's
  /// own OpenMP regions run on the calling thread too.
  ///
  /// factor_threads: the BLAS threads of the factorisations alone (-1: blas_threads; 0: the BLAS's
  /// own setting), for factorisations of 1e9 flops or more (smaller ones run on blas_threads: the
  /// threads' start-up would cost more than they save). With serial solves (blas_threads 1) and a
  /// threaded factorisation, OpenBLAS's workers are ended after it rather than left spinning (so no
  /// other thread of the program may be inside OpenBLAS at that moment).
  ///
  /// Throws InputError for an unknown ordering, blas_threads below 0 or factor_threads below -1.
  explicit CholmodSolver(const std::string& ordering = "metis", int blas_threads = 0, int factor_threads = -1);
  /// The same with the options as a parameter struct (the factory's keys).
  explicit CholmodSolver(const CholmodParams& p) : CholmodSolver(p.ordering, p.blas_threads, p.factor_threads) {
    check_ = p.check;
  }
  ~CholmodSolver() override;
  CholmodSolver(const CholmodSolver&) = delete;
  CholmodSolver& operator=(const CholmodSolver&) = delete;

  /// Symbolic analysis of a symmetric matrix (only one triangle is read). With `blocks` (the 3x3
  /// block pattern A was expanded from, interleaved unknowns) and ordering "metis", the
  /// fill-reducing ordering is computed on the graph of the blocks (9x fewer edges) and expanded to
  /// the unknowns: each node's three unknowns stay together, for about the same factor size.
  void analyze(const Csr& A, const CsrPattern* blocks = nullptr);
  /// Numeric factorisation; A must have the analysed pattern. Throws Error naming the column where
  /// positive definiteness fails.
  void factorize(const Csr& A);
  /// analyze + factorize through the Solver interface: the same as setup(A) (A must then outlive
  /// the solver, as for every Solver); solve() and update() work afterwards.
  void compute(const Csr& A) { setup(A); }

  index_t rows() const override { return n_; }
  index_t cols() const override { return n_; }
  /// Nonzeros in the factor L (after factorize).
  double factor_nnz() const;
  /// The fill-reducing ordering CHOLMOD's analysis chose ("AMD", "METIS", "NESDIS", ...).
  std::string ordering() const;
  /// "CHOLMOD supernodal, ordering METIS (best of AMD, METIS), factor nonzeros ..., flops ...".
  std::string describe() const override;

 private:
  /// A: Csr or Bcsr (converted once; update() copies the values into the same scalar pattern).
  void setup_impl(const LinearOperator& A) override;
  void update_impl() override;
  /// solve(): x = A⁻¹ b (the guess is not used), checked and refined as check_ says.
  const DirectSolveParams* direct_check() const override { return &check_; }
  void apply_impl(const Vector& b, Vector& x) const override;
  ScalarMatrix scalar_;
  struct Impl;
  std::unique_ptr<Impl> impl_;
  index_t n_ = 0;
  int blas_threads_ = 0;
  int factor_threads_ = 0;
  DirectSolveParams check_;
};

}  // namespace pmg

namespace pmg::cholmod {

/// Registers the method `cholmod` in the solver factory (idempotent; a name the user registered is kept).
void register_solvers();

}  // namespace pmg::cholmod
