// A small cubic cantilever with its degree hierarchy and a Chebyshev PMG, shared by the GPU tests
// (host emulation and device).
#pragma once

#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/multigrid/cycle.hpp"
#include "pmg/multigrid/factory.hpp"

#include <memory>
#include <vector>

namespace pmg::test {

struct GpuCantilever {
  fem::TetMesh mesh;
  fem::DegreeHierarchy h;
  std::unique_ptr<Solver> pmg;  ///< a MultigridCycle with Chebyshev smoothing, set up (degree >= 2)
  Vector b;
  explicit GpuCantilever(int degree = 3, index_t k = 2)
      : mesh(fem::box_mesh_24(4 * k, k, k, 1.0, 0.25, 0.25)),
        h(mesh, degree, fem::Material{500e3, 0.3, 1000.0}, [](const fem::Vec3& X) { return X.x() < 1e-12; }) {
    h.assemble(nullptr);
    if (h.num_levels() >= 2) {  // a linear cantilever has no hierarchy, only its matrix
      SolverContext ctx;
      ctx.levels = &h;
      mg::register_solvers();
      pmg = make_solver(Config::from_pairs({"method=pmg", "smoother=chebyshev", "operator=assembled"}, "test"), ctx);  // as the GPU cycle
      pmg->setup(h.matrix(h.num_levels() - 1));
    }
    Vector f = Vector::Zero(h.finest().num_dofs());
    h.finest().add_traction(f, [](const fem::Vec3& X) { return X.x() > 1 - 1e-12; }, fem::Vec3(0, 0, -250.0));
    b = h.finest().restrict_to_free(f);
  }
  const Bcsr& A() const { return h.matrix(h.num_levels() - 1); }
  mg::MultigridCycle& cycle() const { return dynamic_cast<mg::MultigridCycle&>(*pmg); }
  std::vector<const Bcsr*> matrices() const {
    std::vector<const Bcsr*> m;
    for (int l = 0; l < h.num_levels(); ++l) m.push_back(&h.matrix(l));
    return m;
  }
  std::vector<const mg::BlockTransfer*> transfers() const {
    std::vector<const mg::BlockTransfer*> t;
    for (int l = 1; l < h.num_levels(); ++l) t.push_back(&cycle().transfer(l));
    return t;
  }
};

}  // namespace pmg::test
