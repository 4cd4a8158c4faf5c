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
#include <sstream>
#include <string>
#include <tuple>

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

/// What every rank's step must agree on: the step's parameters and the solver's keys.
std::vector<mpi::Item> step_items(const fem::SimulationParams& p, const DistributedMgpcgParams& solver) {
  std::vector<mpi::Item> items = {{"dt", detail::exact(p.dt)},
                                  {"rayleigh_alpha", detail::exact(p.rayleigh_alpha)},
                                  {"rayleigh_beta", detail::exact(p.rayleigh_beta)},
                                  {"the material model", p.corotational ? "corotational" : "linear"}};
  const std::vector<mpi::Item> keys = detail::params_items(solver);
  items.insert(items.end(), keys.begin(), keys.end());
  return items;
}

}  // namespace

/// A rank's StepPart: owned unknowns in global order, its free local nodes' values from their
/// owners and its element sums into them (petsc::GhostExchange), sums over the ranks, a rank's own
/// failure every rank's, and the PETSc solver on the owned unknowns.
class DistributedEuler::RankPart final : public fem::StepPart {
 public:
  RankPart(DistributedEuler& e) : e_(e) {}
  const fem::ElasticityModel& finest() const override { return e_.ranks_->local().finest(); }
  fem::BoundSystem& system() const override { return *e_.system_; }
  void add_to_owners(const Vector& local, Vector& owned) const override { e_.ghosts_->add_to_owners(local, owned); }
  void to_local(const Vector& owned, Vector& local) const override { e_.ghosts_->to_local(owned, local); }
  double sum(double mine) const override { return e_.sum(mine); }
  void together(const std::function<void()>& f) const override { mpi::together(e_.comm_, f); }
  void agree(const std::string& error, const std::string& what) const override { agree_on(e_.comm_, error, what); }
  double residual_norm(const Vector& b, const Vector& v) const override {
    Vector av;
    e_.solver_->multiply(e_.ranks_->num_levels() - 1, v, av);
    return std::sqrt(e_.sum((b - av).squaredNorm()));
  }
  SolveResult solve(const Vector& b, Vector& v) override {
    const SolveResult res = e_.solver_->solve(b, v);
    if (!res.ok() && e_.params_.throw_on_failure) throw SolveError(res);
    return res;
  }
  std::string solver_name() const override { return "petsc-mgpcg"; }

 private:
  DistributedEuler& e_;
};

DistributedEuler::DistributedEuler(const fem::DegreeHierarchy& serial, const Vector& f_ext,
                                   const fem::SimulationParams& p, DistributedMgpcgParams solver, MPI_Comm comm)
    : serial_(&serial), p_(p), comm_(comm) {
  const fem::ElasticityModel& m = serial.finest();
  // Each rank was handed the whole model: the same on every rank, or a named error on all.
  std::vector<mpi::Item> items = step_items(p, solver);
  items.push_back({"the external force", "digest " + mpi::digest(f_ext)});
  const std::vector<mpi::Item> model = detail::hierarchy_items(serial);
  items.insert(items.end(), model.begin(), model.end());
  mpi::check_agreement(comm, items, "distributed time step");
  mpi::together(comm, [&] { fem::check_simulation(m, f_ext, p); });
  if (serial.num_levels() < 2)
    throw InputError("distributed time step: needs at least two levels (an FEM scene of degree >= 2)");
  own_ranks_ = std::make_unique<RankHierarchy>(serial, comm);
  ranks_ = own_ranks_.get();
  const int top = ranks_->num_levels() - 1;
  build(ranks_->owned_part(top, m.restrict_to_free(f_ext)), solver);
}

DistributedEuler::DistributedEuler(RankHierarchy& ranks, const Vector& f_ext_owned, const fem::SimulationParams& p,
                                   DistributedMgpcgParams solver)
    : p_(p), comm_(ranks.comm()), ranks_(&ranks) {
  mpi::check_agreement(comm_, step_items(p, solver), "distributed time step");
  const int top = ranks.num_levels() - 1;
  mpi::together(comm_, [&] {
    const fem::ElasticityModel& local = ranks.local().finest();
    if (f_ext_owned.size() != 3 * static_cast<Eigen::Index>(ranks.owned(top)))
      throw InputError("distributed time step: an external force of " + std::to_string(f_ext_owned.size()) +
                       " entries for " + std::to_string(3 * ranks.owned(top)) + " owned unknowns");
    if (!f_ext_owned.allFinite()) throw InputError("distributed time step: the external force is not finite");
    fem::check_simulation(local, Vector::Zero(local.num_dofs()), p);
  });
  if (ranks.num_levels() < 2)
    throw InputError("distributed time step: needs at least two levels (an FEM scene of degree >= 2)");
  build(f_ext_owned, solver);
}

