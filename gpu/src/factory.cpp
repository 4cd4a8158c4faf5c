// The GPU solvers as pmg::Solver objects on host vectors, registered in the solver factory.
#include "pmg/gpu/factory.hpp"

#include "pmg/fem/matrix_free.hpp"
#include "pmg/gpu/solvers.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/multigrid/transfer.hpp"
#include "pmg/sparse/preconditioners.hpp"
#include "pmg/sparse/timer.hpp"

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

namespace pmg::gpu {

namespace {



std::string ms(double seconds) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f ms", 1e3 * seconds);
  return buf;
}

/// What every GPU solver shares: the device check, the host <-> device copies of b and x around a
/// device solve, and their times for describe().
class DeviceSolver : public Solver {
 public:
  explicit DeviceSolver(KrylovParams params) : params_(params) {}
  bool is_linear() const override { return false; }
  std::string describe() const override {
    std::string s = "on " + device_name_ + "; set-up " + ms(setup_seconds_);
    if (solved_)
      s += "; last solve: upload " + ms(upload_) + ", device " + ms(device_) + ", download " + ms(download_);
    const std::string d = describe_device();
    return d.empty() ? s : d + "; " + s;
  }

 protected:
  /// Builds the device objects for A (a Bcsr) and uploads them.
  virtual void upload_system(const Bcsr& A) = 0;
  /// A's values changed (same pattern): refresh the device copies.
  virtual void update_system(const Bcsr& A) = 0;
  /// The same for any operator; by default A must be a Bcsr (gpu-mgpcg also takes the
  /// matrix-free finest level).
  virtual void upload_operator(const LinearOperator& A) { upload_system(as_bcsr(A, name())); }
  virtual void update_operator(const LinearOperator& A) { update_system(as_bcsr(A, name())); }
  virtual SolveResult device_solve(const DeviceVector& b, DeviceVector& x, const KrylovParams& p,
                                   SolveMonitor* monitor) const = 0;
  virtual std::string describe_device() const { return ""; }

  KrylovParams params_;

 private:
  void setup_impl(const LinearOperator& A) override {
    if (device_count() == 0) throw InputError(name() + ": no CUDA device or driver on this machine");
    device_name_ = device_info().name;
    const auto t0 = Clock::now();
    upload_operator(A);
    synchronize();
    setup_seconds_ = seconds_since(t0);
    // b and x on the device, allocated once: each solve's uploads reuse them.
    b_.resize(static_cast<std::size_t>(A.rows()));
    x_.resize(static_cast<std::size_t>(A.rows()));
    solved_ = false;
  }
  void update_impl() override {
    const auto t0 = Clock::now();
    update_operator(system());
    synchronize();
    setup_seconds_ = seconds_since(t0);
  }
  void apply_impl(const Vector& b, Vector& x) const override {
    x = Vector::Zero(b.size());
    KrylovParams p = params_;
    p.throw_on_failure = false;  // a preconditioner's use: whatever it reached
    run(b, x, p, nullptr);
  }
  SolveResult solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const override {
    return run(b, x, params_, monitor);
  }
  SolveResult run(const Vector& b, Vector& x, const KrylovParams& given, SolveMonitor* monitor) const {
    const KrylovParams p = with_rhs_floor(given, b);  // rhs_floor raises abs_tol, as the CPU solvers do
    const auto t0 = Clock::now();
    b_.upload(b);
    x_.upload(x);
    synchronize();
    upload_ = seconds_since(t0);
    const auto t1 = Clock::now();
    SolveResult r;
    try {
      r = device_solve(b_, x_, p, monitor);
    } catch (const SolveError& e) {
      x_.download(x);  // the iterate the failure left, as the CPU solvers leave it
      throw;
    }
    synchronize();
    device_ = seconds_since(t1);
    const auto t2 = Clock::now();
    x_.download(x);
    download_ = seconds_since(t2);
    solved_ = true;
    r.seconds = seconds_since(t0);
    return r;
  }

