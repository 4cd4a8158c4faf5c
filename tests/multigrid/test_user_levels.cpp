// mg::UserLevels: levels as FEM codes hand them over (CSR arrays, either layout, node or dof
// prolongations, Dirichlet identity rows, the finest matrix alone) give the cycle the same levels
// as pmgkit's own hierarchy; components constrained on their own (symmetry planes, rollers) solve
// as a direct solve of the constrained system does; and what cannot work is refused with a
// message saying what to do.
#include "pmg/fem/generators.hpp"
#include "pmg/fem/hierarchy.hpp"
#include "pmg/fem/locator.hpp"
#include "pmg/multigrid/factory.hpp"
#include "pmg/multigrid/user_levels.hpp"
#include "pmg/sparse/layout.hpp"
#include "pmg/sparse/threads.hpp"

#include <catch2/catch.hpp>

#include <limits>
#include <random>
#include <sstream>

using namespace pmg;
using namespace pmg::fem;

namespace {

/// Fixed threads for the scope: comparisons of two solves bit for bit need the same threads in both
/// (the adaptive policy runs each on the cores free when it starts: on a busy machine fewer, and
/// the reductions sum in another order).
struct FixedThreads {
  ThreadPolicy kept = thread_policy();
  FixedThreads() { set_thread_policy(ThreadPolicy::fixed); }
  ~FixedThreads() { set_thread_policy(kept); }
};

struct Levels {
  TetMesh mesh = box_mesh_24(4, 1, 1, 1.0, 0.25, 0.25);
  DegreeHierarchy h{mesh, 3, Material{500e3, 0.3, 1000.0}, [](const Vec3& X) { return X.x() < 1e-12; }};
  std::vector<Csr> A, P;
  Vector b;
  Levels() {
    h.assemble(nullptr);
    for (int l = 0; l < h.num_levels(); ++l) A.push_back(h.matrix(l).to_csr());
    for (int l = 1; l < h.num_levels(); ++l) P.push_back(h.prolongation(l));
    b = Vector::LinSpaced(A.back().rows(), -1.0, 2.0);
  }
};

std::vector<CsrView> views(const std::vector<Csr>& m) {
  std::vector<CsrView> v;
  for (const auto& x : m) v.push_back(view_of(x));
  return v;
}

/// MGPCG's defaults on user levels, spelt out for the hierarchy's assembled route.
const std::string kUserDefaults =
    "operator=assembled smoother=chebyshev smoother.kind=opt-fourth smoother.degree=3 smoother.estimate=lanczos cycles=1";

SolveResult mgpcg(const mg::LevelProvider& levels, const Vector& b, Vector& x, const std::string& extra = "") {
  std::vector<std::string> pairs{"method=mgpcg", "tol=1e-10"};
  std::istringstream words(extra);
  for (std::string w; words >> w;) pairs.push_back(w);
  auto s = make_solver(Config::from_pairs(pairs, "test"), {&levels});
  s->setup(levels.matrix(levels.num_levels() - 1));
  x = Vector::Zero(b.size());
  return s->solve(b, x);
}

/// A permuted copy P_r A P_c^T: out(perm_r[i], perm_c[j]) = A(i, j).
Csr permuted(const Csr& A, const std::vector<index_t>& pr, const std::vector<index_t>& pc) {
  std::vector<Triplet> t;
  const auto& p = A.pattern();
  for (index_t i = 0; i < A.rows(); ++i)
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k) t.emplace_back(pr[i], pc[p.col_idx[k]], A.values()[k]);
  return Csr::from_triplets(A.rows(), A.cols(), t);
}

/// interleaved dof -> component-major dof for n nodes
std::vector<index_t> to_component(index_t n) {
  std::vector<index_t> p(3 * n);
  for (index_t i = 0; i < 3 * n; ++i) p[i] = (i % 3) * n + i / 3;
  return p;
}

Csr kron_identity(const Csr& P) {
  std::vector<Triplet> t;
  const auto& p = P.pattern();
  for (index_t i = 0; i < P.rows(); ++i)
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k)
      for (int c = 0; c < 3; ++c) t.emplace_back(3 * i + c, 3 * p.col_idx[k] + c, P.values()[k]);
  return Csr::from_triplets(3 * P.rows(), 3 * P.cols(), t);
}

}  // namespace

