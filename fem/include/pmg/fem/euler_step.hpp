// pmg/fem/euler_step.hpp — the one implicit-Euler step of pmg/fem/simulation.hpp, written once for
// one process (fem::ImplicitEuler) and for a rank's share of a model across MPI ranks
// (dist::DistributedEuler). A step reads and writes two kinds of vectors:
//
//   local: over the part's own hierarchy — the displacement u as a full vector of its finest space,
//          the velocity and every element sum (forces, M v) over its free nodes;
//   owned: the unknowns this part solves for, in the step solver's order.
//
// A StepPart says how the two meet: on one process they are the same vector and every reduction
// is the value itself; across ranks `add_to_owners` sums each rank's element contributions into
// the node's owner, `to_local` gives every rank its ghosts' values, `sum` is an MPI_Allreduce and
// `together` makes a rank's own failure every rank's. The step equation, the warm start, the
// failure messages and the energies are EulerStep's alone, so a fix lands once.
#pragma once

#include "pmg/fem/bound_system.hpp"
#include "pmg/fem/simulation.hpp"

#include <array>
#include <functional>
#include <string>

namespace pmg::fem {

/// Where an implicit-Euler step's vectors live (see the file comment).
class StepPart {
 public:
  virtual ~StepPart() = default;
  /// The part's finest model (its rotations, its free nodes).
  virtual const ElasticityModel& finest() const = 0;
  /// The part's hierarchy bound to the step solver: what a step prepares, and its mass.
  virtual BoundSystem& system() const = 0;
  /// owned = Σ over the parts of `local` (a vector over the part's free nodes), each value summed
  /// into its owner.
  virtual void add_to_owners(const Vector& local, Vector& owned) const = 0;
  /// local = the owners' values of the part's free nodes.
  virtual void to_local(const Vector& owned, Vector& local) const = 0;
  /// Σ over the parts of `mine`.
  virtual double sum(double mine) const = 0;
  /// Runs f, the part's own work; a failure on any part is thrown on every part, its type kept
  /// (one process: f's exception as it is).
  virtual void together(const std::function<void()>& f) const = 0;
  /// Throws pmg::Error "what: error" on every part when `error` is not empty on any.
  virtual void agree(const std::string& error, const std::string& what) const = 0;
  /// ‖b − A v‖ over every part's owned unknowns, A the step matrix the solver was set up on.
  virtual double residual_norm(const Vector& b, const Vector& v) const = 0;
  /// Solves A v = b on the owned unknowns from the guess v. Throws SolveError when the solve fails
  /// and the solver throws on failure.
  virtual SolveResult solve(const Vector& b, Vector& v) = 0;
  /// The step solver's name, for messages.
  virtual std::string solver_name() const = 0;
};

/// The implicit-Euler step of pmg/fem/simulation.hpp on a StepPart (see the file comment). Holds a
/// reference to the part, which must outlive it.
class EulerStep {
 public:
  /// f_ext_owned: the constant external force on the owned unknowns. The state starts at rest.
  EulerStep(StepPart& part, const SimulationParams& p, Vector f_ext_owned);
  /// The state: u a full vector of the part's finest space, v over its free nodes, and both on
  /// the owned unknowns (the caller keeps them consistent).
  void set_state(Vector u_local, Vector v_local, Vector u_owned, Vector v_owned);
  /// The state from owned vectors: the local ones from their owners.
  void set_state_owned(Vector u_owned, Vector v_owned);
  /// One step (simulation.hpp's equation). Throws SolveError naming the step when the solve fails
  /// and pmg::Error when the velocity turns non-finite (on every part).
  StepStats step();
  /// ½ vᵀ M v over every part.
  double kinetic_energy() const;
  /// The elastic energy of the state over every part, from the pass the next step reuses.
  double elastic_energy() const;
  /// f_extᵀ u over every part.
  double external_work() const;
  double time() const { return t_; }  ///< simulated time in seconds
  int steps() const { return step_; }  ///< steps done
  const Vector& u_local() const { return u_local_; }  ///< the part's full displacement
  const Vector& v_local() const { return v_local_; }  ///< the part's free-node velocity
  const Vector& u_owned() const { return u_owned_; }  ///< the owned displacement
  const Vector& v_owned() const { return v_owned_; }  ///< the owned velocity
  /// The levels below the finest no longer carry the step's weights (their caller used them for
  /// something else, a static solve): the next step prepares them.
  void levels_changed() { levels_current_ = false; }

 private:
  void evaluate_state() const;
  StepPart& part_;
  SimulationParams p_;
  Vector f_ext_owned_;
  Vector u_local_, v_local_, u_owned_, v_owned_;
  double t_ = 0.0;
  int step_ = 0;
  mutable bool levels_current_ = false;  // linear material: the levels carry the step's weights
  struct StateTerms {
    bool valid = false;
    bool prepare = false;  // the pass brought the finest operator to the step: the levels follow
    Rotations R;
    Vector force_owned;
    double energy = 0.0;
    std::array<double, kNumStages> seconds{};
  };
  mutable StateTerms state_;
};

}  // namespace pmg::fem
