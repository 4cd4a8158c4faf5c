// The PETSc adapter (pmg/petsc/petsc.hpp): the only file that includes PETSc.
#include "pmg/petsc/petsc.hpp"

#include "pmg/mpi/session.hpp"
#include "common.hpp"

#include <petscksp.h>

#include <atomic>
#include <cctype>
#include <chrono>
#include <limits>
#include <sstream>

namespace pmg::petsc {

namespace {

std::string& last_error() {
  static thread_local std::string message;
  return message;
}

/// Keeps PETSc's own message of the first error in a call chain (PETSc's default handler prints a
/// traceback; ours becomes an exception's text instead).
PetscErrorCode keep_message(MPI_Comm, int, const char* function, const char*, PetscErrorCode n,
                            PetscErrorType p, const char* message, void*) {
  if (p == PETSC_ERROR_INITIAL)
    last_error() = std::string(message && *message ? message : "error") + " (in " + function + ")";
  return n;
}

void check(PetscErrorCode err, const char* what) {
  if (!err) return;
  std::string text = last_error();
  if (text.empty()) {
    const char* generic = nullptr;
    PetscErrorMessage(err, &generic, nullptr);
    text = generic ? generic : "error " + std::to_string(err);
  }
  last_error().clear();
  throw Error(std::string("PETSc: ") + what + " failed: " + text);
}

/// PETSc initialised once, after MPI, and finalised before MPI is (pmg::mpi::at_finalize).
struct PetscSession {
  bool owned = false;
  PetscSession() {
    mpi::start();
    PetscBool initialized = PETSC_FALSE;
    PetscInitialized(&initialized);
    if (!initialized) {
      // No signal handler: a crash stays a crash (sanitizers, debuggers), SIGINT stays ours.
      static char name[] = "pmg", flag[] = "-no_signal_handler";
      static char* args[] = {name, flag, nullptr};
      int argc = 2;
      char** argv = args;
      check(PetscInitialize(&argc, &argv, nullptr, nullptr), "PetscInitialize");
      owned = true;
    }
    PetscPushErrorHandler(keep_message, nullptr);
    if (owned)
      mpi::at_finalize([] {
        // A program that owns MPI may have finalised it already: PETSc cannot end cleanly then.
        int mpi_finalized = 0;
        MPI_Finalized(&mpi_finalized);
        PetscBool finalized = PETSC_FALSE;
        PetscFinalized(&finalized);
        if (!finalized && !mpi_finalized) PetscFinalize();
      });
  }
};

void petsc() {
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  static PetscSession session;
}

}  // namespace
}  // namespace pmg::petsc

namespace pmg::petsc::detail {

void start() { ::pmg::petsc::petsc(); }
void check(PetscErrorCode err, const char* what) { ::pmg::petsc::check(err, what); }
void clear_error() { ::pmg::petsc::last_error().clear(); }

std::string prefixed(const std::string& options, const std::string& prefix) {
  std::istringstream in(options);
  std::ostringstream out;
  std::string token;
  while (in >> token) {
    if (token.size() > 1 && token[0] == '-' && std::isalpha(static_cast<unsigned char>(token[1])))
      token = "-" + prefix + token.substr(1);
    out << token << " ";
  }
  return out.str();
}

std::vector<std::string> option_names(const std::string& options) {
  std::istringstream in(options);
  std::vector<std::string> names;
  std::string token;
  bool value_allowed = false;  // the previous token was an option name
  while (in >> token) {
    if (token.size() > 1 && token[0] == '-' && std::isalpha(static_cast<unsigned char>(token[1]))) {
      names.push_back(token.substr(1));
      value_allowed = true;
    } else if (value_allowed) {
      value_allowed = false;
    } else {
      throw InputError("PETSc options: '" + token + "' is " +
                       (names.empty() ? std::string("not an option (an option starts with '-': '-") + token + "')"
                                      : "a second value after '-" + names.back() + "' (each option takes at most one value)"));
    }
  }
  return names;
}

void refuse_unused(const std::string& options, const std::string& prefix, bool allow_unused, const std::string& who) {
  if (allow_unused) return;
  std::string unused;
  // Options PETSc reads only while solving (viewers, the converged reason) are not asked for.
  const auto read_when_solving = [](const std::string& name) {
    const auto ends = [&](const std::string& tail) {
      return name.size() >= tail.size() && name.compare(name.size() - tail.size(), tail.size(), tail) == 0;
    };
    return name.find("view") != std::string::npos || ends("converged_reason") || ends("converged_rate");
  };
  for (const std::string& name : option_names(options)) {
    if (read_when_solving(name)) continue;
    PetscBool used = PETSC_FALSE;
    check(PetscOptionsUsed(nullptr, (prefix + name).c_str(), &used), "PetscOptionsUsed");  // stored without the dash
    if (!used) unused += (unused.empty() ? "'-" : ", '-") + name + "'";
  }
  if (!unused.empty())
    throw InputError(who + ": PETSc read none of the options " + unused +
                     " (misspelt, or for another type of solver or preconditioner; unused_keys=known "
                     "accepts options PETSc does not read)");
}

}  // namespace pmg::petsc::detail

