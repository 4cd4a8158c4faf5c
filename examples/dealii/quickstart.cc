// The deal.II user's quick start (docs/quickstart-dealii.md): linear elasticity with FE_Q(2)^3 on a
// clamped 4 x 1 x 1 bar under gravity, assembled the deal.II way (step-8), solved by pmgkit's
// MGPCG on the Q1 and Q2 levels and checked against deal.II's UMFPACK. What pmgkit needs from a
// deal.II program: each level's matrix (boundary values applied by AffineConstraints, so the
// constrained rows are diagonal-only) and the interpolation between the levels, as CSR arrays.
#include <deal.II/base/function.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/timer.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/fe_system.h>
#include <deal.II/fe/fe_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/tria.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/sparse_direct.h>
#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/sparsity_pattern.h>
#include <deal.II/lac/vector.h>
#include <deal.II/numerics/vector_tools.h>

#include <pmg/multigrid/user_levels.hpp>
#include <pmg/solvers.hpp>

#include <cstdint>
#include <iostream>
#include <map>
#include <vector>

using namespace dealii;

namespace {

constexpr double E = 1e5, nu = 0.3, rho = 1e3, g = 9.81;

/// One level: its dofs, boundary values, matrix and right-hand side.
struct Level {
  explicit Level(const Triangulation<3>& tria, unsigned degree) : fe(FE_Q<3>(degree), 3), dof(tria) {
    dof.distribute_dofs(fe);  // FESystem numbers the 3 components of a support point together
    VectorTools::interpolate_boundary_values(dof, 0, Functions::ZeroFunction<3>(3), constraints);  // x = 0
    constraints.close();
    DynamicSparsityPattern dsp(dof.n_dofs());
    DoFTools::make_sparsity_pattern(dof, dsp, constraints, true);
    sparsity.copy_from(dsp);
    A.reinit(sparsity);
    b.reinit(dof.n_dofs());
    assemble();
  }

  void assemble() {
    const double lambda = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
    const QGauss<3> quadrature(fe.degree + 1);
    FEValues<3> fv(fe, quadrature, update_values | update_gradients | update_JxW_values);
    const unsigned n = fe.n_dofs_per_cell();
    FullMatrix<double> Ke(n, n);
    Vector<double> fe_b(n);
    std::vector<types::global_dof_index> ids(n);
    for (const auto& cell : dof.active_cell_iterators()) {
      fv.reinit(cell);
      Ke = 0;
      fe_b = 0;
      for (unsigned q = 0; q < quadrature.size(); ++q)
        for (unsigned i = 0; i < n; ++i) {
          const unsigned ci = fe.system_to_component_index(i).first;
          for (unsigned j = 0; j < n; ++j) {
            const unsigned cj = fe.system_to_component_index(j).first;
            Ke(i, j) += (fv.shape_grad(i, q)[ci] * fv.shape_grad(j, q)[cj] * lambda +
                         fv.shape_grad(i, q)[cj] * fv.shape_grad(j, q)[ci] * mu +
                         (ci == cj ? fv.shape_grad(i, q) * fv.shape_grad(j, q) * mu : 0.0)) * fv.JxW(q);
          }
          if (ci == 2) fe_b(i) -= rho * g * fv.shape_value(i, q) * fv.JxW(q);
        }
      cell->get_dof_indices(ids);
      constraints.distribute_local_to_global(Ke, fe_b, ids, A, b);
    }
  }

  FESystem<3> fe;
  DoFHandler<3> dof;
  AffineConstraints<double> constraints;
  SparsityPattern sparsity;
  SparseMatrix<double> A;
  Vector<double> b;
};

/// CSR arrays of a deal.II matrix, each row in deal.II's order (diagonal first): pmgkit reads rows
/// in any order, so nothing is sorted.
struct CsrArrays {
  std::vector<std::int64_t> row_ptr{0};
  std::vector<std::int32_t> col_idx;
  std::vector<double> values;
  unsigned rows = 0, cols = 0;

