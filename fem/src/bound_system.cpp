#include "pmg/fem/bound_system.hpp"
#include "pmg/sparse/timer.hpp"

#include <algorithm>
#include <string>

// The only reader of SolverNeeds outside the solvers that answer it (tests/check_seam.py checks).
namespace pmg::fem {

BoundSystem::BoundSystem(DegreeHierarchy& h, Solver& solver) : h_(&h), solver_(&solver), needs_(solver.needs()) {}
BoundSystem::BoundSystem(BoundSystem&&) noexcept = default;
BoundSystem& BoundSystem::operator=(BoundSystem&&) noexcept = default;
BoundSystem::~BoundSystem() = default;

bool BoundSystem::matrix_free() const { return needs_.matrix_free && h_->num_levels() > 1; }

EvaluateSeconds BoundSystem::evaluate(const Vector& u, const Rotations* R, SystemWeights w, Vector* force,
                                      double* energy, bool update) {
  EvaluateSeconds s;
  const int finest = h_->num_levels() - 1;
  auto t0 = Clock::now();
  if (matrix_free()) {
    // The finest level is an operator: its update is the rotation of the stored gradients, and
    // force and energy come from the same operator.
    if (update) {
      h_->update_matrix_free(finest, R, w.mass, w.stiffness);
      s.finest = seconds_since(t0);
    }
    t0 = Clock::now();
    if (force || energy) {
      Vector scratch;
      h_->matrix_free(finest).element_force(u, R, force ? *force : scratch, energy);
      s.force = seconds_since(t0);
    }
  } else if (update) {
    h_->assemble_level(finest, R, w.mass, w.stiffness, u, force, energy);
    s.finest = seconds_since(t0);
  } else {  // the finest matrix is current: force and energy only
    ElasticityModel::ElementPass pass;
    pass.u = &u;
    pass.force = force;
    pass.energy = energy;
    h_->finest().evaluate(pass);
    s.force = seconds_since(t0);
  }
  return s;
}

const LinearOperator& BoundSystem::prepare(const Rotations* R, SystemWeights w, bool finest) {
  const int L = h_->num_levels();
  prepare_seconds_.clear();
  const int lowest = std::clamp(needs_.lowest_level, 0, L - 1);
  for (int l = L - 1; l >= lowest; --l) {
    if (l == L - 1 && !finest) continue;
    if (l < L - 1 && !needs_.lower_levels) break;
    const auto t0 = Clock::now();
    // Matrix-free operators above the solver's lowest level, assembled matrices otherwise.
    const bool operator_only = needs_.matrix_free && l > lowest;
    if (operator_only) h_->update_matrix_free(l, R, w.mass, w.stiffness);
    else h_->assemble_level(l, R, nullptr, w.mass, w.stiffness);
    prepare_seconds_.emplace_back((operator_only ? "matrix-free " : "assembly ") + h_->level_name(l),
                                  seconds_since(t0));
  }
  return system();
}

RefreshSeconds BoundSystem::refresh(const Rotations* R, SystemWeights w, bool finest) {
  RefreshSeconds s;
  auto t0 = Clock::now();
  prepare(R, w, finest);
  s.prepare = seconds_since(t0);
  s.setup = set_up_solver();
  return s;
}

double BoundSystem::set_up_solver() {
  const auto t0 = Clock::now();
  const LinearOperator& A = system();
  if (solver_->is_set_up() && &solver_->system() == &A) solver_->update();
  else solver_->setup(A);
  return seconds_since(t0);
}

const LinearOperator& BoundSystem::system() const {
  const int L = h_->num_levels();
  if (matrix_free()) return h_->matrix_free(L - 1);
  return h_->matrix(L - 1);
}

const LinearOperator& BoundSystem::mass() const {
  if (!matrix_free()) return h_->mass(h_->num_levels() - 1);
  if (!mass_op_) {
    mass_op_ = std::make_unique<ElasticityOperator>(h_->finest());
    mass_op_->set_weights(1.0, 0.0);
  }
  return *mass_op_;
}

std::string BoundSystem::preparation_key() const {
  if (!needs_.lower_levels && !needs_.matrix_free) return "";
  return std::string(needs_.lower_levels ? "lower levels" : "finest level") + (needs_.matrix_free ? ", matrix-free" : "") +
         ", lowest " + std::to_string(std::clamp(needs_.lowest_level, 0, h_->num_levels() - 1));
}

std::vector<std::string> BoundSystem::notes() const {
  std::vector<std::string> notes;
  const int L = h_->num_levels();
  if (matrix_free()) {
    const int lowest = std::clamp(needs_.lowest_level, 0, L - 1);  // its degree is the factorised one
    notes.push_back("matrix-free: degrees >= " + std::to_string(lowest + 2) +
                    " never assembled (their operators take each step's rotations); " +
                    (lowest == 0 ? std::string("the linear level") : h_->level_name(lowest)) +
                    " assembled and its solver set up per step");
  }
  if (!needs_.lower_levels && L > 1)
    notes.push_back("lower degrees: not assembled (" + solver_->name() + " needs only the finest level)");
  return notes;
}

const std::vector<std::pair<std::string, double>>& BoundSystem::prepare_seconds() const { return prepare_seconds_; }

}  // namespace pmg::fem