TEST_CASE("user levels reproduce the hierarchy's cycle", "[user-levels]") {
  const FixedThreads fixed;  // the answers are compared bit for bit
  Levels s;
  Vector x_ref, x;
  const SolveResult r_ref = mgpcg(s.h, s.b, x_ref, kUserDefaults);  // as the user levels
  mg::UserLevels u(views(s.A), views(s.P), {});
  REQUIRE(u.num_levels() == 3);
  for (int l = 0; l < 3; ++l) CHECK(u.matrix(l).values() == s.h.matrix(l).values());
  const SolveResult r = mgpcg(u, u.reduce(s.b), x);
  CHECK(r.iterations == r_ref.iterations);
  CHECK((u.expand(x, s.b) - x_ref).norm() == 0.0);

  SECTION("32-bit row pointers and 64-bit columns, read in place") {
    std::vector<std::vector<std::int32_t>> rp;
    std::vector<std::vector<std::int64_t>> ci;
    std::vector<CsrView> v = views(s.A);
    for (auto& w : v) {
      const auto* r64 = static_cast<const std::int64_t*>(w.row_ptr);
      const auto* c32 = static_cast<const std::int32_t*>(w.col_idx);
      rp.emplace_back(r64, r64 + w.rows + 1);
      ci.emplace_back(c32, c32 + w.nnz);
      w.row_ptr = rp.back().data(), w.row_ptr_bytes = 4;
      w.col_idx = ci.back().data(), w.col_idx_bytes = 8;
    }
    mg::UserLevels u32(v, views(s.P), {});
    for (int l = 0; l < 3; ++l) CHECK(u32.matrix(l).values() == s.h.matrix(l).values());
  }
  SECTION("the finest matrix alone: Galerkin products, geometric refused") {
    mg::UserLevels g({view_of(s.A.back())}, views(s.P), {mg::DofLayout::interleaved, true});
    CHECK_FALSE(g.has_matrix(0));
    CHECK(g.has_matrix(2));
    Vector xg;
    const SolveResult rg = mgpcg(g, s.b, xg, "coarse_operator=galerkin");
    CHECK(rg.status == SolveStatus::converged);
    Vector xr;
    mgpcg(s.h, s.b, xr, "coarse_operator=galerkin");
    CHECK((xg - xr).norm() <= 1e-12 * xr.norm());
    CHECK_THROWS_WITH(mgpcg(g, s.b, xg), Catch::Contains("coarse_operator=galerkin"));
  }
  SECTION("new values on the same pattern, and a different pattern refused") {
    std::vector<Csr> twice = s.A;
    for (auto& m : twice)
      for (double& v : m.values()) v *= 2.0;
    u.set_values(views(twice));
    for (int l = 0; l < 3; ++l)
      for (size_t k = 0; k < u.matrix(l).values().size(); k += 97) CHECK(u.matrix(l).values()[k] == 2.0 * s.h.matrix(l).values()[k]);
    // An entry outside the pattern (nodes 0 and the last one do not touch) is refused.
    std::vector<Csr> other = s.A;
    const Csr& a1 = s.A[1];
    std::vector<Triplet> t{Triplet(0, a1.cols() - 1, 1.0), Triplet(a1.rows() - 1, 0, 1.0)};
    for (index_t i = 0; i < a1.rows(); ++i)
      for (offset_t k = a1.pattern().row_ptr[i]; k < a1.pattern().row_ptr[i + 1]; ++k)
        t.emplace_back(i, a1.pattern().col_idx[k], a1.values()[k]);
    other[1] = Csr::from_triplets(a1.rows(), a1.cols(), t);
    CHECK_THROWS_WITH(u.set_values(views(other)), Catch::Contains("outside the pattern"));
    // The same entries in another order are the same pattern.
    std::vector<Csr> reordered = s.A;
    u.set_values(views(reordered));
  }
}

TEST_CASE("component-major levels and dof prolongations", "[user-levels]") {
  Levels s;
  std::vector<Csr> Ac, Pc, Pd;
  std::vector<std::vector<index_t>> perm;
  for (const auto& A : s.A) perm.push_back(to_component(A.rows() / 3));
  for (size_t l = 0; l < s.A.size(); ++l) Ac.push_back(permuted(s.A[l], perm[l], perm[l]));
  for (size_t l = 0; l < s.P.size(); ++l) Pd.push_back(permuted(kron_identity(s.P[l]), perm[l + 1], perm[l]));
  mg::UserLevelOptions o;
  o.layout = mg::DofLayout::component;
  for (const auto* prolongations : {&s.P, &Pd}) {
    mg::UserLevels u(views(Ac), views(*prolongations), o);
    for (int l = 0; l < 3; ++l) CHECK(u.matrix(l).values() == s.h.matrix(l).values());
    for (int l = 1; l < 3; ++l) CHECK(u.prolongation(l).values() == s.P[l - 1].values());
  }
  CHECK_THROWS_WITH(mg::UserLevels(views(Ac), views(s.P), {}), Catch::Contains("layout='component'") && Catch::Contains("--layout component"));
  CHECK_THROWS_WITH(mg::parse_layout("rows"), Catch::Contains("interleaved"));
}