void DistributedEuler::build(const Vector& f_ext_owned, const DistributedMgpcgParams& solver) {
  const int top = ranks_->num_levels() - 1;
  ghosts_ = std::make_unique<petsc::GhostExchange>(comm_, ranks_->first(top), ranks_->owned(top), ranks_->global(top));
  params_ = solver;
  solver_ = std::make_unique<petsc::PMultigridCg>(comm_, to_pcmg(solver));
  rank_solver_ = std::make_unique<RankLevels>(*solver_, *ranks_);
  system_ = std::make_unique<fem::BoundSystem>(ranks_->local().bind(*rank_solver_));
  part_ = std::make_unique<RankPart>(*this);
  step_ = std::make_unique<fem::EulerStep>(*part_, p_, f_ext_owned);
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
  if (!serial_)
    throw InputError("distributed time step: set_state takes serial vectors, and this one runs on a distributed mesh "
                     "(set_state_local)");
  const fem::ElasticityModel& m = serial_->finest();
  mpi::check_agreement(comm_, {{"the displacement", "digest " + mpi::digest(u)}, {"the velocity", "digest " + mpi::digest(v)}},
                       "distributed time step: set_state");
  mpi::together(comm_, [&] { fem::check_state(m, u, v); });
  const int top = ranks_->num_levels() - 1;
  const fem::ElasticityModel& local = ranks_->local().finest();
  step_->set_state(ranks_->local_part(*serial_, top, u), local.restrict_to_free(ranks_->local_part(*serial_, top, v)),
                   ranks_->owned_part(top, m.restrict_to_free(u)), ranks_->owned_part(top, m.restrict_to_free(v)));
}

void DistributedEuler::set_state_local(const Vector& u, const Vector& v) {
  const int top = ranks_->num_levels() - 1;
  const fem::ElasticityModel& local = ranks_->local().finest();
  mpi::together(comm_, [&] {
    for (const Vector* x : {&u, &v}) {
      const char* what = x == &u ? "displacement" : "velocity";
      if (x->size() != local.num_dofs())
        throw InputError(std::string("distributed time step: set_state_local: a ") + what + " of " +
                         std::to_string(x->size()) + " entries for the rank's " + std::to_string(local.num_dofs()));
      if (!x->allFinite()) throw InputError(std::string("distributed time step: set_state_local: the ") + what + " is not finite");
    }
  });
  // A component held at zero (a support or symmetry plane) must start at zero, as fem::check_state says.
  mpi::together(comm_, [&] {
    const std::vector<char>& held = local.constrained_free_dofs();
    const auto& fi = local.assembler().free_index();
    for (index_t i = 0; i < local.num_nodes() && !held.empty(); ++i)
      for (int c = 0; c < 3 && fi[i] >= 0; ++c)
        if (held[3 * static_cast<size_t>(fi[i]) + c] && (u[3 * i + c] != 0.0 || v[3 * i + c] != 0.0))
          throw InputError("distributed time step: set_state_local: a node holds its " + std::string(1, char('x' + c)) +
                           " component at zero (a support or symmetry plane) but starts with it moved");
  });
  // The owned part of the rank's free nodes; the ghosts then take their owners' values.
  const Vector uf = local.restrict_to_free(u), vf = local.restrict_to_free(v);
  const std::vector<index_t>& global = ranks_->global(top);
  const index_t first = ranks_->first(top), owned = ranks_->owned(top);
  Vector u_owned(ghosts_->owned_size()), v_owned(ghosts_->owned_size());
  for (size_t i = 0; i < global.size(); ++i) {
    const index_t k = global[i] - first;
    if (k < 0 || k >= owned) continue;
    u_owned.segment<3>(3 * k) = uf.segment<3>(3 * static_cast<Eigen::Index>(i));
    v_owned.segment<3>(3 * k) = vf.segment<3>(3 * static_cast<Eigen::Index>(i));
  }
  step_->set_state_owned(std::move(u_owned), std::move(v_owned));
}

