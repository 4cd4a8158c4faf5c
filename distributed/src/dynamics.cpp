// Implicit Euler across MPI ranks (pmg/distributed/dynamics.hpp).
#include "pmg/distributed/dynamics.hpp"
#include "agreement.hpp"
#include "pmg/sparse/threads.hpp"

#include "pmg/fem/vtk_writer.hpp"
#include "pmg/mpi/agreement.hpp"
#include "pmg/mpi/session.hpp"
#include "pmg/petsc/pcmg.hpp"
#include "pmg/sparse/timer.hpp"

#include <cmath>
#include <cstdint>
#include <mutex>
#include <string>

namespace pmg::dist {

namespace {

/// Every rank learns whether any rank failed; every rank throws the lowest failed rank's error,
/// so that no rank waits in a collective call for one that left.
void agree_on(MPI_Comm comm, const std::string& error, const std::string& what) {
  mpi::agree_on_error(comm, error.empty() ? error : what + ": " + error);
}

/// petsc::PMultigridCg on the rank's levels as the seam's Solver: it reads the rank's matrix-free
/// levels above an assembled linear level, which fem::BoundSystem prepares; its set-up and update
/// are the PETSc solver's setup() and refresh() (collective calls). A step solves through the
/// PETSc solver itself, on owned unknowns, so this Solver is never applied.
class RankLevels final : public Solver {
 public:
  RankLevels(petsc::PMultigridCg& solver, RankHierarchy& ranks) : solver_(solver), ranks_(ranks) {}
  std::string name() const override { return "petsc-mgpcg (the rank's levels)"; }
  SolverNeeds needs() const override { return {/*lower_levels=*/true, /*matrix_free=*/true, /*lowest_level=*/0}; }