TEST_CASE("Dirichlet identity rows: whole nodes removed, kept columns refused", "[user-levels]") {
  const FixedThreads fixed;  // the answers are compared bit for bit
  Levels s;
  // The finest level with 2 extra clamped nodes in front, as identity rows of diagonal 4; the
  // finest prolongation interpolates into them as well.
  const Csr& A = s.A.back();
  const index_t n = A.rows() / 3, extra = 2;
  std::vector<Triplet> t;
  const auto& p = A.pattern();
  for (index_t i = 0; i < A.rows(); ++i)
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k) t.emplace_back(i + 3 * extra, p.col_idx[k] + 3 * extra, A.values()[k]);
  for (index_t i = 0; i < 3 * extra; ++i) t.emplace_back(i, i, 4.0);
  const Csr F = Csr::from_triplets(3 * (n + extra), 3 * (n + extra), t);
  std::vector<Triplet> tp;
  const Csr& P = s.P.back();
  for (index_t i = 0; i < P.rows(); ++i)
    for (offset_t k = P.pattern().row_ptr[i]; k < P.pattern().row_ptr[i + 1]; ++k)
      tp.emplace_back(i + extra, P.pattern().col_idx[k], P.values()[k]);
  tp.emplace_back(0, 0, 1.0);
  const Csr PF = Csr::from_triplets(n + extra, P.cols(), tp);
  mg::UserLevels u({view_of(s.A[0]), view_of(s.A[1]), view_of(F)}, {view_of(s.P[0]), view_of(PF)}, {});
  CHECK(u.removed_nodes() == std::vector<index_t>{0, 0, extra});
  CHECK(u.matrix(2).values() == s.h.matrix(2).values());
  Vector bF(F.rows());
  bF << Vector::Constant(3 * extra, 8.0), s.b;
  Vector x;
  mgpcg(u, u.reduce(bF), x);
  const Vector xf = u.expand(x, bF);
  CHECK(xf.head(3 * extra).isApprox(Vector::Constant(3 * extra, 2.0)));
  Vector x_ref;
  mgpcg(s.h, s.b, x_ref, kUserDefaults);
  CHECK((xf.tail(3 * n) - x_ref).norm() == 0.0);

  // identity rows whose columns were kept
  std::vector<Triplet> tk = t;
  tk.emplace_back(3 * extra, 0, 1.0);  // a free row coupling to a clamped column
  const Csr kept = Csr::from_triplets(F.rows(), F.cols(), tk);
  CHECK_THROWS_WITH(mg::UserLevels({view_of(s.A[0]), view_of(s.A[1]), view_of(kept)}, {view_of(s.P[0]), view_of(PF)}, {}),
                    Catch::Contains("columns of identity rows must be zero"));
}

TEST_CASE("refused values leave the levels as they were; levels out of range and NaN at identity rows are named",
          "[user-levels]") {
  Levels s;
  mg::UserLevels u(views(s.A), views(s.P), {});
  const std::vector<double> before = u.matrix(2).values();
  // Not symmetric: refused after the values were written, so they must be put back.
  Csr bad = s.A.back();
  bad.values()[5] += 1e5;
  CHECK_THROWS_WITH(u.set_values({view_of(s.A[0]), view_of(s.A[1]), view_of(bad)}), Catch::Contains("not symmetric"));
  CHECK(u.matrix(2).values() == before);
  Vector x;
  CHECK(mgpcg(u, s.b, x).status == SolveStatus::converged);
  Vector r(s.b.size());
  s.h.matrix(2).residual(s.b, x, r);
  CHECK(r.norm() <= 1e-9 * s.b.norm());

  CHECK_THROWS_WITH(u.matrix(3), Catch::Contains("no level 3 (levels 0 to 2)"));
  CHECK_THROWS_WITH(u.prolongation(0), Catch::Contains("no prolongation into level 0"));
  CHECK_THROWS_WITH(s.h.prolongation(3), Catch::Contains("no prolongation into level 3"));

  // A clamped node in front as identity rows: its right-hand side entries never reach the solver.
  const Csr& A = s.A.back();
  std::vector<Triplet> t;
  for (index_t i = 0; i < A.rows(); ++i)
    for (offset_t k = A.pattern().row_ptr[i]; k < A.pattern().row_ptr[i + 1]; ++k)
      t.emplace_back(i + 3, A.pattern().col_idx[k] + 3, A.values()[k]);
  for (index_t i = 0; i < 3; ++i) t.emplace_back(i, i, 1.0);
  const Csr F = Csr::from_triplets(A.rows() + 3, A.cols() + 3, t);
  std::vector<Triplet> tp;
  const Csr& P = s.P.back();
  for (index_t i = 0; i < P.rows(); ++i)
    for (offset_t k = P.pattern().row_ptr[i]; k < P.pattern().row_ptr[i + 1]; ++k)
      tp.emplace_back(i + 1, P.pattern().col_idx[k], P.values()[k]);
  mg::UserLevels c({view_of(s.A[0]), view_of(s.A[1]), view_of(F)},
                   {view_of(s.P[0]), view_of(Csr::from_triplets(P.rows() + 1, P.cols(), tp))}, {});
  Vector bF = Vector::Ones(F.rows());
  bF[1] = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_WITH(c.reduce(bF), Catch::Contains("entry 1 (an identity row"));
}