  std::string device_name_;
  double setup_seconds_ = 0;  ///< the last setup() or update(): host work and uploads
  mutable DeviceVector b_, x_;
  mutable double upload_ = 0, device_ = 0, download_ = 0;
  mutable bool solved_ = false;
};

class McgSolver final : public DeviceSolver {
 public:
  using DeviceSolver::DeviceSolver;
  std::string name() const override { return "gpu-mcg"; }

 private:
  void upload_system(const Bcsr& A) override {
    mcg_.reset();
    M_.setup(A);
    bin_ = std::make_unique<BinBcsr>(A);
    dA_ = std::make_unique<DeviceBinBcsr>(*bin_);
    dM_ = std::make_unique<DeviceBlockJacobi>(M_);
    mcg_ = std::make_unique<Mcg>(*dA_, *dM_);
  }
  void update_system(const Bcsr& A) override {
    M_.update();
    bin_->update_values(A);
    dA_->update_values(*bin_);
    dM_->update(M_);
  }
  SolveResult device_solve(const DeviceVector& b, DeviceVector& x, const KrylovParams& p,
                           SolveMonitor* monitor) const override {
    return mcg_->solve(b, x, p, monitor);
  }
  std::string describe_device() const override { return "BIN-BCSR, block Jacobi"; }

  BlockJacobiPreconditioner M_;
  std::unique_ptr<BinBcsr> bin_;
  std::unique_ptr<DeviceBinBcsr> dA_;
  std::unique_ptr<DeviceBlockJacobi> dM_;
  std::unique_ptr<Mcg> mcg_;
};

class LibraryPcgSolver final : public DeviceSolver {
 public:
  using DeviceSolver::DeviceSolver;
  std::string name() const override { return "gpu-pcg"; }

 private:
  void upload_system(const Bcsr& A) override {
    pcg_.reset();
    M_.setup(A);
    pcg_ = std::make_unique<LibraryPcg>(A, M_);
  }
  /// LibraryPcg keeps no host references: a new one on the new values (the baseline's update).
  void update_system(const Bcsr& A) override { upload_system(A); }
  SolveResult device_solve(const DeviceVector& b, DeviceVector& x, const KrylovParams& p,
                           SolveMonitor* monitor) const override {
    return pcg_->solve(b, x, p, monitor);
  }
  std::string describe_device() const override { return "cusparseDbsrmv + cuBLAS, block Jacobi"; }

  BlockJacobiPreconditioner M_;
  std::unique_ptr<LibraryPcg> pcg_;
};

/// The levels a device cycle can take: at least two, no components held on their own. Returns
/// their number.
int check_device_levels(const mg::LevelProvider& levels, const std::string& method) {
  const int L = levels.num_levels();
  if (L < 2) throw InputError(method + ": needs at least two levels (a degree >= 2 hierarchy)");
  for (int l = 0; l < L; ++l)
    if (levels.constrained_dofs(l))
      throw InputError(method + ": " + levels.level_name(l) + " has components constrained on their own "
                       "(symmetry planes, rollers), which the device cycle's transfers do not mask; use mgpcg");
  return L;
}

/// gpu-pmg and gpu-mgpcg: one device V-cycle (gpu::VCycle) on the hierarchy's levels, matrix-free
/// (DeviceElasticityOperator) or assembled (BIN-BCSR) above the lowest, run as a stationary
/// iteration (gpu::multigrid_solve) or as MGPCG's preconditioner (gpu::mgpcg_solve).
class CycleSolver final : public DeviceSolver {
 public:
  CycleSolver(std::string name, KrylovParams params, const mg::LevelProvider& levels, mg::ChebyshevParams chebyshev,
              bool matrix_free, bool krylov)
      : DeviceSolver(params), name_(std::move(name)), levels_(levels), chebyshev_(chebyshev),
        matrix_free_(matrix_free), krylov_(krylov) {}
  std::string name() const override { return name_; }
  SolverNeeds needs() const override { return {true, matrix_free_}; }

