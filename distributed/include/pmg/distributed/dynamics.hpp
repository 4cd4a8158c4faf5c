// pmg/distributed/dynamics.hpp — the implicit-Euler time step of pmg/fem/simulation.hpp across MPI
// ranks: each rank computes the rotations, elastic forces and energy of its own elements only,
// keeps the velocity and displacement of its owned nodes, and solves the step system with the
// p-multigrid on PETSc (pmg/petsc/pcmg.hpp). The step is fem::EulerStep's (pmg/fem/euler_step.hpp),
// the very code of fem::ImplicitEuler, on a StepPart whose exchanges, sums and solve span the ranks:
//
//   (m M + s K_R) v⁺ = M v + Δt (f_ext + f_el(x)),   x⁺ = x + Δt v⁺,   f_el = Σ_ranks Gᵀ f_el,rank,
//
// where G gathers a rank's local nodes (owned and ghost) from their owners (a PETSc scatter,
// petsc::GhostExchange) and Gᵀ adds the rank's element contributions back into the owners. Per
// step: one gather of the velocity (which also advances the rank's copy of the state on its ghost
// nodes), one reverse add of the force and one of M v, one operator product for the warm-start
// test, the solve's own exchanges, and a few reductions (energies, norms, the probe). A failure in
// a rank's own work (its rotations, operators, lowest-level assembly) is agreed on before the next
// collective call, so every rank throws it.
//
// Sums over elements are sums over ranks of sums over the rank's elements, so the energies are
// reductions of per-rank sums: ½ vᵀ M v = Σ_ranks ½ (G v)ᵀ M_rank (G v), the elastic energy the same.
// A probe point belongs to the rank holding its element. Frames are ParaView's parallel
// convention: one .vtu piece per rank (its elements, its local state) and one .pvtu naming them.
//
// Two set-ups. Replicated: every rank holds the serial hierarchy, from which RankHierarchy takes its
// share, and gives the initial state as serial vectors. On a distributed mesh (MeshProblem,
// pmg/distributed/mesh_problem.hpp): the rank's share was built from its own cells, the external
// force comes as owned unknowns, and the initial state from the rank's own nodes (set_state_local)
// or as the static equilibrium under a load (set_static_state: fem::corotational_fixed_point,
// the serial static solve's loop, on the rank's part, its norms reduced over the ranks); a probe is a point located once
// (locate). From the first step on, each rank touches only its own elements and nodes. Every
// member function is collective over the communicator.
#pragma once

#include "pmg/distributed/mgpcg.hpp"
#include "pmg/distributed/rank_hierarchy.hpp"
#include "pmg/fem/euler_step.hpp"
#include "pmg/fem/simulation.hpp"
#include "pmg/fem/static_solve.hpp"

#include <array>
#include <memory>
#include <string>

namespace pmg::petsc {
class GhostExchange;
class PMultigridCg;
}  // namespace pmg::petsc

namespace pmg::dist {

/// Implicit Euler for (corotational) elasticity across MPI ranks (see the file comment). The
/// communicator must outlive the object.
class DistributedEuler {
 public:
  /// Partitions `serial` over comm's ranks (RankHierarchy) and checks the parameters as
  /// fem::ImplicitEuler does. f_ext: the serial full external force (constant in time). `serial`
  /// must outlive the object. Throws InputError for parameters ImplicitEuler refuses.
  DistributedEuler(const fem::DegreeHierarchy& serial, const Vector& f_ext, const fem::SimulationParams& p,
                   DistributedMgpcgParams solver = {}, MPI_Comm comm = MPI_COMM_WORLD);
  /// On a rank's share of a distributed mesh (RankHierarchy's mesh constructor; it must outlive
  /// the object), over its communicator. f_ext_owned: the external force on the finest level's
  /// owned unknowns (MeshProblem::load()). The state starts at rest. Throws InputError (on every
  /// rank) for parameters ImplicitEuler refuses or a force of the wrong size.
  DistributedEuler(RankHierarchy& ranks, const Vector& f_ext_owned, const fem::SimulationParams& p,
                   DistributedMgpcgParams solver = {});
  ~DistributedEuler();
  DistributedEuler(const DistributedEuler&) = delete;
  DistributedEuler& operator=(const DistributedEuler&) = delete;