namespace {

/// A copy of A with the rows and columns of the flagged unknowns zeroed but for the diagonal: the
/// symmetric elimination of a homogeneous constraint on those components.
Csr constrained_copy(const Csr& A, const std::vector<char>& fixed) {
  std::vector<Triplet> t;
  const auto& p = A.pattern();
  for (index_t i = 0; i < A.rows(); ++i)
    for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k) {
      const index_t j = p.col_idx[k];
      if ((fixed[i] || fixed[j]) && i != j) continue;
      t.emplace_back(i, j, A.values()[k]);
    }
  return Csr::from_triplets(A.rows(), A.cols(), t);
}

/// Per unknown of a level of h: 1 where `plane(axis)` holds, for the components in `planes`
/// (axis a constrains component a on the plane X_a = 0).
std::vector<char> on_planes(const DegreeHierarchy& h, int level, const std::vector<int>& axes) {
  const std::vector<double> X = h.node_coordinates(level);
  std::vector<char> fixed(X.size(), 0);
  for (size_t n = 0; n < X.size() / 3; ++n)
    for (int a : axes)
      if (std::abs(X[3 * n + a]) < 1e-12) fixed[3 * n + a] = 1;
  return fixed;
}

}  // namespace

TEST_CASE("symmetry planes and rollers through the multigrid equal a direct solve", "[user-levels][constraints]") {
  // A cantilever clamped at x = 0, with y = 0 a symmetry plane (u_y = 0: a half model), or y = 0
  // and z = 0 both (a quarter model); the load pushes into both planes' normals and along them.
  const TetMesh mesh = box_mesh_24(6, 2, 2, 3.0, 1.0, 1.0);
  DegreeHierarchy h(mesh, 3, Material{500e3, 0.3, 1000.0}, [](const Vec3& X) { return X.x() < 1e-12; });
  h.assemble(nullptr);
  std::vector<Csr> P;
  for (int l = 1; l < h.num_levels(); ++l) P.push_back(h.prolongation(l));
  const Vector g = h.finest().restrict_to_free(h.finest().gravity(Vec3(0.0, -9.81, -9.81)));
  auto solve_count = [&](const mg::LevelProvider& levels, const Vector& b, Vector& x, const std::string& extra) {
    const SolveResult r = mgpcg(levels, b, x, extra);
    REQUIRE(r.ok());
    return r.iterations;
  };
  std::vector<Csr> plain;
  for (int l = 0; l < h.num_levels(); ++l) plain.push_back(h.matrix(l).to_csr());
  Vector x_plain;
  const int clamped_only = solve_count(mg::UserLevels(views(plain), views(P), {}), g, x_plain, "");

  const std::vector<int> axes = GENERATE(std::vector<int>{1}, std::vector<int>{1, 2});
  const bool galerkin = GENERATE(false, true);
  CAPTURE(axes, galerkin);
  std::vector<Csr> A;
  for (int l = 0; l < h.num_levels(); ++l) A.push_back(constrained_copy(plain[l], on_planes(h, l, axes)));
  const std::vector<char> fixed = on_planes(h, h.num_levels() - 1, axes);
  Vector b = g;
  for (Eigen::Index i = 0; i < b.size(); ++i)
    if (fixed[i]) b[i] = 0.0;
  mg::UserLevelOptions o;
  o.galerkin_only = galerkin;
  mg::UserLevels u(galerkin ? std::vector<CsrView>{view_of(A.back())} : views(A), views(P), o);
  REQUIRE(u.constrained_dofs(h.num_levels() - 1));
  CHECK(*u.constrained_dofs(h.num_levels() - 1) == fixed);
  CHECK((galerkin ? u.constrained_dofs(0) == nullptr : u.constrained_dofs(0) != nullptr));
  Vector x;
  const int its = solve_count(u, u.reduce(b), x, galerkin ? "coarse_operator=galerkin" : "");
  const Vector xf = u.expand(x, b);
  // The direct solve of the constrained system.
  auto direct = make_solver(Config::from_pairs({"method=cholmod"}, "test"), {});
  direct->setup(A.back());
  Vector x_ref = Vector::Zero(b.size());
  direct->solve(b, x_ref);
  CHECK((xf - x_ref).norm() <= 1e-8 * x_ref.norm());
  double on_plane = 0.0;
  for (Eigen::Index i = 0; i < xf.size(); ++i)
    if (fixed[i]) on_plane = std::max(on_plane, std::abs(xf[i]));
  CHECK(on_plane == 0.0);
  CHECK((xf - x_plain).norm() > 1e-3 * x_plain.norm());  // the constraint changed the answer
  INFO("iterations: " << its << " constrained, " << clamped_only << " clamped only");
  CHECK(its <= 1.2 * clamped_only);

  // New values on the same patterns (a time step's M + K): update() re-forms the levels (the
  // Galerkin products with their masks) and the answer is again the direct solve's.
  h.assemble(nullptr, nullptr, 1e5, 1.0);
  std::vector<Csr> A2;
  for (int l = 0; l < h.num_levels(); ++l) A2.push_back(constrained_copy(h.matrix(l).to_csr(), on_planes(h, l, axes)));
  u.set_values(galerkin ? std::vector<CsrView>{view_of(A2.back())} : views(A2));
  std::vector<std::string> keys{"method=mgpcg", "tol=1e-10"};
  if (galerkin) keys.push_back("coarse_operator=galerkin");
  auto solver = make_solver(Config::from_pairs(keys, "test"), {&u});
  solver->setup(u.matrix(h.num_levels() - 1));
  u.set_values(galerkin ? std::vector<CsrView>{view_of(A.back())} : views(A));  // back, then forward by update()
  solver->update();
  u.set_values(galerkin ? std::vector<CsrView>{view_of(A2.back())} : views(A2));
  solver->update();
  Vector x2 = Vector::Zero(u.reduced_size());
  REQUIRE(solver->solve(u.reduce(b), x2).ok());
  direct->setup(A2.back());
  Vector x2_ref = Vector::Zero(b.size());
  direct->solve(b, x2_ref);
  const Vector x2f = u.expand(x2, b);
  CHECK((x2f - x2_ref).norm() <= 1e-8 * x2_ref.norm());
  CHECK((x2f - x_ref).norm() > 1e-3 * x_ref.norm());
  on_plane = 0.0;
  for (Eigen::Index i = 0; i < x2f.size(); ++i)
    if (fixed[i]) on_plane = std::max(on_plane, std::abs(x2f[i]));
  CHECK(on_plane == 0.0);

  // The same reduction into the caller's storage: views of plain arrays, nothing allocated.
  std::vector<double> b_raw(b.data(), b.data() + b.size()), x_raw(b.size(), -1.0);
  Vector rb(u.reduced_size());
  u.reduce(Eigen::Map<const Vector>(b_raw.data(), b.size()), rb);
  CHECK(rb == u.reduce(b));
  u.expand(x2, Eigen::Map<const Vector>(b_raw.data(), b.size()), Eigen::Map<Vector>(x_raw.data(), b.size()));
  CHECK(Eigen::Map<const Vector>(x_raw.data(), b.size()) == x2f);
  Vector short_out(u.reduced_size() - 1);
  CHECK_THROWS_WITH(u.reduce(b, short_out), Catch::Contains("reduced_size()"));
  CHECK_THROWS_WITH(u.expand(x2, b, short_out), Catch::Contains("expected"));
}

