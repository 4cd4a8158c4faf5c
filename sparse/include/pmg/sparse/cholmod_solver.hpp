// pmg/sparse/cholmod_solver.hpp — sparse Cholesky through CHOLMOD (supernodal), with the symbolic
// analysis (ordering, elimination tree, supernodes: once per pattern) separate from the numeric
// factorisation (once per change of values), as Eigen's analyzePattern/factorize. The one adapter
// of CHOLMOD in pmgkit: as a Solver (setup(A) analyses and factorises, update() refactorises
// numerically with the pattern kept) or through analyze/factorize directly.
#pragma once

#include "pmg/sparse/csr.hpp"
#include "pmg/sparse/solver.hpp"

#include <memory>

namespace pmg {

class CholmodSolver final : public Solver {
 public:
  std::string name() const override { return "cholmod"; }
  /// ordering: "metis" (the default: METIS nested dissection alone), "auto" (CHOLMOD's default:
  /// AMD, and METIS too when AMD's factor is costly; the better one is kept), "amd", or "nesdis"
  /// (CHOLMOD's nested dissection). On the README's 3-D elasticity systems METIS gives the
  /// smallest factor every time (Homer P3: 3.43e7 nonzeros against AMD's 3.70e7; Bunny P2: 2.57e7
  /// against 3.12e7), so "auto" only adds AMD's time to the analysis (0.2-0.3 s of 1 s).
  ///
  /// blas_threads: threads of the BLAS under CHOLMOD's supernodes during this solver's
  /// factorisations and solves (restored after each call); 0 leaves the BLAS's own setting. Only
  /// OpenBLAS is steered (found at run time; other BLAS libraries ignore it). OpenBLAS's pthreads
  /// build keeps its own worker threads, which spin on sched_yield for a while after every call:
  /// next to pmgkit's OpenMP kernels they take a core from them. A multigrid's lowest level is
  /// factorised and solved between those kernels, so the factory gives it 1 (on the twisted cubic
  /// Homer this halved the matrix-free solve time: README, matrix-free section); a large standalone
  /// factorisation gains a little from more (Homer P3: 2.30 s with 2 threads, 2.58 s with 1).
  ///
  /// factor_threads: the BLAS threads of the factorisations alone (-1: blas_threads; 0: the BLAS's
  /// own setting), for factorisations of 1e9 flops or more (smaller ones run on blas_threads: the
  /// threads' start-up would cost more than they save). With serial solves (blas_threads 1) and a
  /// threaded factorisation, OpenBLAS's workers are ended after it rather than left spinning (so no
  /// other thread of the program may be inside OpenBLAS at that moment). The cube's linear level
  /// (77k unknowns, 3.0e10 flops): 1.74 s with 1 thread, 1.25 s with 2.
  explicit CholmodSolver(const std::string& ordering = "metis", int blas_threads = 0, int factor_threads = -1);
  ~CholmodSolver() override;
  CholmodSolver(const CholmodSolver&) = delete;
  CholmodSolver& operator=(const CholmodSolver&) = delete;

  /// Symbolic analysis of a symmetric matrix (only one triangle is read). With `blocks` (the 3x3
  /// block pattern A was expanded from, interleaved unknowns) and ordering "metis", the
  /// fill-reducing ordering is computed on the graph of the blocks (9x fewer edges) and expanded to
  /// the unknowns: each node's three unknowns stay together. On the cube's linear level (77k
  /// unknowns) this cut the analysis from 0.60 to 0.32 s for the same factor size (2.33e7 against
  /// 2.34e7 nonzeros); on the cubic Homer (97.5k unknowns) 1.23 to 0.99 s, 1.5% more nonzeros.
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
  /// x = A⁻¹ b (the guess is not used), reported relative to ||b||.
  SolveResult solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const override;
  void apply_impl(const Vector& b, Vector& x) const override;
  ScalarMatrix scalar_;
  struct Impl;
  std::unique_ptr<Impl> impl_;
  index_t n_ = 0;
  int blas_threads_ = 0;
  int factor_threads_ = 0;
};

}  // namespace pmg