/// The rank's share of set_static_state's fixed point (fem::corotational_fixed_point): the state is
/// the rank's owned unknowns, each correction solved across the ranks by the static solve's own
/// PETSc solver, the norms summed over the ranks.
class DistributedEuler::StaticRankPart final : public fem::StaticPart {
 public:
  StaticRankPart(DistributedEuler& e, const Vector& f_owned, petsc::PMultigridCg& solver, int* solver_iterations)
      : e_(e), f_owned_(f_owned), solver_(solver), solver_iterations_(solver_iterations) {}

  Vector correction(const Vector& u, int it) override {
    // K_R δ = f + f_el(u) (pmg/fem/static_solve.hpp) at the state u on every rank's nodes.
    e_.step_->set_state_owned(u, Vector::Zero(u.size()));
    fem::DegreeHierarchy& local = e_.ranks_->local();
    const bool corotational = e_.p_.corotational;
    fem::Rotations R;
    Vector force;
    std::string error;
    try {
      if (corotational) R = local.finest().rotations(e_.step_->u_local());
      e_.system_->evaluate(e_.step_->u_local(), corotational ? &R : nullptr, {}, &force, nullptr);
      e_.system_->prepare(corotational ? &R : nullptr, {}, /*finest=*/false);
    } catch (const std::exception& ex) {
      error = ex.what();
    }
    agree_on(e_.comm_, error, "static state, iteration " + std::to_string(it));
    if (it == 1) solver_.setup(e_.ranks_->rank_levels());
    else solver_.refresh();
    Vector rhs;
    e_.ghosts_->add_to_owners(local.finest().restrict_to_free(force), rhs);
    rhs += f_owned_;
    Vector delta = Vector::Zero(rhs.size());
    const SolveResult res = solver_.solve(rhs, delta);
    if (solver_iterations_) *solver_iterations_ += res.iterations;
    if (!res.ok()) {
      SolveResult r = res;
      r.message = "static state: iteration " + std::to_string(it) + ": petsc-mgpcg failed: " + res.message;
      throw SolveError(r);
    }
    return delta;
  }
  double norm(const Vector& v) const override { return std::sqrt(e_.sum(v.squaredNorm())); }

 private:
  DistributedEuler& e_;
  const Vector& f_owned_;
  petsc::PMultigridCg& solver_;
  int* solver_iterations_;
};

int DistributedEuler::set_static_state(const Vector& f_owned, const fem::StaticOptions& options, double solve_tol,
                                       int* solver_iterations) {
  if (solver_iterations) *solver_iterations = 0;
  mpi::check_agreement(comm_,
                       {{"the static solve's tolerance", detail::exact(solve_tol)},
                        {"corotational_tol", detail::exact(options.corotational_tol)},
                        {"max_corotational_iterations", std::to_string(options.max_corotational_iterations)},
                        {"relaxation", detail::exact(options.relaxation)}},
                       "distributed time step: set_static_state");
  mpi::together(comm_, [&] {
    if (f_owned.size() != ghosts_->owned_size())
      throw InputError("distributed time step: a static load of " + std::to_string(f_owned.size()) + " entries for " +
                       std::to_string(ghosts_->owned_size()) + " owned unknowns");
    if (!f_owned.allFinite()) throw InputError("distributed time step: the static load is not finite");
    if (!(solve_tol > 0 && solve_tol < 1)) throw InputError("distributed time step: a static solve tolerance in (0, 1)");
    if (!(options.relaxation > 0 && options.relaxation <= 1) || options.max_corotational_iterations < 1)
      throw InputError("distributed time step: the fixed point's relaxation in (0, 1] and at least one iteration");
  });
  // Its own solver on the stiffness alone, to solve_tol: the step solver keeps its tolerance.
  DistributedMgpcgParams sp = params_;
  sp.tol = solve_tol;
  sp.rhs_floor = 0.0;
  petsc::PMultigridCg solver(comm_, to_pcmg(sp));
  // The state is the iterate from here; a failure restores the one before (every rank fails alike).
  const Vector u_before = step_->u_owned(), v_before = step_->v_owned();
  Vector u = Vector::Zero(ghosts_->owned_size());
  step_->set_state_owned(u, u);
  step_->levels_changed();  // the levels below carry the stiffness alone until the next step
  try {
    StaticRankPart part(*this, f_owned, solver, solver_iterations);
    const fem::FixedPointStats stats = fem::corotational_fixed_point(part, u, p_.corotational, options, "static state");
    step_->set_state_owned(u, Vector::Zero(u.size()));
    return stats.iterations;
  } catch (...) {
    step_->set_state_owned(u_before, v_before);
    throw;
  }
}