namespace {

/// A's entries as a FEM code may hand them over: each row's diagonal first, the rest in reverse
/// order, every off-diagonal entry split into two halves (duplicates); 64-bit row pointers.
struct Scrambled {
  std::vector<std::int64_t> row_ptr{0};
  std::vector<std::int32_t> cols;
  std::vector<double> values;
  CsrView view;
  explicit Scrambled(const Csr& A) {
    const auto& p = A.pattern();
    for (index_t i = 0; i < A.rows(); ++i) {
      for (offset_t k = p.row_ptr[i]; k < p.row_ptr[i + 1]; ++k)
        if (p.col_idx[k] == i) cols.push_back(i), values.push_back(A.values()[k]);
      for (offset_t k = p.row_ptr[i + 1] - 1; k >= p.row_ptr[i]; --k)
        if (p.col_idx[k] != i)
          for (int half = 0; half < 2; ++half) cols.push_back(p.col_idx[k]), values.push_back(0.5 * A.values()[k]);
      row_ptr.push_back(static_cast<std::int64_t>(cols.size()));
    }
    view.rows = A.rows(), view.cols = A.cols(), view.nnz = static_cast<offset_t>(cols.size());
    view.row_ptr = row_ptr.data(), view.row_ptr_bytes = 8;
    view.col_idx = cols.data(), view.col_idx_bytes = 4;
    view.values = values.data();
  }
};

}  // namespace

