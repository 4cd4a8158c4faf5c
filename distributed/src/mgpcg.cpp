// petsc-mgpcg (pmg/distributed/mgpcg.hpp).
#include "pmg/distributed/mgpcg.hpp"
#include "agreement.hpp"
#include "pmg/sparse/timer.hpp"
#include "pmg/sparse/defaults.hpp"

#include "pmg/mpi/agreement.hpp"
#include "pmg/mpi/session.hpp"
#include "pmg/petsc/pcmg.hpp"
#include "pmg/petsc/petsc.hpp"
#include "pmg/sparse/factory.hpp"
#include "pmg/sparse/params.hpp"

#include <chrono>
#include <mutex>
#include <sstream>

namespace pmg::dist {

void DistributedMgpcgParams::visit(ParamVisitor& v) {
  visit_stopping_keys(v, tol, rhs_floor, max_iterations, throw_on_failure);  // the common keys
  v.integer("smoothing_steps", smoothing_steps, 1, 100, "Chebyshev steps per pre- and post-smoothing");
  v.choice("lowest_level", lowest_level, {"auto", "mumps", "gamg", "boomeramg", "hypre", "cholmod"},
           ("the lowest level's method by mgpcg's names: auto: MUMPS below " + std::to_string(kAmgAcrossRanksUnknowns) +
            " unknowns on the linear level, BoomerAMG (one V-cycle through PETSc's PCHYPRE) from there; mumps: "
            "Cholesky; gamg: one GAMG V-cycle with the rigid-body near-null space; boomeramg (alias hypre); "
            "cholmod (mgpcg's) factors on one process and is refused: mumps is the Cholesky across ranks")
               .c_str());
  v.text("options", options, "further PETSc options (\"-name value ...\": -mg_levels_..., -mg_coarse_...), "
                             "under this solver's own prefix");
}

petsc::PcmgParams to_pcmg(const DistributedMgpcgParams& params) {
  petsc::PcmgParams p;
  p.rel_tol = params.tol;
  p.max_iterations = params.max_iterations;
  p.rhs_floor = params.rhs_floor;
  p.smoothing_steps = params.smoothing_steps;
  p.lowest_level = params.lowest_level;
  p.options = params.options;
  p.allow_unused_options = params.allow_unused_options;
  return p;
}

DistributedMgpcg::DistributedMgpcg(const fem::DegreeHierarchy& serial, DistributedMgpcgParams params, MPI_Comm comm)
    : serial_(&serial), params_(std::move(params)), comm_(comm) {
  if (serial.num_levels() < 2)
    throw InputError("petsc-mgpcg: needs at least two levels (an FEM scene of degree >= 2)");
}

DistributedMgpcg::~DistributedMgpcg() = default;

void DistributedMgpcg::setup_impl(const LinearOperator& A) {
  // Every rank partitions its own copy of the model: they must be the same model and keys, else
  // the ranks' parts do not fit together (a hang or a wrong answer).
  std::vector<mpi::Item> items = detail::params_items(params_);
  const std::vector<mpi::Item> model = detail::hierarchy_items(*serial_);
  items.insert(items.end(), model.begin(), model.end());
  mpi::check_agreement(comm_, items, "petsc-mgpcg");
  mpi::together(comm_, [&] {
    const index_t n = 3 * serial_->finest().assembler().num_free();
    if (A.rows() != n)
      throw InputError("petsc-mgpcg: set up on an operator of " + std::to_string(A.rows()) +
                       " rows; the scene's finest level has " + std::to_string(n) + " unknowns");
  });
  mpi::together(comm_, [&] { set_up_ranks(); });
}

void DistributedMgpcg::set_up_ranks() {
  partition_seconds_.clear();
  auto t0 = Clock::now();
  ranks_ = std::make_unique<RankHierarchy>(*serial_, comm_);
  partition_seconds_.emplace_back("partition and the rank's hierarchy", seconds_since(t0));
  t0 = Clock::now();
  ranks_->bring_to(*serial_);
  std::vector<petsc::RankLevel> levels = ranks_->rank_levels();
  partition_seconds_.emplace_back("the rank's operators", seconds_since(t0));
  solver_ = std::make_unique<petsc::PMultigridCg>(comm_, to_pcmg(params_));
  solver_->setup(std::move(levels));
  ghosts_.clear();
  for (int l = ranks_->num_levels() - 1; l >= 0; --l) {
    const long mine[2] = {ranks_->ghosts(l), ranks_->owned(l)};
    std::vector<long> all(2 * static_cast<size_t>(ranks_->size()));
    {
      std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
      MPI_Allgather(mine, 2, MPI_LONG, all.data(), 2, MPI_LONG, comm_);
    }
    ghosts_.emplace_back();
    for (int r = 0; r < ranks_->size(); ++r) ghosts_.back().emplace_back(all[2 * r], all[2 * r + 1]);
  }
}

void DistributedMgpcg::update_impl() {
  // The mesh, material and fixed nodes were compared at set-up; new values may change the stiffness.
  const auto& scale = serial_->finest().stiffness_scale();
  mpi::check_agreement(comm_, {{"the per-element stiffness", "digest " + mpi::digest(scale.data(), scale.size() * sizeof(double))}},
                       "petsc-mgpcg: update");
  mpi::together(comm_, [&] {
    ranks_->bring_to(*serial_);
    solver_->refresh();
  });
}

SolveResult DistributedMgpcg::solve_impl(const Vector& b, Vector& x, SolveMonitor* monitor) const {
  // Every rank holds the whole b and x0: they must be the same vectors.
  mpi::check_agreement(comm_, {{"the right-hand side", "digest " + mpi::digest(b)}, {"the starting guess", "digest " + mpi::digest(x)}},
                       "petsc-mgpcg: solve");
  const int top = ranks_->num_levels() - 1;
  // A held component is an identity row of the serial operator (x = b there) and the ranks' count
  // times the identity in PETSc's: solved with b and x zero there, then given b's value.
  const std::vector<char>& held = serial_->finest().constrained_free_dofs();
  Vector bz = b, xz = x;
  for (size_t i = 0; i < held.size(); ++i)
    if (held[i]) bz[static_cast<Eigen::Index>(i)] = xz[static_cast<Eigen::Index>(i)] = 0.0;
  const Vector b_owned = ranks_->owned_part(top, bz);
  Vector x_owned = ranks_->owned_part(top, xz);
  SolveResult res;
  mpi::together(comm_, [&] { res = solver_->solve(b_owned, x_owned, monitor); });
  x = ranks_->gather(top, x_owned);
  for (size_t i = 0; i < held.size(); ++i)
    if (held[i]) x[static_cast<Eigen::Index>(i)] = b[static_cast<Eigen::Index>(i)];
  if (!res.ok() && params_.throw_on_failure) throw SolveError(res);
  return res;
}

void DistributedMgpcg::apply_impl(const Vector& b, Vector& x) const {
  x = Vector::Zero(b.size());
  solve_impl(b, x, nullptr);
}

std::string DistributedMgpcg::describe() const {
  if (!solver_) return "petsc-mgpcg (not set up)";
  std::ostringstream s;
  s << solver_->describe() << "; ghost/owned nodes per rank: ";
  for (size_t k = 0; k < ghosts_.size(); ++k) {
    s << (k ? "; " : "") << ranks_->local().level_name(ranks_->num_levels() - 1 - static_cast<int>(k));
    for (const auto& [ghosts, owned] : ghosts_[k]) s << " " << ghosts << "/" << owned;
  }
  return s.str();
}

TimingBreakdown DistributedMgpcg::setup_timings() const {
  TimingBreakdown t;
  if (!solver_) return t;
  t = solver_->setup_timings();
  t.parts.insert(t.parts.begin(), partition_seconds_.begin(), partition_seconds_.end());
  return t;
}

void register_solvers() {
  static std::once_flag once;
  std::call_once(once, [] {
    register_builtin_solver(
        {"petsc-mgpcg",
         "p-multigrid preconditioned CG across MPI ranks on PETSc (CG + PCMG; METIS partition, shell levels)",
         list_params<DistributedMgpcgParams>(), true, false, "distributed", [] { mg::start_petsc(); },
         /*across_ranks=*/true},
        [](const Config& c, const SolverContext& ctx) -> std::unique_ptr<Solver> {
          const fem::DegreeHierarchy* h = ctx.levels ? ctx.levels->partitionable_hierarchy() : nullptr;
          if (!h)
            c.fail("method", "petsc-mgpcg needs an FEM scene (--box, --mesh or a scene file): it partitions "
                             "the mesh, which a matrix file does not have");
          MPI_Comm comm = MPI_COMM_WORLD;
          if (ctx.communicator >= 0) {
            int initialized = 0;
            MPI_Initialized(&initialized);
            if (!initialized)
              c.fail("method", "petsc-mgpcg: a communicator was given before MPI was started");
            comm = MPI_Comm_f2c(static_cast<MPI_Fint>(ctx.communicator));
            if (comm == MPI_COMM_NULL) c.fail("method", "petsc-mgpcg: the communicator is MPI_COMM_NULL");
          }
          DistributedMgpcgParams p = read_params<DistributedMgpcgParams>(c);
          p.allow_unused_options = unused_options_allowed(c);
          return std::make_unique<DistributedMgpcg>(*h, p, comm);
        });
  });
}

}  // namespace pmg::dist
