// CG + PCMG across MPI ranks (pmg/petsc/pcmg.hpp).
#include "pmg/petsc/pcmg.hpp"
#include "pmg/sparse/timer.hpp"
#include "pmg/sparse/vector_ops.hpp"

#include "common.hpp"
#include "vectors.hpp"
#include "pmg/mpi/agreement.hpp"
#include "pmg/mpi/session.hpp"

#include <petscksp.h>

#include <Eigen/Dense>

#include <dlfcn.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

namespace pmg::petsc {

using detail::check;

namespace {

/// OpenBLAS on one thread while PETSc runs: PETSc's vector operations are level-1 BLAS calls
/// (dot products, axpy), and OpenBLAS's own pthreads started beside OpenMP's spinning threads
/// contend with them for the cores (docs/distributed.md measures it). Found through dlsym, so any
/// BLAS links; the caller's setting is restored on return.
class SerialBlas {
 public:
  SerialBlas() {
    using Get = int (*)();
    set_ = reinterpret_cast<Set>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
    const auto get = reinterpret_cast<Get>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
    if (!set_ || !get) {
      set_ = nullptr;
      return;
    }
    saved_ = get();
    if (saved_ > 1) set_(1);
  }
  ~SerialBlas() {
    if (set_ && saved_ > 1) set_(saved_);
  }
  SerialBlas(const SerialBlas&) = delete;
  SerialBlas& operator=(const SerialBlas&) = delete;