TEST_CASE("rows in any column order and duplicate entries are read as given, without a sorting copy",
          "[user-levels][unsorted]") {
  Levels s;
  std::vector<Scrambled> A, P;
  for (const Csr& m : s.A) A.emplace_back(m);
  for (const Csr& m : s.P) P.emplace_back(m);
  std::vector<CsrView> av, pv;
  for (const auto& m : A) av.push_back(m.view);
  for (const auto& m : P) pv.push_back(m.view);
  CHECK_FALSE(av.back().is_canonical());
  CHECK_THROWS_WITH(av.back().validate("m"), Catch::Contains("not sorted and unique"));
  av.back().validate("m", false);
  mg::UserLevels u(av, pv, {});
  const mg::UserLevels sorted(views(s.A), views(s.P), {});
  for (int l = 0; l < u.num_levels(); ++l) {
    const Bcsr& a = u.matrix(l);
    const Bcsr& b = sorted.matrix(l);
    REQUIRE(a.pattern().col_idx == b.pattern().col_idx);
    double diff = 0.0, scale = 0.0;
    for (size_t k = 0; k < a.values().size(); ++k)
      diff = std::max(diff, std::abs(a.values()[k] - b.values()[k])), scale = std::max(scale, std::abs(b.values()[k]));
    CHECK(diff <= 1e-14 * scale);  // halves summed: rounding at most
  }
  Vector x, y;
  const SolveResult r = mgpcg(u, s.b, x), q = mgpcg(sorted, s.b, y);
  CHECK(r.iterations == q.iterations);
  CHECK((x - y).norm() <= 1e-12 * y.norm());
  // New values on the same (scrambled) pattern, through set_values: the same walk, duplicates summed.
  for (auto& m : A)
    for (double& v : m.values) v *= 2.0;
  u.set_values(av);
  CHECK(u.matrix(u.num_levels() - 1).values()[0] == Approx(2.0 * sorted.matrix(u.num_levels() - 1).values()[0]));
  // to_csr sorts and sums.
  const Csr c = to_csr(P.back().view, "P");
  CHECK(c.pattern().col_idx == s.P.back().pattern().col_idx);
}

TEST_CASE("layout=component: any method on a component-major matrix solves as on the interleaved one",
          "[user-levels][layout]") {
  const FixedThreads fixed;  // the answers are compared bit for bit
  Levels s;
  const Csr& A = s.A.back();
  const index_t n = A.rows() / 3;
  const std::vector<index_t> perm = to_component(n);  // interleaved dof -> component-major dof
  const Csr Ac = permuted(A, perm, perm);
  Vector bc(s.b.size());
  for (index_t i = 0; i < s.b.size(); ++i) bc[perm[i]] = s.b[i];
  for (const std::string method : {"block-jacobi-pcg", "cg", "cholmod", "mcg"}) {
    CAPTURE(method);
    // The reference: the interleaved matrix in the format the wrapper gives the method.
    const Bcsr Ab = Bcsr::from_csr(A);
    auto plain = make_solver(Config::from_pairs({"method=" + method}, "test"), {});
    if (method_needs_blocks(method)) plain->setup(Ab);
    else plain->setup(A);
    Vector x = Vector::Zero(s.b.size());
    const SolveResult r = plain->solve(s.b, x);
    auto wrapped = make_solver(Config::from_pairs({"method=" + method, "layout=component"}, "test"), {});
    wrapped->setup(Ac);
    CHECK_THAT(wrapped->describe(), Catch::Contains("component-major input"));
    Vector xc = Vector::Zero(bc.size());
    const SolveResult rc = wrapped->solve(bc, xc);
    CHECK(rc.iterations == r.iterations);
    double diff = 0.0;
    for (index_t i = 0; i < s.b.size(); ++i) diff = std::max(diff, std::abs(xc[perm[i]] - x[i]));
    CHECK(diff == 0.0);  // the same matrix, the same arithmetic: the same answer
    // New values on the same pattern: update() refreshes the permuted copy.
    Csr A2 = Ac;
    for (double& v : A2.values()) v *= 2.0;
    wrapped->setup(A2);
    Vector x2 = Vector::Zero(bc.size());
    wrapped->solve(bc, x2);
    CHECK((2.0 * x2 - xc).norm() <= 1e-8 * xc.norm());
  }
  CHECK_THROWS_WITH(make_solver(Config::from_pairs({"method=mgpcg", "layout=component"}, "test"), {&s.h}),
                    Catch::Contains("multigrid levels take their layout where they are built"));
  CHECK_THROWS_WITH(make_solver(Config::from_pairs({"method=cg", "layout=rows"}, "test"), {}), Catch::Contains("layout"));
}

