// pmg/fem/bound_system.hpp — the one seam between an FEM degree hierarchy and a solver.
//
// A solver says once what it reads of the system's owner (Solver::needs(): the levels below the
// finest, matrix-free operators, its lowest level); a BoundSystem, made by DegreeHierarchy::bind,
// is the only code that reads that record. Every FEM caller of a solver (a time step, a static
// solve, pmg compare, scenes, Python) goes through it with the same three calls and never asks
// what the solver is:
//
//   evaluate(u, R, w)   the finest level at state u: its operator (the assembled matrix, or the
//                       matrix-free operator where the solver multiplies with that) brought to the
//                       rotations R and the weights w = (m, s) of  m M + s K_R, in the same pass over
//                       the elements that gives the elastic force f_el(u) and energy;
//   refresh(R, w)       the levels that the solver reads, down to its lowest, brought to the
//                       same R and w (with `finest` false, those below the finest: evaluate()
//                       brought that one), then the solver set up, or updated where it is set up
//                       on that operator already: whatever the solver needs, nothing more;
//   system(), mass()    the finest operator the solver is set up on and multiplies with, and the
//                       finest consistent mass (an operator with weights (1, 0) on the matrix-free
//                       route, so that no finest matrix is ever held there).
//
// Holds references to the hierarchy and the solver, which must outlive it.
#pragma once

#include "pmg/fem/hierarchy.hpp"
#include "pmg/sparse/solver.hpp"

#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace pmg::fem {

/// The weights of a level's system  mass M + stiffness K_R  (a static solve: (0, 1); an
/// implicit-Euler step: (1 + Δt α, Δt β + Δt²)).
struct SystemWeights {
  double mass = 0.0;       ///< m, the weight of the consistent mass M
  double stiffness = 1.0;  ///< s, the weight of the stiffness K_R
};

/// Seconds spent by one BoundSystem::evaluate(): bringing the finest operator to the state, and
/// the force and energy (0 where they came from the same pass as the operator).
struct EvaluateSeconds {
  double finest = 0.0;  ///< the finest operator brought to the state (with the force, when assembled)
  double force = 0.0;   ///< force and energy on their own (matrix-free, or no operator update)
};

/// Seconds spent by one BoundSystem::refresh(): the levels the solver reads, and its set-up or
/// update.
struct RefreshSeconds {
  double prepare = 0.0;  ///< the levels the solver reads
  double setup = 0.0;    ///< the solver's set-up or update
};

/// A degree hierarchy bound to a solver (see the file comment). Movable, not copyable.
class BoundSystem {
 public:
  /// Asks the solver once what it reads of h (Solver::needs()).
  BoundSystem(DegreeHierarchy& h, Solver& solver);
  BoundSystem(BoundSystem&&) noexcept;             ///< moves the binding (the references stay)
  BoundSystem& operator=(BoundSystem&&) noexcept;  ///< moves the binding (the references stay)
  ~BoundSystem();

  /// The finest level at displacement u (full vector): with `update` its operator is brought to
  /// rotations R (nullptr: none) and weights w in the pass that gives the elastic force f_el(u)
  /// (full vector) and the strain energy; without it (a linear material whose finest operator is
  /// current) only force and energy are computed. force and energy may be nullptr.
  EvaluateSeconds evaluate(const Vector& u, const Rotations* R, SystemWeights w, Vector* force, double* energy,
                           bool update = true);
  /// Brings the levels the solver reads to R and w — the finest too unless `finest` is false (a
  /// caller whose evaluate() brought it there) — then set_up_solver(). Set-up errors propagate
  /// as the solver throws them.
  RefreshSeconds refresh(const Rotations* R, SystemWeights w, bool finest = true);
  /// The solver set up on system(), or updated where it is set up on that very operator already
  /// (same pattern, new values: numeric set-up only). Returns the seconds it took.
  double set_up_solver();
  /// refresh()'s preparation alone, without touching the solver (a study that times the set-up
  /// itself, or a caller that sets the solver up on its own). Returns system().
  const LinearOperator& prepare(const Rotations* R = nullptr, SystemWeights w = {}, bool finest = true);

  /// The finest operator the solver is set up on and multiplies with: the matrix-free operator
  /// where the solver uses those, the finest matrix otherwise.
  const LinearOperator& system() const;
  /// The finest consistent mass over the free nodes (matrix or, on the matrix-free route, an
  /// operator built on first use and kept by this object).
  const LinearOperator& mass() const;
  /// True on the matrix-free route: system() is an operator, not an assembled matrix, and the
  /// finest level's matrix is never read (nor assembled).
  bool matrix_free() const;
  /// Equal for two bindings of the same hierarchy that prepare the same levels the same way, empty
  /// when there is nothing to prepare beyond the finest matrix (a study prepares once per key).
  std::string preparation_key() const;
  /// What the binding prepares, in words, for reports (one sentence each; empty: nothing to say).
  std::vector<std::string> notes() const;
  /// Where the last prepare() or refresh() spent its time: ("matrix-free degree 2", s) or
  /// ("assembly degree 1", s) per level it touched, finest first.
  const std::vector<std::pair<std::string, double>>& prepare_seconds() const;

  DegreeHierarchy& hierarchy() const { return *h_; }  ///< the bound hierarchy
  Solver& solver() const { return *solver_; }         ///< the bound solver

 private:
  DegreeHierarchy* h_;
  Solver* solver_;
  SolverNeeds needs_;
  mutable std::unique_ptr<ElasticityOperator> mass_op_;
  std::vector<std::pair<std::string, double>> prepare_seconds_;
};

}  // namespace pmg::fem