 private:
  using Set = void (*)(int);
  Set set_ = nullptr;
  int saved_ = 0;
};

/// A shell level: the rank's element operator between a scatter from the global vector and the
/// reverse scatter back (see the file comment of pcmg.hpp).
struct ShellLevel {
  const LinearOperator* op = nullptr;
  const DiagonalBlocksSource* blocks = nullptr;
  index_t owned = 0;
  VecScatter scatter = nullptr;        // global (owned unknowns) -> local unknowns
  VecScatter block_scatter = nullptr;  // the same for 9 values per node (the diagonal blocks)
  Vec xl = nullptr, yl = nullptr;      // local vectors over xd, yd's storage
  Vec gg = nullptr;                    // the owned 9-per-node vector (summed diagonal blocks)
  mutable Vector xd, yd;
  std::vector<double> local_blocks;
  std::vector<double> inverse_blocks, diagonal;  // per owned node: 9, 3
  void destroy() {
    if (scatter) VecScatterDestroy(&scatter);
    if (block_scatter) VecScatterDestroy(&block_scatter);
    for (Vec* v : {&xl, &yl, &gg})
      if (*v) VecDestroy(v);
  }
};

PetscErrorCode shell_mult(Mat A, Vec x, Vec y) {
  ShellLevel* s = nullptr;
  PetscFunctionBeginUser;
  PetscCall(MatShellGetContext(A, &s));
  PetscCall(VecScatterBegin(s->scatter, x, s->xl, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(s->scatter, x, s->xl, INSERT_VALUES, SCATTER_FORWARD));
  try {
    s->op->apply(s->xd, s->yd);
  } catch (const std::exception& e) {
    SETERRQ(PETSC_COMM_SELF, PETSC_ERR_LIB, "the rank's element operator failed: %s", e.what());
  }
  PetscCall(VecSet(y, 0.0));
  PetscCall(VecScatterBegin(s->scatter, s->yl, y, ADD_VALUES, SCATTER_REVERSE));
  PetscCall(VecScatterEnd(s->scatter, s->yl, y, ADD_VALUES, SCATTER_REVERSE));
  PetscFunctionReturn(0);
}

PetscErrorCode shell_diagonal(Mat A, Vec d) {
  ShellLevel* s = nullptr;
  PetscFunctionBeginUser;
  PetscCall(MatShellGetContext(A, &s));
  PetscScalar* v = nullptr;
  PetscCall(VecGetArray(d, &v));
  for (size_t i = 0; i < s->diagonal.size(); ++i) v[i] = s->diagonal[i];
  PetscCall(VecRestoreArray(d, &v));
  PetscFunctionReturn(0);
}

/// z = D⁻¹ r on the rank's owned nodes (point-block Jacobi, the smoothers' preconditioner), over
/// the level's inverted diagonal blocks: pmgkit's threaded kernel (PETSc's PCPBJACOBI runs on one
/// thread).
PetscErrorCode shell_block_jacobi(PC pc, Vec r, Vec z) {
  ShellLevel* s = nullptr;
  PetscFunctionBeginUser;
  PetscCall(PCShellGetContext(pc, &s));
  const PetscScalar* rp = nullptr;
  PetscScalar* zp = nullptr;
  PetscCall(VecGetArrayRead(r, &rp));
  PetscCall(VecGetArrayWrite(z, &zp));
  ops::block_diagonal_apply(s->inverse_blocks.data(), rp, zp, s->owned);
  PetscCall(VecRestoreArrayWrite(z, &zp));
  PetscCall(VecRestoreArrayRead(r, &rp));
  PetscFunctionReturn(0);
}

PetscErrorCode shell_invert_block_diagonal(Mat A, const PetscScalar** values) {
  ShellLevel* s = nullptr;
  PetscFunctionBeginUser;
  PetscCall(MatShellGetContext(A, &s));
  *values = s->inverse_blocks.data();
  PetscFunctionReturn(0);
}

/// The rank's diagonal blocks summed over the ranks, then per owned node the 3 diagonal entries
/// and the inverse block, row-major (shell_block_jacobi reads it so; PETSc's PCPBJACOBI, under
/// `-mg_levels_pc_type pbjacobi`, reads column-major: the same, the blocks being symmetric).
void refresh_diagonal(ShellLevel& s, MPI_Comm comm) {
  s.blocks->diagonal_blocks(s.local_blocks);
  OwnedVec local;
  check(VecCreateSeqWithArray(PETSC_COMM_SELF, 9, static_cast<PetscInt>(s.local_blocks.size()),
                              s.local_blocks.data(), &local.object),
        "VecCreateSeqWithArray");
  check(VecSet(s.gg, 0.0), "VecSet");
  check(VecScatterBegin(s.block_scatter, local.object, s.gg, ADD_VALUES, SCATTER_REVERSE), "VecScatterBegin");
  check(VecScatterEnd(s.block_scatter, local.object, s.gg, ADD_VALUES, SCATTER_REVERSE), "VecScatterEnd");
  const PetscScalar* g = nullptr;
  check(VecGetArrayRead(s.gg, &g), "VecGetArrayRead");
  s.diagonal.resize(3 * static_cast<size_t>(s.owned));
  s.inverse_blocks.resize(9 * static_cast<size_t>(s.owned));
  bool singular = false;
  for (index_t i = 0; i < s.owned; ++i) {
    Eigen::Map<const Block3> B(g + 9 * static_cast<size_t>(i));
    for (int c = 0; c < 3; ++c) s.diagonal[3 * i + c] = B(c, c);
    // Inverted at unit scale: the determinant of a block of entries 1e-200 underflows.
    const double scale = B.cwiseAbs().maxCoeff();
    Block3 inv = Block3::Zero();
    bool invertible = false;
    double det = 0;
    if (scale > 0 && std::isfinite(scale)) {
      const Block3 unit = B / scale;
      unit.computeInverseAndDetWithCheck(inv, det, invertible, 1e-14);
    }
    const Block3 scaled_back = inv / scale;
    singular = singular || !invertible || !std::isfinite(det) || !scaled_back.allFinite();
    Eigen::Map<Block3>(s.inverse_blocks.data() + 9 * static_cast<size_t>(i)) = scaled_back;
  }
  VecRestoreArrayRead(s.gg, &g);
  // Only the owner sees a bad block: every rank learns of it before any of them throws.
  int mine = singular ? 1 : 0, any = 0;
  MPI_Allreduce(&mine, &any, 1, MPI_INT, MPI_MAX, comm);
  if (any) throw Error("distributed p-multigrid: a singular or non-finite 3x3 diagonal block (a node without stiffness)");
}

/// A smoother's preconditioner: the shell level's point-block Jacobi (shell_block_jacobi).
void set_block_jacobi(PC pc, ShellLevel* s) {
  check(PCSetType(pc, PCSHELL), "PCSetType");
  check(PCShellSetContext(pc, s), "PCShellSetContext");
  check(PCShellSetApply(pc, shell_block_jacobi), "PCShellSetApply");
  check(PCShellSetName(pc, "point-block Jacobi"), "PCShellSetName");
}

/// Global unknowns of a level from the owned counts.
long sum_over(MPI_Comm comm, long owned) {
  long total = 0;
  MPI_Allreduce(&owned, &total, 1, MPI_LONG, MPI_SUM, comm);
  return total;
}

/// One monitor call per CG iteration: ||r_i|| / ||b|| (the solvers' reference) into the caller's
/// SolveMonitor; `scale` = ||r_0|| / ||b|| turns PETSc's ratios (to its first residual) into it.
struct MonitorContext {
  SolveMonitor* monitor = nullptr;
  double r0 = 0, scale = 1;
};

PetscErrorCode record_iteration(KSP, PetscInt it, PetscReal rnorm, void* ctx) {
  auto* m = static_cast<MonitorContext*>(ctx);
  if (it == 0) m->r0 = rnorm;
  if (m->monitor) m->monitor->record(static_cast<int>(it), m->r0 > 0 ? m->scale * rnorm / m->r0 : 0.0);
  return 0;
}

}  // namespace

struct PMultigridCg::Impl {
  MPI_Comm comm = MPI_COMM_NULL;
  std::string prefix;
  std::vector<RankLevel> levels;
  std::vector<std::unique_ptr<ShellLevel>> shells;  // [l]: level l >= 1
  std::vector<Mat> ops;                             // [l]: the operator of level l
  std::vector<Mat> prolongations;                   // [l]: from l-1 to l (l >= 1)
  std::vector<long> global_sizes;
  Mat coarse = nullptr;
  Vec coordinates = nullptr;
  MatNullSpace near_null = nullptr;
  KSP ksp = nullptr;
  mutable Vec b = nullptr, x = nullptr, r = nullptr;
  std::vector<std::pair<std::string, double>> setup_seconds;
  mutable MonitorContext monitor;
  bool ready = false;  // the last setup() completed