  /// The state from serial full vectors (every rank gives the same; clamped nodes at rest). The
  /// replicated set-up only.
  void set_state(const Vector& u, const Vector& v);
  /// The state from each rank's full vectors of its own finest level (3 per node of its sub-mesh
  /// space, as fem::ElasticityModel::interpolate() gives them); a node shared by ranks takes its
  /// owner's value, clamped nodes are set at rest. Throws InputError on every rank for a vector of
  /// the wrong size or not finite.
  void set_state_local(const Vector& u, const Vector& v);
  /// The state of static equilibrium under the force f_owned (owned unknowns), at rest: the fixed
  /// point of pmg/fem/static_solve.hpp (corotational as the time step's material; linear: one
  /// solve), each solve by a PETSc solver of the step solver's keys but tolerance `solve_tol`, on
  /// the stiffness alone. Returns the fixed-point iterations (`solver_iterations`, where given,
  /// gets the solves' iterations summed). Throws SolveError or pmg::Error (every rank) when a
  /// solve or the fixed point fails.
  int set_static_state(const Vector& f_owned, const fem::StaticOptions& options = {}, double solve_tol = 1e-10,
                       int* solver_iterations = nullptr);
  /// One step (see the file comment). Throws SolveError naming the step when the solve fails and
  /// pmg::Error when the velocity turns non-finite on any rank (every rank throws).
  fem::StepStats step();
  /// Simulated time in seconds.
  double time() const;
  /// Steps done.
  int steps() const;
  /// ½ vᵀ M v over every rank.
  double kinetic_energy() const;
  /// The elastic energy of the state over every rank (from the pass the next step reuses).
  double elastic_energy() const;
  /// f_extᵀ u over every rank.
  double external_work() const;
  /// The displacement at a point of a serial element given by barycentric coordinates; every rank
  /// gets it.
  fem::Vec3 displacement_at(index_t serial_element, const Eigen::Vector4d& barycentric) const;
  /// A point of the rank-distributed mesh: the lowest rank whose elements hold it, its element
  /// there and barycentric coordinates.
  struct Located {
    int rank = -1;        ///< the rank that evaluates the point
    index_t element = -1;  ///< that rank's element
    Eigen::Vector4d barycentric = Eigen::Vector4d::Zero();  ///< in that element
  };
  /// Locates a rest point once (every rank gets the same answer). Throws InputError on every rank,
  /// naming the point, when no rank's elements hold it.
  Located locate(const fem::Vec3& point) const;
  /// The displacement at a located point; every rank gets it.
  fem::Vec3 displacement_at(const Located& point) const;
  /// The displacement on the finest level's owned unknowns (global order).
  const Vector& displacement_owned() const;
  /// The serial full displacement (every rank gets all of it: for checks, not per step). The
  /// replicated set-up only.
  Vector gather_displacement() const;
  /// Writes `directory/stem_<rank>.vtu` on every rank (the rank's elements and state), then on
  /// rank 0 `directory/stem.pvtu` naming the pieces; each file atomically, the .pvtu after every
  /// piece is complete. Returns "stem.pvtu".
  std::string write_frame(const std::string& directory, const std::string& stem) const;
  /// True on every rank when `mine` is true on any (a stop request every rank must follow).
  bool any_rank(bool mine) const;
  /// Throws pmg::Error on every rank when `error` is not empty on any (`what`: this rank's error,
  /// or the lowest failed rank named): a caller's own per-rank work (writing a file) made
  /// collective, so that no rank goes on into a step another has left.
  void agree(const std::string& error, const std::string& what) const;
  /// Collective: throws the same InputError on every rank unless every rank gives the same `value`
  /// of what `name` says (an output directory, say): pmg::mpi::check_agreement.
  void require_same_on_every_rank(const std::string& name, const std::string& value) const;
  /// The rank's share of the hierarchy.
  const RankHierarchy& ranks() const { return *ranks_; }
  /// The PETSc solver (set up at the first step).
  const petsc::PMultigridCg& solver() const { return *solver_; }
  /// A description of the solver after the first step (levels, smoother, ghosts per rank).
  std::string describe() const;

 private:
  class RankPart;
  double sum(double mine) const;
  /// The rank's solver, ghost exchange, binding and step, after ranks_ is set; the state at rest.
  void build(const Vector& f_ext_owned, const DistributedMgpcgParams& solver);
  class StaticRankPart;  // the rank's share of set_static_state's fixed point

  const fem::DegreeHierarchy* serial_ = nullptr;  // the replicated set-up's serial hierarchy
  fem::SimulationParams p_;
  DistributedMgpcgParams params_;  // the step solver's keys
  MPI_Comm comm_;
  std::unique_ptr<RankHierarchy> own_ranks_;  // the replicated set-up's share
  RankHierarchy* ranks_ = nullptr;
  std::unique_ptr<petsc::GhostExchange> ghosts_;
  std::unique_ptr<petsc::PMultigridCg> solver_;
  /// solver_ on the rank's levels as the seam's Solver (set up and refreshed through system_).
  std::unique_ptr<Solver> rank_solver_;
  /// The rank's hierarchy bound to rank_solver_ (fem::BoundSystem): what a step prepares, and the
  /// rank's consistent mass.
  std::unique_ptr<fem::BoundSystem> system_;
  std::unique_ptr<fem::StepPart> part_;  // the rank's exchanges, reductions and solve
  std::unique_ptr<fem::EulerStep> step_;  // the one implicit-Euler step (pmg/fem/euler_step.hpp)
};

}  // namespace pmg::dist