  pmg::CsrView view() const {
    pmg::CsrView v;
    v.rows = rows, v.cols = cols, v.nnz = static_cast<pmg::offset_t>(values.size());
    v.row_ptr = row_ptr.data(), v.row_ptr_bytes = 8;
    v.col_idx = col_idx.data(), v.col_idx_bytes = 4;
    v.values = values.data();
    return v;
  }
};

CsrArrays arrays_of(const SparseMatrix<double>& A) {
  CsrArrays c;
  c.rows = A.m(), c.cols = A.n();
  for (unsigned row = 0; row < A.m(); ++row) {
    for (auto it = A.begin(row); it != A.end(row); ++it) {
      c.col_idx.push_back(static_cast<std::int32_t>(it->column()));
      c.values.push_back(it->value());
    }
    c.row_ptr.push_back(static_cast<std::int64_t>(c.values.size()));
  }
  return c;
}

/// The interpolation from the coarse level's space to the fine one's (fine dofs x coarse dofs),
/// from FETools::get_interpolation_matrix on each cell: a shared dof gets the same row from
/// every cell, so rows are set, not summed.
CsrArrays interpolation(const Level& coarse, const Level& fine) {
  FullMatrix<double> M(fine.fe.n_dofs_per_cell(), coarse.fe.n_dofs_per_cell());
  FETools::get_interpolation_matrix(coarse.fe, fine.fe, M);
  std::vector<std::map<unsigned, double>> rows(fine.dof.n_dofs());
  std::vector<types::global_dof_index> ic(coarse.fe.n_dofs_per_cell()), jf(fine.fe.n_dofs_per_cell());
  auto c = coarse.dof.begin_active();
  for (auto f = fine.dof.begin_active(); f != fine.dof.end(); ++f, ++c) {
    c->get_dof_indices(ic);
    f->get_dof_indices(jf);
    for (unsigned i = 0; i < jf.size(); ++i)
      for (unsigned j = 0; j < ic.size(); ++j)
        if (std::abs(M(i, j)) > 1e-14) rows[jf[i]][ic[j]] = M(i, j);
  }
  CsrArrays P;
  P.rows = fine.dof.n_dofs(), P.cols = coarse.dof.n_dofs();
  for (const auto& r : rows) {
    for (const auto& [col, value] : r) P.col_idx.push_back(static_cast<std::int32_t>(col)), P.values.push_back(value);
    P.row_ptr.push_back(static_cast<std::int64_t>(P.values.size()));
  }
  return P;
}

}  // namespace

int main() try {
  Triangulation<3> tria;
  GridGenerator::subdivided_hyper_rectangle(tria, {16, 4, 4}, Point<3>(0, 0, 0), Point<3>(4, 1, 1), true);
  Timer timer;
  const Level q1(tria, 1), q2(tria, 2);
  std::cout << "deal.II " << DEAL_II_PACKAGE_VERSION << ": Q1 " << q1.dof.n_dofs() << " and Q2 " << q2.dof.n_dofs()
            << " unknowns, assembled in " << timer.wall_time() << " s\n";

  // pmgkit: the levels (coarsest first) and the prolongation, read from the arrays in place.
  timer.restart();
  const CsrArrays A1 = arrays_of(q1.A), A2 = arrays_of(q2.A), P = interpolation(q1, q2);
  std::cout << "CSR arrays and the Q1 -> Q2 interpolation: " << timer.wall_time() << " s\n";
  pmg::register_all_solvers();
  timer.restart();
  pmg::mg::UserLevels levels({A1.view(), A2.view()}, {P.view()}, {});
  pmg::SolverContext context;
  context.levels = &levels;
  auto solver = pmg::make_solver(pmg::Config::from_pairs({"method=mgpcg", "tol=1e-10"}, "quickstart"), context);
  solver->setup(levels.matrix(levels.num_levels() - 1));
  const unsigned n = q2.dof.n_dofs();
  pmg::Vector rb(levels.reduced_size()), rx = pmg::Vector::Zero(levels.reduced_size());
  levels.reduce(Eigen::Map<const pmg::Vector>(q2.b.begin(), n), rb);  // the clamped dofs left out
  const pmg::SolveResult r = solver->solve(rb, rx);
  Vector<double> x(n);
  levels.expand(rx, Eigen::Map<const pmg::Vector>(q2.b.begin(), n), Eigen::Map<pmg::Vector>(x.begin(), n));
  const double t_pmg = timer.wall_time();

  timer.restart();
  SparseDirectUMFPACK umfpack;
  umfpack.initialize(q2.A);
  Vector<double> x_ref(q2.b);
  umfpack.solve(x_ref);
  const double t_umfpack = timer.wall_time();

  Vector<double> diff(x);
  diff -= x_ref;
  const double error = diff.l2_norm() / x_ref.l2_norm();
  std::cout << "pmgkit mgpcg on the Q1/Q2 levels: " << pmg::to_string(r.status) << " in " << r.iterations
            << " iterations, " << t_pmg << " s (set-up included)\n"
            << "deal.II's UMFPACK: " << t_umfpack << " s; relative difference " << error << "\n";
  return r.ok() && error < 1e-8 ? 0 : 1;
} catch (const std::exception& e) {  // pmg::InputError / SolveError, or deal.II's exceptions
  std::cerr << "quickstart: " << e.what() << "\n";
  return 2;
}