namespace pmg::petsc {

using petsc::detail::prefixed;

bool petsc_available() { return true; }

void start_petsc() { petsc(); }

struct PetscPreconditioner::Impl {
  Mat A = nullptr, Sp = nullptr;
  Vec r = nullptr, z = nullptr, coords = nullptr;
  MatNullSpace near_null = nullptr;
  IS is_u = nullptr, is_p = nullptr;
  PC pc = nullptr;
  std::vector<PetscInt> row_ptr;  // 32-bit copy of the 64-bit offsets
  std::vector<PetscInt> sp_row_ptr;  // fieldsplit: Ŝ = −s M_p, its offsets and values
  std::vector<double> sp_values;
  std::string prefix, options;
  void destroy() {
    if (pc) PCDestroy(&pc);
    if (is_u) ISDestroy(&is_u);
    if (is_p) ISDestroy(&is_p);
    if (Sp) MatDestroy(&Sp);
    if (near_null) MatNullSpaceDestroy(&near_null);
    if (coords) VecDestroy(&coords);
    if (r) VecDestroy(&r);
    if (z) VecDestroy(&z);
    if (A) MatDestroy(&A);
  }
  ~Impl() {
    std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
    destroy();
  }
};

PetscPreconditioner::PetscPreconditioner(const PetscParams& params)
    : impl_(std::make_unique<Impl>()), params_(params) {
  if (params.type != "gamg" && params.type != "mumps" && params.type != "cholmod" && params.type != "fieldsplit")
    throw InputError("PETSc: unknown preconditioner type '" + params.type + "' (gamg, mumps, cholmod, fieldsplit)");
  detail::option_names(params.options);  // refuses a malformed option string
  static std::atomic<long> count{0};
  impl_->prefix = "pmg" + std::to_string(count++) + "_";
  // GAMG: CG-estimated Chebyshev/Jacobi smoothing, as FEniCSx's elasticity demo sets it.
  // fieldsplit: the same GAMG on the displacement block, one application per split.
  std::string defaults = params.type == "gamg"
                             ? "-mg_levels_ksp_type chebyshev -mg_levels_pc_type jacobi "
                               "-mg_levels_esteig_ksp_type cg "
                             : "";
  if (params.type == "fieldsplit")
    defaults = "-fieldsplit_0_ksp_type preonly -fieldsplit_0_pc_type gamg -fieldsplit_0_mg_levels_ksp_type chebyshev "
               "-fieldsplit_0_mg_levels_pc_type jacobi -fieldsplit_0_mg_levels_esteig_ksp_type cg "
               "-fieldsplit_1_ksp_type preonly -fieldsplit_1_pc_type jacobi ";
  impl_->options = defaults + params.options;
}

PetscPreconditioner::~PetscPreconditioner() = default;

void PetscPreconditioner::scale_schur() {
  // PETSc's Schur complement of [A Bᵀ; B −C] is −C − B A⁻¹ Bᵀ ≈ −s M_p (s read afresh: a time
  // step's weights change it).
  Impl& d = *impl_;
  const std::vector<double>& mp = saddle_->pressure_mass->values();
  d.sp_values.resize(mp.size());
  for (size_t k = 0; k < mp.size(); ++k) d.sp_values[k] = -saddle_->schur_scale * mp[k];
}

void PetscPreconditioner::set_up_fieldsplit(index_t n) {
  Impl& d = *impl_;
  if (!saddle_ || !saddle_->pressure_mass)
    throw InputError("PETSc fieldsplit: needs the blocks of a saddle point (formulation=mixed)");
  const Csr& Mp = *saddle_->pressure_mass;
  const PetscInt np = Mp.rows(), nu = n - np;
  if (nu <= 0 || nu % 3 != 0)
    throw InputError("PETSc fieldsplit: the system of " + std::to_string(n) +
                     " unknowns has no displacement block of 3 per node beside " + std::to_string(np) + " pressures");
  // The two fields: displacement first (3 per node, for GAMG), then the pressure.
  check(ISCreateStride(PETSC_COMM_SELF, nu, 0, 1, &d.is_u), "ISCreateStride");
  check(ISSetBlockSize(d.is_u, 3), "ISSetBlockSize");
  check(ISCreateStride(PETSC_COMM_SELF, np, nu, 1, &d.is_p), "ISCreateStride");
  if (params_.rigid_near_null_space) {
    if (static_cast<PetscInt>(coordinates_.size()) != nu)
      throw InputError("PETSc fieldsplit: the rigid-body near-null space needs the coordinates of the " +
                       std::to_string(nu / 3) + " displacement nodes, got " + std::to_string(coordinates_.size() / 3));
    check(VecCreateSeqWithArray(PETSC_COMM_SELF, 3, nu, coordinates_.data(), &d.coords), "VecCreateSeqWithArray");
    check(MatNullSpaceCreateRigidBody(d.coords, &d.near_null), "MatNullSpaceCreateRigidBody");
    // PCFIELDSPLIT gives the split's matrix the near-null space composed with its index set.
    check(PetscObjectCompose(reinterpret_cast<PetscObject>(d.is_u), "nearnullspace",
                             reinterpret_cast<PetscObject>(d.near_null)),
          "PetscObjectCompose");
  }
  d.sp_row_ptr.assign(Mp.pattern().row_ptr.begin(), Mp.pattern().row_ptr.end());
  scale_schur();
  check(MatCreateSeqAIJWithArrays(PETSC_COMM_SELF, np, np, d.sp_row_ptr.data(),
                                  const_cast<PetscInt*>(Mp.pattern().col_idx.data()), d.sp_values.data(), &d.Sp),
        "MatCreateSeqAIJWithArrays");
}

void PetscPreconditioner::setup_impl(const LinearOperator& A) {
  petsc();
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  scalar_.setup(A, "PETSc " + params_.type);
  const Csr& S = scalar_.csr();
  Impl& d = *impl_;
  d.destroy();
  const PetscInt n = S.rows();
  if (S.nnz() > std::numeric_limits<PetscInt>::max())
    throw InputError("PETSc: this build's 32-bit indices cannot hold " + std::to_string(S.nnz()) + " nonzeros");
  d.row_ptr.assign(S.pattern().row_ptr.begin(), S.pattern().row_ptr.end());
  static_assert(sizeof(PetscInt) == sizeof(index_t), "PETSc's column indices are shared with ours");
  static_assert(sizeof(PetscScalar) == sizeof(double), "PETSc's values are shared with ours");
  check(MatCreateSeqAIJWithArrays(PETSC_COMM_SELF, n, n, d.row_ptr.data(),
                                  const_cast<PetscInt*>(S.pattern().col_idx.data()),
                                  const_cast<PetscScalar*>(S.values().data()), &d.A),
        "MatCreateSeqAIJWithArrays");
  const bool fieldsplit = params_.type == "fieldsplit";
  const bool blocks = n % 3 == 0 && !fieldsplit;
  if (blocks) check(MatSetBlockSize(d.A, 3), "MatSetBlockSize");
  check(MatSetOption(d.A, MAT_SYMMETRIC, PETSC_TRUE), "MatSetOption");
  if (fieldsplit) set_up_fieldsplit(n);
  if (!params_.indefinite) check(MatSetOption(d.A, MAT_SPD, PETSC_TRUE), "MatSetOption");
  if (params_.type == "gamg" && params_.rigid_near_null_space) {
    if (!blocks || static_cast<PetscInt>(coordinates_.size()) != n)
      throw InputError("PETSc GAMG: the rigid-body near-null space needs the node coordinates of the "
                       "system (3 unknowns per node): " +
                       std::string(coordinates_.empty() ? "none were given (only FEM scenes have them; "
                                                          "set near_null_space=none)"
                                                        : "their count does not match"));
    check(VecCreateSeqWithArray(PETSC_COMM_SELF, 3, n, coordinates_.data(), &d.coords), "VecCreateSeqWithArray");
    check(MatNullSpaceCreateRigidBody(d.coords, &d.near_null), "MatNullSpaceCreateRigidBody");
    check(MatSetNearNullSpace(d.A, d.near_null), "MatSetNearNullSpace");
  }
  check(VecCreateSeqWithArray(PETSC_COMM_SELF, 1, n, nullptr, &d.r), "VecCreateSeqWithArray");
  check(VecCreateSeqWithArray(PETSC_COMM_SELF, 1, n, nullptr, &d.z), "VecCreateSeqWithArray");
  check(PCCreate(PETSC_COMM_SELF, &d.pc), "PCCreate");
  check(PCSetOptionsPrefix(d.pc, d.prefix.c_str()), "PCSetOptionsPrefix");
  check(PCSetOperators(d.pc, d.A, d.A), "PCSetOperators");
  if (params_.type == "gamg") {
    check(PCSetType(d.pc, PCGAMG), "PCSetType");
  } else if (fieldsplit) {
    check(PCSetType(d.pc, PCFIELDSPLIT), "PCSetType");
    check(PCFieldSplitSetIS(d.pc, "0", d.is_u), "PCFieldSplitSetIS");
    check(PCFieldSplitSetIS(d.pc, "1", d.is_p), "PCFieldSplitSetIS");
    check(PCFieldSplitSetType(d.pc, PC_COMPOSITE_SCHUR), "PCFieldSplitSetType");
    check(PCFieldSplitSetSchurFactType(d.pc, PC_FIELDSPLIT_SCHUR_FACT_UPPER), "PCFieldSplitSetSchurFactType");
    check(PCFieldSplitSetSchurPre(d.pc, PC_FIELDSPLIT_SCHUR_PRE_USER, d.Sp), "PCFieldSplitSetSchurPre");
  } else {
    check(PCSetType(d.pc, PCCHOLESKY), "PCSetType");
    check(PCFactorSetMatSolverType(d.pc, params_.type == "mumps" ? MATSOLVERMUMPS : MATSOLVERCHOLMOD),
          "PCFactorSetMatSolverType");
  }
  check(PetscOptionsInsertString(nullptr, prefixed(d.options, d.prefix).c_str()),
        ("the options '" + params_.options + "'").c_str());
  check(PCSetFromOptions(d.pc), "PCSetFromOptions");
  check(PCSetUp(d.pc), "PCSetUp");
  detail::refuse_unused(params_.options, d.prefix, params_.allow_unused_options, "PETSc " + params_.type);
  PCFailedReason reason;
  PCGetFailedReason(d.pc, &reason);
  if (reason != PC_NOERROR)
    throw Error("PETSc " + params_.type + ": set-up failed (" + PCFailedReasons[reason] + ")");
}

void PetscPreconditioner::update_impl() {
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  scalar_.refresh();  // new values in the same arrays the Mat reads
  Impl& d = *impl_;
  if (d.Sp) {
    scale_schur();
    check(MatAssemblyBegin(d.Sp, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
    check(MatAssemblyEnd(d.Sp, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
  }
  // Assembly of an unchanged pattern: PETSc then knows the values changed (its object state).
  check(MatAssemblyBegin(d.A, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
  check(MatAssemblyEnd(d.A, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
  check(PCSetOperators(d.pc, d.A, d.A), "PCSetOperators");
  check(PCSetUp(d.pc), "PCSetUp");
}

void PetscPreconditioner::apply_impl(const Vector& r, Vector& z) const {
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  Impl& d = *impl_;
  check(VecPlaceArray(d.r, r.data()), "VecPlaceArray");
  check(VecPlaceArray(d.z, z.data()), "VecPlaceArray");
  const PetscErrorCode err = PCApply(d.pc, d.r, d.z);
  VecResetArray(d.r);
  VecResetArray(d.z);
  check(err, "PCApply");
}

std::string PetscPreconditioner::describe() const {
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  const Impl& d = *impl_;
  std::ostringstream s;
  s << "PETSc " << params_.type;
  if (params_.type == "gamg") s << " (near-null space: " << (params_.rigid_near_null_space ? "rigid-body modes" : "PETSc's default") << ")";
  if (!d.options.empty()) s << " options: " << d.options;
  if (!d.pc) return s.str();
  if (params_.type == "gamg") {
    PetscInt levels = 0;
    if (PCMGGetLevels(d.pc, &levels) == 0 && levels > 0) {
      double nnz = 0, nnz_fine = 0, rows = 0, rows_fine = 0;
      for (PetscInt l = 0; l < levels; ++l) {
        KSP ksp;
        Mat Al;
        MatInfo info;
        PetscInt m = 0, k = 0;
        if (PCMGGetSmoother(d.pc, l, &ksp) || KSPGetOperators(ksp, &Al, nullptr) ||
            MatGetInfo(Al, MAT_LOCAL, &info) || MatGetSize(Al, &m, &k))
          return s.str();
        nnz += info.nz_used, rows += m;
        if (l == levels - 1) nnz_fine = info.nz_used, rows_fine = m;
      }
      s << "; " << levels << " levels, grid complexity " << rows / rows_fine << ", operator complexity "
        << nnz / nnz_fine;
    }
  } else {
    Mat F;
    MatInfo info;
    if (PCFactorGetMatrix(d.pc, &F) == 0 && MatGetInfo(F, MAT_LOCAL, &info) == 0 && info.nz_used > 0)
      s << "; factor nonzeros " << info.nz_used;
  }
  last_error().clear();
  return s.str();
}

}  // namespace pmg::petsc
