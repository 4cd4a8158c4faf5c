// pmg/fem/pmg_cycle.hpp — header-only glue from a DegreeHierarchy to a pmg::multigrid cycle (link
// pmg::multigrid to use it; pmg::fem itself does not depend on it).
#pragma once

#include "pmg/fem/hierarchy.hpp"
#include "pmg/fem/simulation.hpp"
#include "pmg/multigrid/boomeramg.hpp"
#include "pmg/multigrid/cycle.hpp"

#include <memory>
#include <vector>

namespace pmg::fem {

enum class CoarseOperator {
  geometric,  ///< the hierarchy's re-discretised matrices (same rotations on every level)
  galerkin,   ///< R A P from the finest matrix down (two sparse products per level)
};

struct PmgOptions {
  CoarseOperator coarse_operator = CoarseOperator::geometric;
  bool interpolating_restriction = false;  ///< the seed's R instead of Pᵀ (not symmetric)
  bool chebyshev = false;                  ///< Chebyshev instead of block Gauss–Seidel
  mg::GaussSeidelParams smoother;
  mg::ChebyshevParams chebyshev_params;
  mg::CycleParams cycle;
  /// What solves the linear level. boomeramg_pcg makes the cycle nonlinear: stationary PMG only,
  /// not a preconditioner for MGPCG.
  mg::LowestLevel lowest_level = mg::LowestLevel::cholmod;
  mg::BoomerAMGParams boomeramg;   ///< boomeramg, boomeramg_pcg: the AMG set-up, V-cycles per apply
  double lowest_level_tol = 0.1;  ///< boomeramg_pcg: relative tolerance of the linear-level CG
};

/// Owns what a cycle over a DegreeHierarchy needs: transfers, Galerkin matrices if asked for.
struct PmgSolver {
  std::vector<std::unique_ptr<mg::BlockTransfer>> transfers;
  std::vector<Bcsr> galerkin;  ///< levels 0..L-2 when coarse_operator == galerkin
  std::unique_ptr<mg::MultigridCycle> cycle;
  PmgOptions options;

  /// Recomputes the Galerkin products (if used) and refreshes smoothers and the factorisation,
  /// after the hierarchy's matrices were re-assembled.
  void update(const DegreeHierarchy& h) {
    if (options.coarse_operator == CoarseOperator::galerkin)
      for (int l = h.num_levels() - 2; l >= 0; --l) {
        Bcsr product = mg::galerkin_product(*transfers[l], level_matrix(h, l + 1));
        if (product.values().size() != galerkin[l].values().size())
          throw Error("Galerkin update: the product's pattern changed");
        galerkin[l].values() = std::move(product.values());
      }
    cycle->update();
  }
  const Bcsr& level_matrix(const DegreeHierarchy& h, int l) const {
    return (options.coarse_operator == CoarseOperator::galerkin && l < h.num_levels() - 1)
               ? galerkin[l]
               : h.matrix(l);
  }
};

/// Builds the cycle for the hierarchy's current matrices (assemble() them first).
inline std::unique_ptr<PmgSolver> make_pmg(const DegreeHierarchy& h, const PmgOptions& options = {}) {
  auto s = std::make_unique<PmgSolver>();
  s->options = options;
  const int L = h.num_levels();
  for (int l = 1; l < L; ++l)
    s->transfers.push_back(options.interpolating_restriction
                               ? std::make_unique<mg::BlockTransfer>(h.prolongation(l),
                                                                     h.interpolating_restriction(l))
                               : std::make_unique<mg::BlockTransfer>(h.prolongation(l)));
  if (options.coarse_operator == CoarseOperator::galerkin) {
    s->galerkin.resize(L > 0 ? L - 1 : 0);
    for (int l = L - 2; l >= 0; --l)
      s->galerkin[l] = mg::galerkin_product(*s->transfers[l], s->level_matrix(h, l + 1));
  }
  std::vector<const Bcsr*> matrices;
  std::vector<const mg::BlockTransfer*> transfers;
  std::vector<std::unique_ptr<mg::Smoother>> smoothers;
  for (int l = 0; l < L; ++l) {
    matrices.push_back(&s->level_matrix(h, l));
    if (l > 0) {
      transfers.push_back(s->transfers[l - 1].get());
      if (options.chebyshev)
        smoothers.push_back(std::make_unique<mg::Chebyshev>(*matrices.back(), options.chebyshev_params));
      else
        smoothers.push_back(std::make_unique<mg::BlockGaussSeidel>(*matrices.back(), options.smoother));
    }
  }
  s->cycle = std::make_unique<mg::MultigridCycle>(matrices, transfers, std::move(smoothers),
                                                  mg::make_lowest_level(*matrices[0], options.lowest_level,
                                                                        options.boomeramg, options.lowest_level_tol),
                                                  options.cycle);
  return s;
}

/// PMG (one cycle per iteration) or MGPCG as the step solver of ImplicitEuler: the cycle is
/// built on the first update and refreshed (smoothers, Cholesky refactorisation) on later ones.
class PmgStepSolver final : public StepSolver {
 public:
  PmgStepSolver(const PmgOptions& options, const KrylovParams& params, bool mgpcg = false,
                int cycles_per_apply = 2)
      : options_(options), params_(params), mgpcg_(mgpcg), cycles_(cycles_per_apply) {}
  std::string name() const override { return mgpcg_ ? "mgpcg" : "pmg"; }
  bool needs_lower_levels() const override { return true; }
  void update(DegreeHierarchy& h) override {
    if (!pmg_) pmg_ = make_pmg(h, options_);
    else pmg_->update(h);
  }
  SolveResult solve(const Bcsr& A, const Vector& b, Vector& x) override {
    const KrylovParams p = with_rounding_floor(params_, b);
    return mgpcg_ ? mg::mgpcg(A, *pmg_->cycle, b, x, p, nullptr, cycles_)
                  : mg::multigrid_solve(A, *pmg_->cycle, b, x, p);
  }
  const mg::MultigridCycle* cycle() const { return pmg_ ? pmg_->cycle.get() : nullptr; }

 private:
  PmgOptions options_;
  KrylovParams params_;
  bool mgpcg_;
  int cycles_;
  std::unique_ptr<PmgSolver> pmg_;
};

}  // namespace pmg::fem