 private:
  void upload_system(const Bcsr& A) override { upload_operator(A); }
  void update_system(const Bcsr&) override { cycle_->update(); }
  void update_operator(const LinearOperator&) override { cycle_->update(); }
  void upload_operator(const LinearOperator& A) override {
    const int L = check_device_levels(levels_, name());
    std::vector<const Bcsr*> matrices(static_cast<std::size_t>(L), nullptr);
    std::vector<const LinearOperator*> operators(static_cast<std::size_t>(L), nullptr);
    matrices[0] = &levels_.matrix(0);
    for (int l = 1; l < L; ++l) {
      const bool finest = l == L - 1;
      if (matrix_free_) {
        const LinearOperator* op = finest ? &A : levels_.matrix_free_operator(l);
        if (!op || !op->elasticity_operator())
          throw InputError(name() + ": " + levels_.level_name(l) +
                           " has no matrix-free elasticity operator; use operator=assembled");
        operators[static_cast<std::size_t>(l)] = op;
      } else {
        if (!finest && !levels_.has_matrix(l))
          throw InputError(name() + ": " + levels_.level_name(l) + " has no assembled matrix");
        matrices[static_cast<std::size_t>(l)] = finest ? &as_bcsr(A, name()) : &levels_.matrix(l);
      }
    }
    const index_t finest_rows = matrix_free_ ? operators.back()->rows() : levels_.matrix(L - 1).rows();
    if (finest_rows != A.rows())
      throw InputError(name() + ": the system is not the finest level of the hierarchy (" + std::to_string(A.rows()) +
                       " vs " + std::to_string(finest_rows) + " unknowns)");
    cycle_.reset();
    transfers_.clear();
    transfers_.reserve(static_cast<std::size_t>(L - 1));
    for (int l = 1; l < L; ++l) transfers_.emplace_back(levels_.prolongation(l));
    std::vector<const mg::BlockTransfer*> transfers;
    for (const auto& t : transfers_) transfers.push_back(&t);
    cycle_ = std::make_unique<VCycle>(matrices, transfers, chebyshev_, operators);
  }
  SolveResult device_solve(const DeviceVector& b, DeviceVector& x, const KrylovParams& p,
                           SolveMonitor* monitor) const override {
    return krylov_ ? mgpcg_solve(*cycle_, b, x, p, monitor) : multigrid_solve(*cycle_, b, x, p, monitor);
  }
  std::string describe_device() const override {
    const char* kind = chebyshev_.kind == mg::ChebyshevKind::first    ? "first"
                       : chebyshev_.kind == mg::ChebyshevKind::fourth ? "fourth"
                                                                      : "optimised fourth";
    return std::to_string(cycle_ ? cycle_->num_levels() : 0) + " levels" +
           (matrix_free_ ? ", matrix-free" : ", assembled (BIN-BCSR)") + ", Chebyshev degree " +
           std::to_string(chebyshev_.degree) + " (" + kind + " kind), CHOLMOD on the host below";
  }

  std::string name_;
  const mg::LevelProvider& levels_;
  mg::ChebyshevParams chebyshev_;
  bool matrix_free_, krylov_;
  std::vector<mg::BlockTransfer> transfers_;
  std::unique_ptr<VCycle> cycle_;
};

/// gpu-mgpcg's keys: the CPU mgpcg's smoother defaults (optimised fourth kind, degree 3).
struct GpuMgpcgParams {
  int degree = 3;
  mg::ChebyshevKind kind = mg::ChebyshevKind::optimal_fourth;
  double lower_fraction = mg::ChebyshevParams{}.lower_fraction;
  std::string op = "auto";
  void visit(ParamVisitor& v) {
    v.integer("degree", degree, 1, 64, "Chebyshev degree of the device smoother (the optimised fourth kind: 1 to 6)");
    v.choice("kind", kind,
             {{"first", mg::ChebyshevKind::first}, {"fourth", mg::ChebyshevKind::fourth},
              {"opt-fourth", mg::ChebyshevKind::optimal_fourth}},
             "Chebyshev kind of the device smoother");
    v.real("lower_fraction", lower_fraction, 1e-6, 1.0 - 1e-6, "lower end of the damped interval, times lmax (first kind)");
    v.choice("operator", op, {"auto", "assembled", "matrix-free"},
             "levels above the lowest: matrix-free (DeviceElasticityOperator) or assembled (BIN-BCSR); auto: "
             "matrix-free where the hierarchy offers it");
  }
};

/// gpu-pmg's smoother keys (the Chebyshev polynomial of the first kind on the device).
struct GpuPmgParams {
  int degree = mg::ChebyshevParams{}.degree;
  double lower_fraction = mg::ChebyshevParams{}.lower_fraction;
  void visit(ParamVisitor& v) {
    v.integer("degree", degree, 1, 64, "Chebyshev degree (first kind) of the device smoother");
    v.real("lower_fraction", lower_fraction, 1e-6, 1.0 - 1e-6, "lower end of the damped interval, times lmax");
  }
};

}  // namespace