TEST_CASE("a component-major matrix handed to a block method without the layout key is refused, naming it",
          "[user-levels][layout][errors]") {
  // A quadratic box of 6 x 3 x 3 cubes clamped at one end (a sparse matrix: 10% of entries stored).
  const TetMesh mesh = box_mesh_24(6, 3, 3, 1.0, 0.5, 0.5);
  ElasticityModel model(mesh, 2, Material{});
  model.fix_where([](const Vec3& X) { return X.x() < 1e-12; });
  Bcsr K = model.assembler().make_matrix();
  model.assemble(nullptr, Vector(), K, nullptr);
  const Csr A = K.to_csr();
  const Csr Ac = permuted(A, to_component(A.rows() / 3), to_component(A.rows() / 3));
  const LayoutFit right = layout_fit(A), wrong = layout_fit(Ac);
  CAPTURE(right.interleaved, right.component, wrong.interleaved, wrong.component, wrong.density);
  CHECK(right.interleaved == 1.0);
  CHECK(right.component < 0.1);
  CHECK(wrong.component == 1.0);
  CHECK(wrong.interleaved < 0.9);
  CHECK(wrong.density < 0.5);
  CHECK(component_major_reading(A).empty());
  CHECK_THAT(component_major_reading(Ac), Catch::Contains("100% of the rows"));
  CHECK(right.rows == A.rows());
  for (const std::string method : {"block-jacobi-pcg", "mcg", "block-jacobi", "chebyshev", "damped-jacobi"}) {
    CAPTURE(method);
    auto solver = make_solver(Config::from_pairs({"method=" + method}, "test"), {});
    CHECK_THROWS_WITH(solver->setup(Ac), Catch::Contains("reads as component-major") && Catch::Contains("layout=component"));
    CHECK_FALSE(solver->is_set_up());
    auto fine = make_solver(Config::from_pairs({"method=" + method}, "test"), {});
    CHECK_NOTHROW(fine->setup(A));
  }
  // A BCSR matrix declares its blocks and is not judged (an interleaved plate numbered in layers
  // has the same block structure as a component-major matrix): the check belongs before
  // Bcsr::from_csr, where Python's make_solver and pmg compare make it.
  const Bcsr Ab = Bcsr::from_csr(Ac);
  CHECK_NOTHROW(check_interleaved(Ab, "test"));
  // Matrices that are not 3 unknowns per node are left alone: a scalar Laplacian of size 3k and a
  // dense SPD matrix (both readings fill every block).
  std::vector<Triplet> t;
  const index_t n = 30;
  for (index_t i = 0; i < n; ++i) {
    t.emplace_back(i, i, 2.0);
    if (i > 0) t.emplace_back(i, i - 1, -1.0), t.emplace_back(i - 1, i, -1.0);
  }
  const LayoutFit lap = layout_fit(Csr::from_triplets(n, n, t));
  CHECK(lap.component < 0.9);
  t.clear();
  for (index_t i = 0; i < 6; ++i)
    for (index_t j = 0; j < 6; ++j) t.emplace_back(i, j, i == j ? 10.0 : 1.0);
  const Csr dense = Csr::from_triplets(6, 6, t);
  CHECK(layout_fit(dense).interleaved == 1.0);
  CHECK_NOTHROW(make_solver(Config::from_pairs({"method=block-jacobi-pcg"}, "test"), {})->setup(dense));
}