  void destroy() {
    if (ksp) KSPDestroy(&ksp);
    for (Mat& m : prolongations)
      if (m) MatDestroy(&m);
    prolongations.clear();
    for (size_t l = 1; l < ops.size(); ++l)
      if (ops[l]) MatDestroy(&ops[l]);
    ops.clear();
    if (coarse) MatDestroy(&coarse);
    if (near_null) MatNullSpaceDestroy(&near_null);
    if (coordinates) VecDestroy(&coordinates);
    for (Vec* v : {&b, &x, &r})
      if (*v) VecDestroy(v);
    for (auto& s : shells)
      if (s) s->destroy();
    shells.clear();
  }
  ~Impl() {
    std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
    if (libraries_running()) destroy();
  }

  /// The level's lowest-level matrix values from the rank's element sum (COO: PETSc adds the
  /// entries of ghost rows into their owners).
  void set_coarse_values() {
    const RankLevel& L = levels[0];
    check(MatSetValuesCOO(coarse, L.matrix->values().data(), ADD_VALUES), "MatSetValuesCOO");
  }
  // The steps of setup(), in order.
  void create_shell_level(int l);
  void assemble_lowest_level();
  void create_transfers();
  void create_solver(const PcmgParams& params, const std::string& lowest);
};

PMultigridCg::PMultigridCg(MPI_Comm comm, PcmgParams params) : impl_(std::make_unique<Impl>()), params_(std::move(params)) {
  std::string& m = params_.lowest_level;
  if (m == "hypre") m = "boomeramg";  // the library's name for its method
  if (m == "cholmod")
    throw InputError("distributed p-multigrid: lowest level 'cholmod' factors on one process; across ranks the "
                     "sparse Cholesky is 'mumps'");
  if (m != "auto" && m != "mumps" && m != "gamg" && m != "boomeramg")
    throw InputError("distributed p-multigrid: unknown lowest level '" + m + "' (auto, mumps, gamg, boomeramg)");
  if (!(params_.rel_tol >= 0 && params_.rel_tol < 1))
    throw InputError("distributed p-multigrid: tol must lie in [0, 1)");
  if (params_.max_iterations < 1 || params_.smoothing_steps < 1)
    throw InputError("distributed p-multigrid: max_iterations and smoothing steps must be at least 1");
  detail::option_names(params_.options);  // a malformed option string fails here, on every rank alike
  impl_->comm = comm;
  static std::atomic<long> count{0};
  impl_->prefix = "pmgmg" + std::to_string(count++) + "_";
}

PMultigridCg::~PMultigridCg() = default;

int PMultigridCg::num_levels() const { return static_cast<int>(impl_->levels.size()); }

long PMultigridCg::global_size(int level) const { return impl_->global_sizes.at(level); }

namespace {

/// The checks of setup()'s levels: the lowest assembled, the others with operator, diagonal
/// blocks and prolongation, sizes matching the rank's nodes.
void check_rank_levels(const std::vector<RankLevel>& levels) {
  if (levels.size() < 2) throw InputError("distributed p-multigrid: needs at least two levels (degree >= 2)");
  for (size_t l = 0; l < levels.size(); ++l) {
    const RankLevel& L = levels[l];
    const bool lowest = l == 0;
    if ((lowest && !L.matrix) || (!lowest && (!L.op || !L.blocks || !L.prolongation)))
      throw InputError("distributed p-multigrid: level " + std::to_string(l) + " lacks its " +
                       (lowest ? "matrix" : "operator, diagonal blocks or prolongation"));
    const index_t n_local = static_cast<index_t>(L.global.size());
    if (L.owned < 0 || L.owned > n_local) throw InputError("distributed p-multigrid: owned count out of range");
    if (!lowest && L.op->rows() != 3 * n_local)
      throw InputError("distributed p-multigrid: level " + std::to_string(l) + "'s operator has " +
                       std::to_string(L.op->rows()) + " rows for " + std::to_string(n_local) + " local nodes");
    if (lowest && (L.matrix->block_rows() != n_local || L.coordinates.size() != 3 * L.global.size()))
      throw InputError("distributed p-multigrid: the lowest level's matrix or coordinates do not match its nodes");
  }
}

}  // namespace

/// Level l >= 1 as a PETSc shell matrix over the rank's operator (products, diagonal, inverted
/// diagonal blocks) with its ghost scatters.
void PMultigridCg::Impl::create_shell_level(int l) {
  Impl& d = *this;
  const RankLevel& L = d.levels[l];
  d.shells[l] = std::make_unique<ShellLevel>();  // owned by d at once: destroy() frees it on any error
  ShellLevel* s = d.shells[l].get();
  s->op = L.op;
  s->blocks = L.blocks;
  s->owned = L.owned;
  const PetscInt n_local = static_cast<PetscInt>(L.global.size());
  s->xd = Vector::Zero(3 * n_local);
  s->yd = Vector::Zero(3 * n_local);
  check(VecCreateSeqWithArray(PETSC_COMM_SELF, 3, 3 * n_local, s->xd.data(), &s->xl), "VecCreateSeqWithArray");
  check(VecCreateSeqWithArray(PETSC_COMM_SELF, 3, 3 * n_local, s->yd.data(), &s->yl), "VecCreateSeqWithArray");
  Mat A = nullptr;
  check(MatCreateShell(d.comm, 3 * L.owned, 3 * L.owned, PETSC_DETERMINE, PETSC_DETERMINE, s, &A),
        "MatCreateShell");
  d.ops[l] = A;
  check(MatSetBlockSizes(A, 3, 3), "MatSetBlockSizes");
  check(MatShellSetOperation(A, MATOP_MULT, reinterpret_cast<void (*)(void)>(shell_mult)), "MatShellSetOperation");
  check(MatShellSetOperation(A, MATOP_MULT_TRANSPOSE, reinterpret_cast<void (*)(void)>(shell_mult)),
        "MatShellSetOperation");
  check(MatShellSetOperation(A, MATOP_GET_DIAGONAL, reinterpret_cast<void (*)(void)>(shell_diagonal)),
        "MatShellSetOperation");
  check(MatShellSetOperation(A, MATOP_INVERT_BLOCK_DIAGONAL,
                             reinterpret_cast<void (*)(void)>(shell_invert_block_diagonal)),
        "MatShellSetOperation");
  {
    OwnedVec global;
    check(MatCreateVecs(A, &global.object, nullptr), "MatCreateVecs");
    OwnedIS is;
    check(ISCreateBlock(PETSC_COMM_SELF, 3, n_local, L.global.data(), PETSC_COPY_VALUES, &is.object), "ISCreateBlock");
    check(VecScatterCreate(global.object, is.object, s->xl, nullptr, &s->scatter), "VecScatterCreate");
  }
  // The same numbering, 9 values per node, for the diagonal blocks.
  check(VecCreateMPI(d.comm, 9 * L.owned, PETSC_DETERMINE, &s->gg), "VecCreateMPI");
  check(VecSetBlockSize(s->gg, 9), "VecSetBlockSize");
  {
    OwnedVec layout;  // the local side's layout only: refresh_diagonal() scatters from the blocks
    check(VecCreateSeq(PETSC_COMM_SELF, 9 * n_local, &layout.object), "VecCreateSeq");
    OwnedIS is;
    check(ISCreateBlock(PETSC_COMM_SELF, 9, n_local, L.global.data(), PETSC_COPY_VALUES, &is.object), "ISCreateBlock");
    check(VecScatterCreate(s->gg, is.object, layout.object, nullptr, &s->block_scatter), "VecScatterCreate");
  }
  refresh_diagonal(*s, d.comm);
}

/// The lowest level: the rank's element sum as COO entries (ghost rows go to their owners), and
/// its rigid-body near-null space from the owned nodes' coordinates.
void PMultigridCg::Impl::assemble_lowest_level() {
  Impl& d = *this;
  const RankLevel& L = d.levels[0];
  const Bcsr& M = *L.matrix;
  const CsrPattern& pat = M.pattern();
  const offset_t blocks = M.num_blocks();
  std::vector<PetscInt> ci(9 * static_cast<size_t>(blocks)), cj(9 * static_cast<size_t>(blocks));
  for (index_t i = 0; i < pat.rows; ++i)
    for (offset_t k = pat.row_ptr[i]; k < pat.row_ptr[i + 1]; ++k) {
      const index_t gi = L.global[i], gj = L.global[pat.col_idx[k]];
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
          ci[9 * k + 3 * a + b] = 3 * gi + a;
          cj[9 * k + 3 * a + b] = 3 * gj + b;
        }
    }
  check(MatCreate(d.comm, &d.coarse), "MatCreate");
  check(MatSetSizes(d.coarse, 3 * L.owned, 3 * L.owned, PETSC_DETERMINE, PETSC_DETERMINE), "MatSetSizes");
  check(MatSetType(d.coarse, MATAIJ), "MatSetType");
  check(MatSetBlockSize(d.coarse, 3), "MatSetBlockSize");
  check(MatSetPreallocationCOO(d.coarse, static_cast<PetscCount>(ci.size()), ci.data(), cj.data()),
        "MatSetPreallocationCOO");
  d.set_coarse_values();
  check(MatSetOption(d.coarse, MAT_SYMMETRIC, PETSC_TRUE), "MatSetOption");
  check(MatSetOption(d.coarse, MAT_SPD, PETSC_TRUE), "MatSetOption");
  d.ops[0] = d.coarse;
  // Rigid-body modes from the owned nodes' coordinates.
  check(MatCreateVecs(d.coarse, &d.coordinates, nullptr), "MatCreateVecs");
  check(VecSetBlockSize(d.coordinates, 3), "VecSetBlockSize");
  PetscScalar* c = nullptr;
  check(VecGetArray(d.coordinates, &c), "VecGetArray");
  for (size_t i = 0; i < L.global.size(); ++i) {
    const index_t g = L.global[i] - L.first;
    if (g < 0 || g >= L.owned) continue;
    for (int k = 0; k < 3; ++k) c[3 * g + k] = L.coordinates[3 * i + k];
  }
  VecRestoreArray(d.coordinates, &c);
  check(MatNullSpaceCreateRigidBody(d.coordinates, &d.near_null), "MatNullSpaceCreateRigidBody");
  check(MatSetNearNullSpace(d.coarse, d.near_null), "MatSetNearNullSpace");
}

/// The owned rows of each prolongation, 3x3 identity blocks per scalar entry, without the held
/// components of either level (RankLevel::constrained).
void PMultigridCg::Impl::create_transfers() {
  Impl& d = *this;
  const int nl = static_cast<int>(d.levels.size());
  d.prolongations.assign(nl, nullptr);
  for (int l = 1; l < nl; ++l) {
    const RankLevel& F = d.levels[l];
    const RankLevel& C = d.levels[l - 1];
    const Csr& P = *F.prolongation;
    if (P.rows() != static_cast<index_t>(F.global.size()) || P.cols() != static_cast<index_t>(C.global.size()))
      throw InputError("distributed p-multigrid: prolongation " + std::to_string(l) + " does not match the levels' nodes");
    for (const RankLevel* L : {&F, &C})
      if (L->constrained && L->constrained->size() != 3 * L->global.size())
        throw InputError("distributed p-multigrid: held components of " + L->name + " do not match its nodes");
    const auto held = [](const RankLevel& L, index_t node, int a) {
      return L.constrained && (*L.constrained)[3 * static_cast<size_t>(node) + a] != 0;
    };
    std::vector<PetscInt> ci, cj;
    std::vector<PetscScalar> v;
    const CsrPattern& pat = P.pattern();
    for (index_t i = 0; i < P.rows(); ++i) {
      const index_t gi = F.global[i];
      if (gi < F.first || gi >= F.first + F.owned) continue;
      for (offset_t k = pat.row_ptr[i]; k < pat.row_ptr[i + 1]; ++k)
        for (int a = 0; a < 3; ++a) {
          ci.push_back(3 * gi + a);
          cj.push_back(3 * C.global[pat.col_idx[k]] + a);
          v.push_back(held(F, i, a) || held(C, pat.col_idx[k], a) ? 0.0 : P.values()[k]);
        }
    }
    Mat Pm = nullptr;
    check(MatCreate(d.comm, &Pm), "MatCreate");
    d.prolongations[l] = Pm;
    check(MatSetSizes(Pm, 3 * F.owned, 3 * C.owned, PETSC_DETERMINE, PETSC_DETERMINE), "MatSetSizes");
    check(MatSetType(Pm, MATAIJ), "MatSetType");
    check(MatSetBlockSizes(Pm, 3, 3), "MatSetBlockSizes");
    check(MatSetPreallocationCOO(Pm, static_cast<PetscCount>(ci.size()), ci.data(), cj.data()), "MatSetPreallocationCOO");
    check(MatSetValuesCOO(Pm, v.data(), INSERT_VALUES), "MatSetValuesCOO");
  }
}

/// CG + PCMG on the levels: Chebyshev with point-block Jacobi above the lowest level, MUMPS'
/// Cholesky, GAMG or BoomerAMG on it; the defaults as options, so that the user's override them.
void PMultigridCg::Impl::create_solver(const PcmgParams& params, const std::string& lowest) {
  Impl& d = *this;
  const int nl = static_cast<int>(d.levels.size());
  check(KSPCreate(d.comm, &d.ksp), "KSPCreate");
  check(KSPSetOptionsPrefix(d.ksp, d.prefix.c_str()), "KSPSetOptionsPrefix");
  check(KSPSetOperators(d.ksp, d.ops[nl - 1], d.ops[nl - 1]), "KSPSetOperators");
  check(KSPSetType(d.ksp, KSPCG), "KSPSetType");
  check(KSPSetNormType(d.ksp, KSP_NORM_UNPRECONDITIONED), "KSPSetNormType");
  check(KSPSetTolerances(d.ksp, params.rel_tol, 0.0, 1e6, params.max_iterations), "KSPSetTolerances");
  check(KSPConvergedDefaultSetUIRNorm(d.ksp), "KSPConvergedDefaultSetUIRNorm");
  PC pc = nullptr;
  check(KSPGetPC(d.ksp, &pc), "KSPGetPC");
  check(PCSetType(pc, PCMG), "PCSetType");
  check(PCMGSetLevels(pc, nl, nullptr), "PCMGSetLevels");
  check(PCMGSetType(pc, PC_MG_MULTIPLICATIVE), "PCMGSetType");
  check(PCMGSetCycleType(pc, PC_MG_CYCLE_V), "PCMGSetCycleType");
  check(PCMGSetGalerkin(pc, PC_MG_GALERKIN_NONE), "PCMGSetGalerkin");
  for (int l = 1; l < nl; ++l) check(PCMGSetInterpolation(pc, l, d.prolongations[l]), "PCMGSetInterpolation");
  {
    KSP s = nullptr;
    check(PCMGGetSmoother(pc, 0, &s), "PCMGGetSmoother");
    check(KSPSetOperators(s, d.ops[0], d.ops[0]), "KSPSetOperators");
    check(KSPSetType(s, KSPPREONLY), "KSPSetType");
    PC sp = nullptr;
    check(KSPGetPC(s, &sp), "KSPGetPC");
    if (lowest == "mumps") {
      check(PCSetType(sp, PCCHOLESKY), "PCSetType");
      check(PCFactorSetMatSolverType(sp, MATSOLVERMUMPS), "PCFactorSetMatSolverType");
    } else if (lowest == "gamg") {
      check(PCSetType(sp, PCGAMG), "PCSetType");
    } else {
      check(PCSetType(sp, PCHYPRE), "PCSetType");
      check(PCHYPRESetType(sp, "boomeramg"), "PCHYPRESetType");
    }
  }
  for (int l = 1; l < nl; ++l) {
    KSP s = nullptr;
    check(PCMGGetSmoother(pc, l, &s), "PCMGGetSmoother");
    check(KSPSetOperators(s, d.ops[l], d.ops[l]), "KSPSetOperators");
    check(KSPSetType(s, KSPCHEBYSHEV), "KSPSetType");
    check(KSPChebyshevEstEigSet(s, 0.0, 0.1, 0.0, 1.1), "KSPChebyshevEstEigSet");
    check(KSPSetTolerances(s, PETSC_DEFAULT, PETSC_DEFAULT, PETSC_DEFAULT, params.smoothing_steps), "KSPSetTolerances");
    check(KSPSetNormType(s, KSP_NORM_NONE), "KSPSetNormType");
    PC sp = nullptr;
    check(KSPGetPC(s, &sp), "KSPGetPC");
    set_block_jacobi(sp, d.shells[l].get());
  }
  // Defaults as options (so that the user's options, inserted after, override them).
  std::string defaults = "-mg_levels_esteig_ksp_type cg -mg_levels_esteig_ksp_max_it 10 ";
  // MUMPS sizes its workspace from the analysis plus ICNTL(14) percent (20 by default); the
  // numerical factorisation can still need more (INFOG(1) = -9, seen on 4 ranks of the quadratic
  // bunny): 100 percent, on a level below amg_threshold unknowns.
  if (lowest == "mumps") defaults += "-mg_coarse_mat_mumps_icntl_14 100 ";
  if (lowest == "gamg")
    defaults += "-mg_coarse_mg_levels_ksp_type chebyshev -mg_coarse_mg_levels_pc_type jacobi "
                "-mg_coarse_mg_levels_esteig_ksp_type cg ";
  // BoomerAMG close to pmgkit's own boomeramg lowest level (pmg/hypre/boomeramg.hpp): PMIS
  // coarsening (HMIS there: its first pass is per rank, so its iterations change with the
  // partition, by 2 on 3 ranks in tests/distributed), extended+i interpolation of at most 6 entries
  // per row, one level of aggressive coarsening, strength 0.5, Chebyshev relaxation. PCHYPRE's
  // own defaults (Falgout, classical interpolation) cost 2.4-2.7x BoomerAMG's set-up time (1.6x the
  // whole solver set-up) and 1.3x the peak memory for 0.57x the iterations on the quadratic cube
  // of docs/distributed.md.
  if (lowest == "boomeramg")
    defaults += "-mg_coarse_pc_hypre_boomeramg_relax_type_all Chebyshev -mg_coarse_pc_hypre_boomeramg_coarsen_type PMIS "
                "-mg_coarse_pc_hypre_boomeramg_interp_type ext+i -mg_coarse_pc_hypre_boomeramg_P_max 6 "
                "-mg_coarse_pc_hypre_boomeramg_agg_nl 1 -mg_coarse_pc_hypre_boomeramg_strong_threshold 0.5 ";
  check(PetscOptionsInsertString(nullptr, detail::prefixed(defaults + params.options, d.prefix).c_str()),
        ("the options '" + params.options + "'").c_str());
  check(KSPSetFromOptions(d.ksp), "KSPSetFromOptions");
  check(KSPMonitorSet(d.ksp, record_iteration, &d.monitor, nullptr), "KSPMonitorSet");
  check(KSPSetUp(d.ksp), "KSPSetUp");
  detail::refuse_unused(params.options, d.prefix, params.allow_unused_options, "petsc-mgpcg");
  check(MatCreateVecs(d.ops[nl - 1], &d.x, &d.b), "MatCreateVecs");
  check(VecDuplicate(d.b, &d.r), "VecDuplicate");
}

void PMultigridCg::setup(std::vector<RankLevel> levels) {
  detail::start();
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  // A failure on one rank (its options, its levels) ends the set-up on every rank.
  mpi::together(impl_->comm, [&] { set_up(std::move(levels)); });
}

void PMultigridCg::set_up(std::vector<RankLevel> levels) {
  const SerialBlas serial_blas;
  Impl& d = *impl_;
  d.ready = false;
  d.destroy();
  d.setup_seconds.clear();
  check_rank_levels(levels);
  d.levels = std::move(levels);
  const int nl = static_cast<int>(d.levels.size());
  d.global_sizes.resize(nl);
  for (int l = 0; l < nl; ++l) d.global_sizes[l] = 3 * sum_over(d.comm, d.levels[l].owned);
  d.ops.assign(nl, nullptr);
  d.shells.resize(nl);
  auto t0 = Clock::now();
  for (int l = 1; l < nl; ++l) d.create_shell_level(l);
  d.setup_seconds.emplace_back("shell levels", seconds_since(t0));
  t0 = Clock::now();
  d.assemble_lowest_level();
  d.setup_seconds.emplace_back("assembly " + d.levels[0].name, seconds_since(t0));
  t0 = Clock::now();
  d.create_transfers();
  d.setup_seconds.emplace_back("transfers", seconds_since(t0));
  t0 = Clock::now();
  lowest_ = params_.lowest_level;
  if (lowest_ == "auto") lowest_ = d.global_sizes[0] < params_.amg_threshold ? "mumps" : "boomeramg";
  d.create_solver(params_, lowest_);
  d.setup_seconds.emplace_back("KSP set-up (lowest level " + lowest_ + ")", seconds_since(t0));
  d.ready = true;
}

void PMultigridCg::refresh() {
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  const SerialBlas serial_blas;
  Impl& d = *impl_;
  if (!d.ready) throw InputError("distributed p-multigrid: refresh() without a completed setup()");
  d.ready = false;  // until this refresh completes
  for (size_t l = 1; l < d.shells.size(); ++l) refresh_diagonal(*d.shells[l], d.comm);
  check(MatZeroEntries(d.coarse), "MatZeroEntries");
  d.set_coarse_values();
  // The operators' state changed: the smoothers re-estimate, the lowest level refactors.
  for (size_t l = 1; l < d.ops.size(); ++l) {  // an assembly marks a shell's state as changed
    check(MatAssemblyBegin(d.ops[l], MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
    check(MatAssemblyEnd(d.ops[l], MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
  }
  const int nl = static_cast<int>(d.ops.size());
  check(KSPSetOperators(d.ksp, d.ops[nl - 1], d.ops[nl - 1]), "KSPSetOperators");
  PC pc = nullptr;
  check(KSPGetPC(d.ksp, &pc), "KSPGetPC");
  for (int l = 0; l < nl; ++l) {
    KSP s = nullptr;
    check(PCMGGetSmoother(pc, l, &s), "PCMGGetSmoother");
    check(KSPSetOperators(s, d.ops[l], d.ops[l]), "KSPSetOperators");
    if (l > 0) check(KSPChebyshevEstEigSet(s, 0.0, 0.1, 0.0, 1.1), "KSPChebyshevEstEigSet");
  }
  check(KSPSetUp(d.ksp), "KSPSetUp");
  d.ready = true;
}

namespace {

/// ||v||_2 over every rank without overflow or underflow (PETSc's VecNorm is BLAS's dnrm2, which
/// gives 0 for a vector of entries 1e-200): the largest magnitude first, then the scaled sum.
double safe_norm(Vec v, MPI_Comm comm) {
  PetscInt n = 0;
  check(VecGetLocalSize(v, &n), "VecGetLocalSize");
  const PetscScalar* a = nullptr;
  check(VecGetArrayRead(v, &a), "VecGetArrayRead");
  double local_max = 0, global_max = 0;
  for (PetscInt i = 0; i < n; ++i) local_max = std::max(local_max, std::abs(a[i]));
  if (std::isnan(local_max) || std::isinf(local_max)) local_max = std::numeric_limits<double>::infinity();
  MPI_Allreduce(&local_max, &global_max, 1, MPI_DOUBLE, MPI_MAX, comm);
  double local_sum = 0, global_sum = 0;
  if (global_max > 0 && std::isfinite(global_max))
    for (PetscInt i = 0; i < n; ++i) {
      const double t = a[i] / global_max;
      local_sum += t * t;
    }
  VecRestoreArrayRead(v, &a);
  MPI_Allreduce(&local_sum, &global_sum, 1, MPI_DOUBLE, MPI_SUM, comm);
  if (!std::isfinite(global_max)) return global_max;
  return global_max * std::sqrt(global_sum);
}

SolveStatus status_of(KSPConvergedReason reason) {
  if (reason > 0) return SolveStatus::converged;
  switch (reason) {
    case KSP_DIVERGED_ITS: return SolveStatus::iteration_limit;
    case KSP_DIVERGED_DTOL: return SolveStatus::diverged;
    case KSP_DIVERGED_NANORINF: return SolveStatus::non_finite;
    default: return SolveStatus::breakdown;
  }
}

}  // namespace

SolveResult PMultigridCg::solve(const Vector& b, Vector& x, SolveMonitor* monitor) const {
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  const SerialBlas serial_blas;
  const Impl& d = *impl_;
  if (!d.ready) throw InputError("distributed p-multigrid: solve() without a completed setup()");
  PetscInt n = 0;
  check(VecGetLocalSize(d.b, &n), "VecGetLocalSize");
  if (b.size() != n || (x.size() != 0 && x.size() != n))
    throw InputError("distributed p-multigrid: the rank's vectors have " + std::to_string(b.size()) +
                     " entries, it owns " + std::to_string(n) + " unknowns");
  if (x.size() == 0) x = Vector::Zero(n);
  const auto t0 = Clock::now();
  if (monitor) monitor->start();
  copy_in(b, d.b);
  copy_in(x, d.x);
  // The initial residual, the reference of both ratios; PETSc then solves for the residual scaled
  // to norm 1 (A (x - x0) / s = r0 / s), so that its own norms neither underflow nor overflow
  // whatever the scale of the system.
  SolveResult res;
  check(MatMult(d.ops.back(), d.x, d.r), "MatMult");
  check(VecAYPX(d.r, -1.0, d.b), "VecAYPX");
  const double r0 = safe_norm(d.r, d.comm);
  const double bnorm = safe_norm(d.b, d.comm);
  // The reference of tol: ||b|| (as every pmgkit solver, SciPy and PETSc), ||r0|| where b = 0.
  const double ref = bnorm > 0 ? bnorm : r0;
  const double floor = params_.rhs_floor > 0 ? params_.rhs_floor * bnorm : 0.0;
  res.initial_residual = r0;
  if (!std::isfinite(r0)) {
    res.status = SolveStatus::non_finite;
    res.message = "distributed p-multigrid: the initial residual is not finite (the operator, right-hand side or "
                  "guess overflows)";
    return res;
  }
  if (r0 == 0 || r0 <= floor || r0 <= params_.rel_tol * ref) {  // x is the solution already
    res.status = SolveStatus::converged;
    res.rel_residual = res.true_rel_residual = r0 > 0 ? r0 / ref : 0.0;
    res.seconds = seconds_since(t0);
    return res;
  }
  // The tolerance and the floor in the units of the scaled system (its first residual is 1).
  check(KSPSetTolerances(d.ksp, params_.rel_tol * ref / r0, floor / r0, 1e6 * std::max(1.0, ref / r0), params_.max_iterations),
        "KSPSetTolerances");
  d.monitor.scale = r0 / ref;
  OwnedVec x0;
  check(VecDuplicate(d.x, &x0.object), "VecDuplicate");
  check(VecCopy(d.x, x0.object), "VecCopy");
  check(VecScale(d.r, 1.0 / r0), "VecScale");
  check(VecSet(d.x, 0.0), "VecSet");
  check(KSPSetInitialGuessNonzero(d.ksp, PETSC_FALSE), "KSPSetInitialGuessNonzero");
  d.monitor.monitor = monitor;
  const PetscErrorCode err = KSPSolve(d.ksp, d.r, d.x);
  d.monitor.monitor = nullptr;
  check(err, "KSPSolve");
  check(VecAYPX(d.x, r0, x0.object), "VecAYPX");  // x = x0 + r0 (the scaled correction)
  KSPConvergedReason reason;
  check(KSPGetConvergedReason(d.ksp, &reason), "KSPGetConvergedReason");
  PetscInt its = 0;
  check(KSPGetIterationNumber(d.ksp, &its), "KSPGetIterationNumber");
  PetscReal rnorm = 0;  // of the scaled system: relative already
  check(KSPGetResidualNorm(d.ksp, &rnorm), "KSPGetResidualNorm");
  check(MatMult(d.ops.back(), d.x, d.r), "MatMult");
  check(VecAYPX(d.r, -1.0, d.b), "VecAYPX");
  const double rtrue = safe_norm(d.r, d.comm);
  copy_out(d.x, x);
  res.iterations = static_cast<int>(its);
  res.rel_residual = rnorm * r0 / ref;
  res.true_rel_residual = rtrue / ref;
  res.status = status_of(reason);
  char text[320];
  if (res.status == SolveStatus::converged && !(rtrue <= 2 * std::max(params_.rel_tol * ref, floor))) {
    res.status = SolveStatus::stagnated;
    std::snprintf(text, sizeof text,
                  "distributed p-multigrid: the recursive residual converged but the true relative residual "
                  "||b - A x|| / ||b|| is %.3e, above twice the tolerance %.3e (limit of attainable accuracy)",
                  res.true_rel_residual, params_.rel_tol);
    res.message = text;
  } else if (!res.ok()) {
    std::snprintf(text, sizeof text, "distributed p-multigrid: CG ended with %s after %d iterations (relative residual %.3e)",
                  KSPConvergedReasons[reason], static_cast<int>(its), res.rel_residual);
    res.message = text;
  }
  res.seconds = seconds_since(t0);
  return res;
}

namespace {

/// y = M x for owned vectors (the layout of M's columns and rows).
void apply_mat(Mat M, const Vector& x, Vector& y) {
  Vec xv = nullptr, yv = nullptr;
  check(MatCreateVecs(M, &xv, &yv), "MatCreateVecs");
  copy_in(x, xv);
  const PetscErrorCode err = MatMult(M, xv, yv);
  if (!err) copy_out(yv, y);
  VecDestroy(&xv);
  VecDestroy(&yv);
  check(err, "MatMult");
}

}  // namespace

void PMultigridCg::multiply(int level, const Vector& x, Vector& y) const {
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  const SerialBlas serial_blas;
  const Impl& d = *impl_;
  if (!d.ready) throw InputError("distributed p-multigrid: multiply() without a completed setup()");
  if (level < 0 || level >= static_cast<int>(d.ops.size())) throw InputError("distributed p-multigrid: no level " + std::to_string(level));
  apply_mat(d.ops[level], x, y);
}

void PMultigridCg::prolong(int level, const Vector& x, Vector& y) const {
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  const SerialBlas serial_blas;
  const Impl& d = *impl_;
  if (!d.ready) throw InputError("distributed p-multigrid: prolong() without a completed setup()");
  if (level < 1 || level >= static_cast<int>(d.ops.size())) throw InputError("distributed p-multigrid: no transfer to level " + std::to_string(level));
  apply_mat(d.prolongations[level], x, y);
}

std::string PMultigridCg::describe() const {
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  const Impl& d = *impl_;
  std::ostringstream s;
  int size = 1;
  MPI_Comm_size(d.comm, &size);
  s << "CG + PCMG on PETSc over " << size << (size == 1 ? " rank" : " ranks") << ": ";
  for (int l = static_cast<int>(d.levels.size()) - 1; l >= 0; --l) {
    s << d.levels[l].name << " " << d.global_sizes[l] << " unknowns"
      << (l > 0 ? " (shell)" : " (MPIAIJ)") << (l > 0 ? ", " : "");
  }
  s << "; smoother Chebyshev(" << params_.smoothing_steps << ") on point-block Jacobi; lowest level "
    << lowest_;
  if (!params_.options.empty()) s << "; options: " << params_.options;
  return s.str();
}

TimingBreakdown PMultigridCg::setup_timings() const {
  TimingBreakdown t;
  t.parts = impl_->setup_seconds;
  t.count = t.parts.empty() ? 0 : 1;
  t.unit = "set-up";
  return t;
}

}  // namespace pmg::petsc