void register_solvers() {
  KrylovParams mcg_defaults;
  mcg_defaults.check_every = 10;
  register_builtin_solver({"gpu-mcg", "GPU: merged CG with block Jacobi on BIN-BCSR (CUDA)",
                   krylov_keys(mcg_defaults) + check_every_key(mcg_defaults), false, true, "gpu"},
                  [mcg_defaults](const Config& c, const SolverContext&) -> std::unique_ptr<Solver> {
                    KrylovParams p = read_krylov(c, mcg_defaults);
                    ParamReader r(c);
                    p.visit_check_every(r);
                    return std::make_unique<McgSolver>(p);
                  });
  register_builtin_solver({"gpu-pcg", "GPU: block-Jacobi PCG from cuSPARSE/cuBLAS calls (CUDA)", krylov_keys(), false, true,
                   "gpu"},
                  [](const Config& c, const SolverContext&) -> std::unique_ptr<Solver> {
                    return std::make_unique<LibraryPcgSolver>(read_krylov(c));
                  });
  register_builtin_solver({"gpu-pmg", "GPU: p-multigrid, Chebyshev V-cycle on the GPU, CHOLMOD lowest level (CUDA)",
                   krylov_keys() + list_params<GpuPmgParams>(), true, true, "gpu"},
                  [](const Config& c, const SolverContext& ctx) -> std::unique_ptr<Solver> {
                    if (!ctx.levels) c.fail("method", "gpu-pmg needs a level hierarchy (an FEM system)");
                    const GpuPmgParams g = read_params<GpuPmgParams>(c);
                    mg::ChebyshevParams cheb;
                    cheb.degree = g.degree;
                    cheb.lower_fraction = g.lower_fraction;
                    return std::make_unique<CycleSolver>("gpu-pmg", read_krylov(c), *ctx.levels, cheb, false, false);
                  });
  register_builtin_solver({"gpu-mgpcg",
                           "GPU: PCG preconditioned by a Chebyshev V-cycle on the GPU (matrix-free or assembled "
                           "levels), CHOLMOD lowest level (CUDA)",
                           krylov_keys() + list_params<GpuMgpcgParams>(), true, true, "gpu"},
                          [](const Config& c, const SolverContext& ctx) -> std::unique_ptr<Solver> {
                            if (!ctx.levels) c.fail("method", "gpu-mgpcg needs a level hierarchy (an FEM system)");
                            const GpuMgpcgParams g = read_params<GpuMgpcgParams>(c);
                            mg::ChebyshevParams cheb;
                            cheb.degree = g.degree;
                            cheb.kind = g.kind;
                            cheb.lower_fraction = g.lower_fraction;
                            cheb.update_iterations = 1;  // as the CPU mgpcg: one warm-started power step per update
                            try {
                              const mg::Chebyshev check(cheb);  // the smoother's own checks (opt-fourth: degree <= 6)
                            } catch (const InputError& e) {
                              c.fail("degree", e.what());
                            }
                            const bool mf = g.op == "matrix-free" || (g.op == "auto" && ctx.levels->offers_matrix_free());
                            if (g.op == "matrix-free" && !ctx.levels->offers_matrix_free())
                              c.fail("operator", "the hierarchy offers no matrix-free operators (an FEM scene's levels do)");
                            return std::make_unique<CycleSolver>("gpu-mgpcg", read_krylov(c), *ctx.levels, cheb, mf, true);
                          });
}

}  // namespace pmg::gpu