 private:
  void setup_impl(const LinearOperator&) override { solver_.setup(ranks_.rank_levels()); }
  void update_impl() override { solver_.refresh(); }
  void apply_impl(const Vector&, Vector&) const override {
    throw Error("petsc-mgpcg: the rank's levels are solved on owned unknowns (DistributedEuler::step)");
  }
  petsc::PMultigridCg& solver_;
  RankHierarchy& ranks_;
};

}  // namespace

DistributedEuler::DistributedEuler(const fem::DegreeHierarchy& serial, const Vector& f_ext,
                                   const fem::SimulationParams& p, DistributedMgpcgParams solver, MPI_Comm comm)
    : serial_(serial), p_(p), comm_(comm) {
  const fem::ElasticityModel& m = serial.finest();
  // Each rank was handed the whole model: the same on every rank, or a named error on all.
  std::vector<mpi::Item> items = {{"dt", detail::exact(p.dt)},
                                  {"rayleigh_alpha", detail::exact(p.rayleigh_alpha)},
                                  {"rayleigh_beta", detail::exact(p.rayleigh_beta)},
                                  {"the material model", p.corotational ? "corotational" : "linear"},
                                  {"the external force", "digest " + mpi::digest(f_ext)}};
  for (const std::vector<mpi::Item>& part : {detail::params_items(solver), detail::hierarchy_items(serial)})
    items.insert(items.end(), part.begin(), part.end());
  mpi::check_agreement(comm, items, "distributed time step");
  mpi::together(comm, [&] { fem::check_simulation(m, f_ext, p); });
  if (serial.num_levels() < 2)
    throw InputError("distributed time step: needs at least two levels (an FEM scene of degree >= 2)");
  if (holds_components(serial))
    throw InputError("distributed time step: components held on their own (symmetry planes, supports) "
                     "are not supported across ranks yet; use mgpcg on one process");
  ranks_ = std::make_unique<RankHierarchy>(serial, comm);
  const int top = ranks_->num_levels() - 1;
  ghosts_ = std::make_unique<petsc::GhostExchange>(comm, ranks_->first(top), ranks_->owned(top), ranks_->global(top));
  f_ext_owned_ = ranks_->owned_part(top, m.restrict_to_free(f_ext));
  solver_ = std::make_unique<petsc::PMultigridCg>(comm, to_pcmg(solver));
  rank_solver_ = std::make_unique<RankLevels>(*solver_, *ranks_);
  system_ = std::make_unique<fem::BoundSystem>(ranks_->local().bind(*rank_solver_));
  set_state(Vector::Zero(m.num_dofs()), Vector::Zero(m.num_dofs()));
}

DistributedEuler::~DistributedEuler() = default;

double DistributedEuler::sum(double mine) const {
  double all = 0.0;
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  MPI_Allreduce(&mine, &all, 1, MPI_DOUBLE, MPI_SUM, comm_);
  return all;
}

void DistributedEuler::agree(const std::string& error, const std::string& what) const {
  agree_on(comm_, error, what);
}

void DistributedEuler::require_same_on_every_rank(const std::string& name, const std::string& value) const {
  mpi::check_agreement(comm_, {{name, value}}, "distributed time step");
}

bool DistributedEuler::any_rank(bool mine) const {
  int flag = mine ? 1 : 0, any = 0;
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  MPI_Allreduce(&flag, &any, 1, MPI_INT, MPI_MAX, comm_);
  return any != 0;
}

void DistributedEuler::set_state(const Vector& u, const Vector& v) {
  const fem::ElasticityModel& m = serial_.finest();
  mpi::check_agreement(comm_, {{"the displacement", "digest " + mpi::digest(u)}, {"the velocity", "digest " + mpi::digest(v)}},
                       "distributed time step: set_state");
  mpi::together(comm_, [&] { fem::check_state(m, u, v); });
  const int top = ranks_->num_levels() - 1;
  const fem::ElasticityModel& local = ranks_->local().finest();
  u_local_ = ranks_->local_part(serial_, top, u);
  v_local_ = local.restrict_to_free(ranks_->local_part(serial_, top, v));
  u_owned_ = ranks_->owned_part(top, m.restrict_to_free(u));
  v_owned_ = ranks_->owned_part(top, m.restrict_to_free(v));
  state_.valid = false;
}

void DistributedEuler::evaluate_state() const {
  if (state_.valid) return;
  state_.seconds = {};
  fem::DegreeHierarchy& local = ranks_->local();
  const fem::StepWeights w = fem::step_weights(p_);
  const fem::Rotations* R = p_.corotational ? &state_.R : nullptr;
  Vector force;
  double energy = 0.0;
  fem::EvaluateSeconds s;
  auto t0 = Clock::now();
  std::string error;  // the rank's own elements first; any rank's failure is every rank's
  try {
    if (p_.corotational) {
      state_.R = local.finest().rotations(u_local_);
      state_.seconds[fem::kRotations] = seconds_since(t0);
    }
    // The finest operator with the force and energy (linear material: final after the first step).
    s = system_->evaluate(u_local_, R, {w.mass, w.stiffness}, &force, &energy,
                          p_.corotational || !rank_solver_->is_set_up());
    state_.seconds[fem::kAssembly] = s.finest;
  } catch (const std::exception& e) {
    error = e.what();
  }
  t0 = Clock::now();
  agree_on(comm_, error, "step " + std::to_string(step_ + 1));
  ghosts_->add_to_owners(local.finest().restrict_to_free(force), state_.force_owned);
  state_.energy = sum(energy);
  state_.seconds[fem::kForces] = s.force + seconds_since(t0);
  state_.valid = true;
}

fem::StepStats DistributedEuler::step() {
  const ThreadBudget budget;  // the cores free now, for the whole step (pmg/sparse/threads.hpp)
  evaluate_state();
  fem::StepStats st;
  st.seconds = state_.seconds;
  fem::DegreeHierarchy& local = ranks_->local();
  const int top = local.num_levels() - 1;
  const fem::StepWeights w = fem::step_weights(p_);
  if (p_.corotational || !rank_solver_->is_set_up()) {
    // The lower degrees get the same rotations and weights (the seam prepares what the rank's
    // solver reads: matrix-free degrees, the linear level assembled); every rank agrees on the
    // rank-local work before the collective set-up.
    const auto t0 = Clock::now();
    const fem::Rotations* R = p_.corotational ? &state_.R : nullptr;
    std::string error;
    try {
      system_->prepare(R, {w.mass, w.stiffness}, /*finest=*/false);
    } catch (const std::exception& e) {
      error = e.what();
    }
    agree_on(comm_, error, "step " + std::to_string(step_ + 1));
    system_->set_up_solver();
    st.seconds[fem::kHierarchy] = seconds_since(t0);
  }
  // b = M v + Δt (f_ext + f_el(x)) on the owned unknowns.
  auto t0 = Clock::now();
  Vector mv_local(system_->mass().rows()), b;
  system_->mass().apply(v_local_, mv_local);
  ghosts_->add_to_owners(mv_local, b);
  b += p_.dt * (f_ext_owned_ + state_.force_owned);
  st.seconds[fem::kForces] += seconds_since(t0);

  // The warm start is kept only where it beats zero (fem::ImplicitEuler::step()).
  t0 = Clock::now();
  const double bn = std::sqrt(sum(b.squaredNorm()));
  Vector av;
  solver_->multiply(top, v_owned_, av);
  if (std::sqrt(sum((b - av).squaredNorm())) > bn) v_owned_.setZero();
  const SolveResult res = solver_->solve(b, v_owned_);
  if (!res.ok()) {
    SolveResult r = res;
    r.message = "step " + std::to_string(step_ + 1) + " (t = " + std::to_string(t_ + p_.dt) +
                " s): petsc-mgpcg failed: " + res.message;
    throw SolveError(r);
  }
  st.seconds[fem::kSolve] = seconds_since(t0);
  agree_on(comm_, v_owned_.allFinite() ? "" : "the velocity is not finite", "step " + std::to_string(step_ + 1));

  ghosts_->to_local(v_owned_, v_local_);
  u_local_ += p_.dt * local.finest().expand(v_local_, Vector());
  u_owned_ += p_.dt * v_owned_;
  state_.valid = false;
  fem::finish_step(st, step_, t_, p_.dt, res, bn);
  return st;
}

double DistributedEuler::kinetic_energy() const {
  Vector mv(system_->mass().rows());
  system_->mass().apply(v_local_, mv);
  return sum(0.5 * v_local_.dot(mv));
}

double DistributedEuler::elastic_energy() const {
  evaluate_state();
  return state_.energy;
}

double DistributedEuler::external_work() const { return sum(f_ext_owned_.dot(u_owned_)); }

fem::Vec3 DistributedEuler::displacement_at(index_t serial_element, const Eigen::Vector4d& barycentric) const {
  if (serial_element < 0 || serial_element >= serial_.finest().space().mesh().num_tets())
    throw InputError("distributed time step: no element " + std::to_string(serial_element));
  const index_t e = ranks_->local_element(serial_element);
  fem::Vec3 mine = fem::Vec3::Zero(), all = fem::Vec3::Zero();
  if (e >= 0) mine = ranks_->local().finest().displacement_at(u_local_, e, barycentric);
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  MPI_Allreduce(mine.data(), all.data(), 3, MPI_DOUBLE, MPI_SUM, comm_);
  return all;
}

Vector DistributedEuler::gather_displacement() const {
  const int top = ranks_->num_levels() - 1;
  return serial_.finest().expand(ranks_->gather(top, u_owned_), Vector());
}

std::string DistributedEuler::write_frame(const std::string& directory, const std::string& stem) const {
  const int rank = ranks_->rank();
  std::string error;
  try {
    fem::write_vtu(directory + "/" + stem + "_" + std::to_string(rank) + ".vtu", ranks_->local().finest().space(),
                   u_local_);
  } catch (const std::exception& e) {
    error = e.what();
  }
  agree_on(comm_, error, "frame " + stem);  // the .pvtu names complete pieces only
  if (rank == 0) {
    try {
      std::vector<std::string> pieces;
      for (int r = 0; r < ranks_->size(); ++r) pieces.push_back(stem + "_" + std::to_string(r) + ".vtu");
      fem::write_pvtu(directory + "/" + stem + ".pvtu", pieces, true);
    } catch (const std::exception& e) {
      error = e.what();
    }
  }
  agree_on(comm_, error, "frame " + stem);
  return stem + ".pvtu";
}

std::string DistributedEuler::describe() const {
  return rank_solver_->is_set_up() ? solver_->describe() : "petsc-mgpcg (not set up: no step yet)";
}

}  // namespace pmg::dist