fem::StepStats DistributedEuler::step() { return step_->step(); }
double DistributedEuler::time() const { return step_->time(); }
int DistributedEuler::steps() const { return step_->steps(); }
const Vector& DistributedEuler::displacement_owned() const { return step_->u_owned(); }
double DistributedEuler::kinetic_energy() const { return step_->kinetic_energy(); }
double DistributedEuler::elastic_energy() const { return step_->elastic_energy(); }
double DistributedEuler::external_work() const { return step_->external_work(); }

fem::Vec3 DistributedEuler::displacement_at(index_t serial_element, const Eigen::Vector4d& barycentric) const {
  if (!serial_) throw InputError("distributed time step: no serial elements on a distributed mesh (locate a point)");
  if (serial_element < 0 || serial_element >= serial_->finest().space().mesh().num_tets())
    throw InputError("distributed time step: no element " + std::to_string(serial_element));
  const index_t e = ranks_->local_element(serial_element);
  fem::Vec3 mine = fem::Vec3::Zero(), all = fem::Vec3::Zero();
  if (e >= 0) mine = ranks_->local().finest().displacement_at(step_->u_local(), e, barycentric);
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  MPI_Allreduce(mine.data(), all.data(), 3, MPI_DOUBLE, MPI_SUM, comm_);
  return all;
}

DistributedEuler::Located DistributedEuler::locate(const fem::Vec3& point) const {
  Located mine;
  std::string error;
  try {
    std::tie(mine.element, mine.barycentric) = ranks_->local().finest().locate(point);
    mine.rank = ranks_->rank();
  } catch (const Error&) {  // not among this rank's elements
  } catch (const std::exception& e) {
    error = e.what();
  }
  agree_on(comm_, error, "locate");
  int holder = mine.rank >= 0 ? mine.rank : ranks_->size();
  Located out;
  {
    std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
    MPI_Allreduce(&holder, &out.rank, 1, MPI_INT, MPI_MIN, comm_);
  }
  if (out.rank == ranks_->size()) {
    std::ostringstream where;
    where << "the point (" << point.transpose() << ") lies outside the mesh (no rank's elements hold it)";
    throw InputError(where.str());
  }
  if (out.rank == ranks_->rank()) out.element = mine.element, out.barycentric = mine.barycentric;
  return out;
}

fem::Vec3 DistributedEuler::displacement_at(const Located& point) const {
  if (point.rank < 0 || point.rank >= ranks_->size()) throw InputError("distributed time step: a point not located");
  fem::Vec3 d = fem::Vec3::Zero();
  std::string error;  // the holder's failure (a point located by another object) is every rank's
  try {
    if (point.rank == ranks_->rank())
      d = ranks_->local().finest().displacement_at(step_->u_local(), point.element, point.barycentric);
  } catch (const std::exception& e) {
    error = e.what();
  }
  agree_on(comm_, error, "displacement_at");
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  MPI_Bcast(d.data(), 3, MPI_DOUBLE, point.rank, comm_);
  return d;
}

Vector DistributedEuler::gather_displacement() const {
  if (!serial_) throw InputError("distributed time step: gather_displacement gathers a serial vector, and this one runs on a distributed mesh");
  const int top = ranks_->num_levels() - 1;
  return serial_->finest().expand(ranks_->gather(top, step_->u_owned()), Vector());
}

std::string DistributedEuler::write_frame(const std::string& directory, const std::string& stem) const {
  const int rank = ranks_->rank();
  std::string error;
  try {
    fem::write_vtu(directory + "/" + stem + "_" + std::to_string(rank) + ".vtu", ranks_->local().finest().space(),
                   step_->u_local());
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