TEST_CASE("user level errors name the level or prolongation", "[user-levels]") {
  Levels s;
  CHECK_THROWS_WITH(mg::UserLevels(views(s.A), {view_of(s.P[1]), view_of(s.P[0])}, {}), Catch::Contains("prolongation 2"));
  CHECK_THROWS_WITH(mg::UserLevels(views(s.A), {view_of(s.P[0])}, {}), Catch::Contains("prolongations"));
  std::vector<Csr> asym = s.A;
  asym[1].values()[1] += 1.0;
  CHECK_THROWS_WITH(mg::UserLevels(views(asym), views(s.P), {}), Catch::Contains("not symmetric"));
  const Csr mixing = kron_identity(s.P[1]);
  std::vector<Triplet> t{Triplet(0, 1, 0.5)};
  const auto& mp = mixing.pattern();
  for (index_t i = 0; i < mixing.rows(); ++i)
    for (offset_t k = mp.row_ptr[i]; k < mp.row_ptr[i + 1]; ++k) t.emplace_back(i, mp.col_idx[k], mixing.values()[k]);
  const Csr mixed = Csr::from_triplets(mixing.rows(), mixing.cols(), t);
  CHECK_THROWS_WITH(mg::UserLevels(views(s.A), {view_of(s.P[0]), view_of(mixed)}, {}), Catch::Contains("different displacement components"));
  CsrView bad = view_of(s.A[0]);
  std::vector<std::int32_t> cols(static_cast<const std::int32_t*>(bad.col_idx), static_cast<const std::int32_t*>(bad.col_idx) + bad.nnz);
  std::swap(cols[0], cols[1]);  // two column indices swapped, their values not: another matrix
  bad.col_idx = cols.data();
  CHECK_THROWS_WITH(mg::UserLevels({bad, view_of(s.A[1]), view_of(s.A[2])}, views(s.P), {}),
                    Catch::Contains("level 0: the matrix is not symmetric"));
}

TEST_CASE("the point locator finds what the scan finds", "[user-levels][locator]") {
  const TetMesh mesh = box_mesh_24(5, 2, 2, 1.0, 0.4, 0.4);
  ElasticityModel m(mesh, 2, Material{});
  const PointLocator loc(m);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> ux(0, 1), uy(0, 0.4);
  Vector u = Vector::LinSpaced(m.num_dofs(), -1, 1);
  for (int q = 0; q < 300; ++q) {
    const Vec3 X(ux(rng), uy(rng), uy(rng));
    const auto [e, l] = loc.locate(X);
    CHECK(l.minCoeff() >= -1e-10);
    CHECK((m.displacement_at(u, e, l) - m.displacement_at(u, X)).norm() <= 1e-12);
  }
  for (const Vec3& V : mesh.vertices) CHECK_NOTHROW(loc.locate(V));  // corners and faces included
  CHECK_THROWS_WITH(loc.locate(Vec3(1.5, 0.2, 0.2)), Catch::Contains("outside the mesh"));
  CHECK_THROWS_WITH(loc.locate(Vec3(std::nan(""), 0.2, 0.2)), Catch::Contains("outside the mesh"));
}

TEST_CASE("fixed iterations past the floating-point floor end as converged, not as a breakdown", "[user-levels][fixed]") {
  // MGPCG reaches a relative residual near 1e-155 in about 130 of 300 fixed iterations; there
  // r^T M^-1 r underflowed to 0 and was reported as "not symmetric positive definite".
  Levels s;
  auto solver = make_solver(Config::from_pairs({"method=mgpcg", "operator=assembled", "fixed_iterations=300"}, "test"), {&s.h});
  solver->setup(s.h.matrix(2));
  Vector x = Vector::Zero(s.b.size());
  SolveResult r;
  REQUIRE_NOTHROW(r = solver->solve(s.b, x));
  CHECK(r.status == SolveStatus::converged);
  CHECK(r.iterations < 300);
  // and the solution is as good as floating point allows: the true residual at the rounding floor
  // of computing A x (about eps ‖A‖ ‖x‖; ‖A‖_F bounds ‖A‖₂)
  Vector res(x.size());
  s.h.matrix(2).residual(s.b, x, res);
  const auto& v = s.h.matrix(2).values();
  const double norm_A = Eigen::Map<const Vector>(v.data(), static_cast<Eigen::Index>(v.size())).norm();
  CHECK(res.norm() <= 100 * std::numeric_limits<double>::epsilon() * norm_A * x.norm());
}
