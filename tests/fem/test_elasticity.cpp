#include "manufactured.hpp"

#include "pmg/fem/generators.hpp"
#include "pmg/fem/matrix_free.hpp"
#include "pmg/fem/static_solve.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <iostream>
#include <limits>
#include <numeric>
#include <random>

#ifdef _OPENMP
#include <omp.h>
#endif

using namespace pmg;
using namespace pmg::fem;
using namespace pmg::fem::test;

namespace {
const Material kSteelish{2.0e5, 0.3, 1.0};

bool on_box_boundary(const Vec3& X, const Vec3& L) {
  for (int d = 0; d < 3; ++d)
    if (std::abs(X[d]) < 1e-12 || std::abs(X[d] - L[d]) < 1e-12) return true;
  return false;
}

/// Solves the Dirichlet problem for field f on the box (all boundary nodes prescribed by
/// interpolation) and returns the model's displacement.
Vector solve_manufactured(ElasticityModel& model, const Field& f, const Vec3& L, int quad_degree) {
  model.fix_where([&](const Vec3& X) { return on_box_boundary(X, L); });
  const Vector prescribed = model.interpolate(f.value);
  const Vector b = model.body_force(body_force_for(f, model.material()), quad_degree);
  return solve_static(model, b, false, {}, prescribed).u;
}
}  // namespace

TEST_CASE("patch test: a degree-p polynomial field is reproduced exactly", "[fem][elasticity]") {
  const TetMesh m = box_mesh_24(2, 2, 2, 1.0, 0.8, 0.6);
  const Vec3 L(1.0, 0.8, 0.6);
  for (int p = 1; p <= 3; ++p) {
    const Field f = polynomial_field(p, 10 + p);
    ElasticityModel model(m, p, kSteelish);
    const Vector u = solve_manufactured(model, f, L, p);
    const Vector exact = model.interpolate(f.value);
    INFO("degree " << p);
    CHECK((u - exact).lpNorm<Eigen::Infinity>() <= 1e-10 * exact.lpNorm<Eigen::Infinity>());
    CHECK(errors(model, u, f).energy <= 1e-9);
  }
}

TEST_CASE("convergence: L2 error order p+1, energy error order p", "[fem][elasticity]") {
  const Field f = sine_field();
  const Vec3 L(1.0, 1.0, 1.0);
  for (int p = 1; p <= 3; ++p) {
    std::vector<Errors> errs;
    const std::vector<int> sizes = p == 1 ? std::vector<int>{2, 4, 8} : std::vector<int>{1, 2, 4};
    for (int n : sizes) {
      const TetMesh m = box_mesh_24(n, n, n, 1.0, 1.0, 1.0);
      ElasticityModel model(m, p, kSteelish);
      errs.push_back(errors(model, solve_manufactured(model, f, L, 2 * p + 4), f));
    }
    const double rate_l2 = std::log2(errs[1].l2 / errs[2].l2);
    const double rate_en = std::log2(errs[1].energy / errs[2].energy);
    std::cout << "p=" << p << " L2 errors " << errs[0].l2 << " " << errs[1].l2 << " " << errs[2].l2
              << " (rate " << rate_l2 << "), energy " << errs[0].energy << " " << errs[1].energy
              << " " << errs[2].energy << " (rate " << rate_en << ")\n";
    INFO("degree " << p << ": L2 rate " << rate_l2 << ", energy rate " << rate_en);
    CHECK(rate_l2 > p + 1 - 0.25);
    CHECK(rate_en > p - 0.15);
  }
}

TEST_CASE("rigid rotation: corotational forces rotate and the energy stays, linear does not",
          "[fem][elasticity][corotational]") {
  const TetMesh m = box_mesh_24(2, 1, 1, 1.0, 0.5, 0.5);
  for (int p = 1; p <= 3; ++p) {
    ElasticityModel model(m, p, kSteelish);
    const auto& X = model.space().positions();
    // A deformed state: a smooth displacement.
    const Vector u = model.interpolate(sine_field().value);
    // Rotate the deformed configuration rigidly by 90 degrees about z through the origin.
    const Mat3 Q = Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ()).toRotationMatrix();
    Vector uq(u.size());
    for (index_t i = 0; i < model.num_nodes(); ++i)
      uq.segment<3>(3 * i) = Q * (X[i] + u.segment<3>(3 * i)) - X[i];
    const Rotations R = model.rotations(u), Rq = model.rotations(uq);
    const Vector f = model.elastic_force(u, &R), fq = model.elastic_force(uq, &Rq);
    double max_diff = 0.0;
    for (index_t i = 0; i < model.num_nodes(); ++i)
      max_diff = std::max(max_diff, (fq.segment<3>(3 * i) - Q * f.segment<3>(3 * i)).norm());
    const double E = model.elastic_energy(u, &R), Eq = model.elastic_energy(uq, &Rq);
    INFO("degree " << p);
    CHECK(max_diff <= 1e-10 * f.norm());
    CHECK(std::abs(Eq - E) <= 1e-10 * E);
    // Linear elasticity sees a large strain energy in a pure rotation of the rest shape.
    Vector rot(u.size());
    for (index_t i = 0; i < model.num_nodes(); ++i) rot.segment<3>(3 * i) = Q * X[i] - X[i];
    const Rotations Rr = model.rotations(rot);
    CHECK(model.elastic_energy(rot, &Rr) <= 1e-20 * kSteelish.young);
    CHECK(model.elastic_energy(rot, nullptr) > 1e3 * E);
  }
}

TEST_CASE("mass: consistent and lumped masses add up to ρ V", "[fem][elasticity][mass]") {
  const TetMesh m = box_mesh_24(2, 1, 1, 1.0, 0.5, 0.4);
  for (int p = 1; p <= 3; ++p) {
    ElasticityModel model(m, p, Material{1e5, 0.3, 1200.0});
    pmg::Bcsr M = model.assembler().make_matrix();  // no node fixed: the full mass matrix
    model.assemble_mass(M);
    const Vector ones = Vector::Ones(M.rows());
    Vector Mo;
    M.apply(ones, Mo);
    INFO("degree " << p);
    CHECK(Mo.sum() / 3 == Approx(1200.0 * 0.2).epsilon(1e-12));  // per component: ρ V
    CHECK(M.to_csr().is_symmetric(1e-14));
    const Vector lumped = model.lumped_mass();
    CHECK(lumped.minCoeff() > 0.0);
    CHECK(lumped.sum() == Approx(1200.0 * 0.2).epsilon(1e-12));
    for (index_t i = 0; i < model.num_nodes(); ++i) CHECK(Mo[3 * i] == Approx(lumped[i]).epsilon(1e-12));
  }
}

TEST_CASE("polar rotation is proper even for inverted elements", "[fem][corotational]") {
  const Mat3 Q = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  const Mat3 S = (Mat3() << 1.2, 0.1, 0.0, 0.1, 0.9, 0.05, 0.0, 0.05, 1.1).finished();
  CHECK((polar_rotation(Q * S) - Q).norm() < 1e-12);
  const Mat3 inverted = Q * S * Eigen::Vector3d(1, 1, -1).asDiagonal();
  const Mat3 R = polar_rotation(inverted);
  CHECK(R.determinant() == Approx(1.0));
  CHECK((R.transpose() * R - Mat3::Identity()).norm() < 1e-12);
}

TEST_CASE("bad material, missing supports and bad forces are clear errors", "[fem][errors]") {
  const TetMesh m = box_mesh_24(1, 1, 1, 1.0, 1.0, 1.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_WITH(ElasticityModel(m, 2, Material{nan, 0.3, 1.0}), Catch::Contains("Young's modulus"));
  CHECK_THROWS_WITH(ElasticityModel(m, 2, Material{-1.0, 0.3, 1.0}), Catch::Contains("Young's modulus"));
  CHECK_THROWS_WITH(ElasticityModel(m, 2, Material{1.0, 0.5, 1.0}), Catch::Contains("Poisson"));
  CHECK_THROWS_WITH(ElasticityModel(m, 2, Material{1.0, -1.0, 1.0}), Catch::Contains("Poisson"));
  CHECK_THROWS_WITH(ElasticityModel(m, 2, Material{1.0, 0.3, -2.0}), Catch::Contains("density"));
  CHECK_THROWS_WITH(ElasticityModel(m, 4, Material{}), Catch::Contains("degree 4"));

  ElasticityModel model(m, 2, Material{});
  const Vector g = model.gravity(Vec3(0, 0, -9.81));
  CHECK_THROWS_WITH(solve_static(model, g, false), Catch::Contains("no node is fixed"));
  model.fix_nodes({0});  // one point: rotations about it remain free
  CHECK_THROWS_WITH(solve_static(model, g, false), Catch::Contains("not positive definite"));
  CHECK_THROWS_WITH(model.fix_nodes({1}), Catch::Contains("after the first assembly"));

  ElasticityModel model2(m, 1, Material{});
  model2.fix_where([](const Vec3& X) { return X.z() < 1e-12; });
  Vector bad = Vector::Zero(model2.num_dofs());
  bad[5] = nan;
  CHECK_THROWS_WITH(solve_static(model2, bad, false), Catch::Contains("NaN"));
  CHECK_THROWS_WITH(model2.add_point_force(bad, Vec3(3, 0, 0), Vec3(1, 0, 0)), Catch::Contains("outside the mesh"));
}

TEST_CASE("clamping by vertices fixes the same face on every degree", "[fem][dirichlet]") {
  const TetMesh mesh = box_mesh_24(2, 1, 1, 2.0, 1.0, 1.0);
  std::vector<char> face(mesh.vertices.size()), edge(mesh.vertices.size()), point(mesh.vertices.size());
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    const Vec3& X = mesh.vertices[v];
    face[v] = X.x() < 1e-12;
    edge[v] = X.x() < 1e-12 && X.y() < 1e-12;
    point[v] = X.norm() < 1e-12;
  }
  CHECK(clamped_dimension(mesh, std::vector<char>(mesh.vertices.size(), 0)) == -1);
  CHECK(clamped_dimension(mesh, point) == 0);
  CHECK(clamped_dimension(mesh, edge) == 1);
  CHECK(clamped_dimension(mesh, face) == 2);
  for (int p = 1; p <= 3; ++p) {
    ElasticityModel by_vertex(mesh, p, kSteelish), by_position(mesh, p, kSteelish);
    by_vertex.fix_vertices(face);
    by_position.fix_where([](const Vec3& X) { return X.x() < 1e-12; });
    for (index_t i = 0; i < by_vertex.num_nodes(); ++i) CHECK(by_vertex.is_fixed(i) == by_position.is_fixed(i));
    ElasticityModel on_edge(mesh, p, kSteelish);
    on_edge.fix_vertices(edge);
    // The x = 0, y = 0 edge of the 24-tet box: 2 vertices, and p - 1 nodes inside the edge.
    CHECK(on_edge.num_fixed() == 2 + (p - 1));
  }
  ElasticityModel m(mesh, 2, kSteelish);
  CHECK_THROWS_AS(m.fix_vertices(std::vector<char>(3, 1)), InputError);
}

TEST_CASE("a per-element stiffness scale acts as a per-element Young's modulus", "[fem][material]") {
  const TetMesh mesh = box_mesh_24(2, 1, 1, 2.0, 1.0, 1.0);
  auto clamp = [](const Vec3& X) { return X.x() < 1e-12; };
  ElasticityModel soft(mesh, 2, kSteelish), scaled(mesh, 2, kSteelish),
      stiff(mesh, 2, Material{3 * kSteelish.young, kSteelish.poisson, kSteelish.density});
  for (ElasticityModel* m : {&soft, &scaled, &stiff}) m->fix_where(clamp);
  scaled.set_stiffness_scale(std::vector<double>(mesh.num_tets(), 3.0));
  const Vector f = soft.gravity(Vec3(0, 0, -9.81));
  const Vector u_scaled = solve_static(scaled, f, false).u, u_stiff = solve_static(stiff, f, false).u;
  CHECK((u_scaled - u_stiff).norm() <= 1e-12 * u_stiff.norm());
  CHECK((solve_static(soft, f, false).u - 3.0 * u_stiff).norm() <= 1e-10 * u_stiff.norm());
  // A stiff half: less deflection than the soft body, more than the stiff one.
  std::vector<double> half(mesh.num_tets(), 1.0);
  for (index_t e = 0; e < mesh.num_tets(); ++e)
    if (mesh.vertices[mesh.tets[e][0]].x() + mesh.vertices[mesh.tets[e][1]].x() > 2.0) half[e] = 1e6;
  scaled.set_stiffness_scale(half);
  const double tip = solve_static(scaled, f, false).u.norm();
  CHECK(tip < solve_static(soft, f, false).u.norm());
  CHECK(tip > u_stiff.norm());
  CHECK_THROWS_AS(scaled.set_stiffness_scale(std::vector<double>(3, 1.0)), InputError);
  CHECK_THROWS_AS(scaled.set_stiffness_scale(std::vector<double>(mesh.num_tets(), -1.0)), InputError);
}

TEST_CASE("one pass over the elements: matrix, force and energy equal the serial R K_e Rᵀ reference",
          "[fem][elasticity][corotational]") {
  // The reference builds each element's unrotated K_e, rotates it blockwise (R K_ab Rᵀ) and forms
  // f_e = -R K_e (Rᵀ x_e - X_e), E_e = ½ dᵀ K_e d with d = Rᵀ x_e - X_e, serially and densely.
  // evaluate() builds R K_e Rᵀ from rotated gradients instead, scatters in parallel by colour,
  // and adds s K_R onto the values already there (m M) when asked.
  const TetMesh mesh = box_mesh_24(2, 1, 1, 1.0, 0.5, 0.5);
  for (int p = 1; p <= 3; ++p) {
    ElasticityModel model(mesh, p, kSteelish);
    model.fix_where([](const Vec3& X) { return X.x() < 1e-12; });
    const auto& X = model.space().positions();
    const int n = model.space().nodes_per_element();
    const Vector u = 0.05 * model.interpolate(sine_field().value);
    const Rotations R = model.rotations(u);
    const auto& fi = model.assembler().free_index();
    const index_t nf = model.num_free_dofs();
    Eigen::MatrixXd K_ref = Eigen::MatrixXd::Zero(nf, nf);
    Vector f_ref = Vector::Zero(model.num_dofs());
    double E_ref = 0.0;
    const ElementTables& tables = element_tables(p);
    for (index_t e = 0; e < mesh.num_tets(); ++e) {
      Eigen::MatrixXd Ke;
      element_stiffness(tables, model.geometry(e), kSteelish.lambda(), kSteelish.mu(), Ke);
      Eigen::VectorXd d(3 * n);
      for (int a = 0; a < n; ++a) {
        const index_t i = model.space().node(e, a);
        d.segment<3>(3 * a) = R[e].transpose() * (X[i] + u.segment<3>(3 * i)) - X[i];
      }
      const Eigen::VectorXd g = Ke * d;
      E_ref += 0.5 * d.dot(g);
      for (int a = 0; a < n; ++a) {
        const index_t ia = model.space().node(e, a);
        f_ref.segment<3>(3 * ia) -= R[e] * g.segment<3>(3 * a);
        for (int b = 0; b < n; ++b) {
          const index_t ib = model.space().node(e, b);
          if (fi[ia] < 0 || fi[ib] < 0) continue;
          K_ref.block<3, 3>(3 * fi[ia], 3 * fi[ib]) += R[e] * Ke.block<3, 3>(3 * a, 3 * b) * R[e].transpose();
        }
      }
    }
    // Everything from one pass, the matrix added onto 2 M with weight 0.5.
    Bcsr M = model.assembler().make_matrix(), K = model.assembler().make_matrix();
    model.assemble_mass(M);
    K.values() = M.values();
    for (double& v : K.values()) v *= 2.0;
    Vector f;
    double E = 0.0;
    ElasticityModel::ElementPass pass;
    pass.u = &u;
    pass.R = &R;
    pass.stiffness = &K;
    pass.stiffness_weight = 0.5;
    pass.add_to_stiffness = true;
    pass.force = &f;
    pass.energy = &E;
    model.evaluate(pass);
    const Eigen::MatrixXd K_dense = K.to_csr().to_eigen().toDense();
    const Eigen::MatrixXd expected = 2.0 * M.to_csr().to_eigen().toDense() + 0.5 * K_ref;
    INFO("degree " << p);
    CHECK((K_dense - expected).norm() <= 1e-12 * expected.norm());
    CHECK((f - f_ref).norm() <= 1e-12 * f_ref.norm());
    CHECK(std::abs(E - E_ref) <= 1e-12 * E_ref);
    // The single-output entry points agree with the one pass.
    CHECK((model.elastic_force(u, &R) - f).norm() <= 1e-14 * f.norm());
    CHECK(model.elastic_energy(u, &R) == Approx(E).epsilon(1e-14));
    // A probe located once evaluates as a probe located every time.
    const Vec3 P(0.7, 0.2, 0.3);
    const auto [e, l] = model.locate(P);
    CHECK((model.displacement_at(u, e, l) - model.displacement_at(u, P)).norm() == 0.0);
  }
}

TEST_CASE("degree 1, the matrix alone: assembled row by row, exactly symmetric, equal to R K_e Rᵀ summed",
          "[fem][elasticity][threads]") {
  // A stiffness-only pass at degree 1 takes the row-by-row route (each free node's block row from
  // its elements, in element order): block (J, I) sums the transposes of block (I, J)'s terms in the
  // same order, so the matrix is symmetric to the last bit, and each row is written by one thread.
  const TetMesh mesh = box_mesh_24(4, 2, 2, 1.0, 0.5, 0.5);
  ElasticityModel model(mesh, 1, kSteelish);
  model.fix_where([](const Vec3& X) { return X.x() < 1e-12; });
  std::vector<double> scale(static_cast<size_t>(mesh.num_tets()));
  for (size_t e = 0; e < scale.size(); ++e) scale[e] = 1.0 + 0.5 * std::sin(static_cast<double>(e));
  model.set_stiffness_scale(scale);
  const Vector u = 0.05 * model.interpolate(sine_field().value);
  const Rotations R = model.rotations(u);
  const auto& fi = model.assembler().free_index();
  for (const Rotations* rot : {static_cast<const Rotations*>(nullptr), &R}) {
    Eigen::MatrixXd K_ref = Eigen::MatrixXd::Zero(model.num_free_dofs(), model.num_free_dofs());
    for (index_t e = 0; e < mesh.num_tets(); ++e) {
      Eigen::MatrixXd Ke;
      const double s = scale[static_cast<size_t>(e)];
      element_stiffness(element_tables(1), model.geometry(e), s * kSteelish.lambda(), s * kSteelish.mu(), Ke);
      const Mat3 Re = rot ? (*rot)[e] : Mat3(Mat3::Identity());
      for (int a = 0; a < 4; ++a)
        for (int b = 0; b < 4; ++b) {
          const index_t I = fi[model.space().node(e, a)], J = fi[model.space().node(e, b)];
          if (I >= 0 && J >= 0) K_ref.block<3, 3>(3 * I, 3 * J) += Re * Ke.block<3, 3>(3 * a, 3 * b) * Re.transpose();
        }
    }
    auto assemble = [&] {
      Bcsr K = model.assembler().make_matrix();
      ElasticityModel::ElementPass pass;
      pass.R = rot;
      pass.stiffness = &K;
      pass.stiffness_weight = 0.5;
      model.evaluate(pass);
      return K;
    };
    const Bcsr K = assemble();
    INFO((rot ? "rotated" : "unrotated"));
    CHECK((K.to_csr().to_eigen().toDense() - 0.5 * K_ref).norm() <= 1e-13 * K_ref.norm());
    CHECK(K.to_csr().is_symmetric(0.0));
    // A matrix of the same block rows on another pattern is refused (the stiffness and the mass),
    // not written by the wrong slots.
    {
      auto other = std::make_shared<BlockPattern>();
      other->rows = other->cols = K.block_rows();
      other->row_ptr.resize(static_cast<size_t>(K.block_rows()) + 1);
      for (index_t I = 0; I < K.block_rows(); ++I) {
        other->col_idx.push_back(I);
        other->row_ptr[static_cast<size_t>(I) + 1] = I + 1;
      }
      Bcsr D(other, std::vector<double>(9 * static_cast<size_t>(K.block_rows()), 0.0));
      ElasticityModel::ElementPass pass;
      pass.R = rot;
      pass.stiffness = &D;
      CHECK_THROWS_AS(model.evaluate(pass), InputError);
      CHECK_THROWS_AS(model.assemble_mass(D), InputError);
    }
#ifdef _OPENMP
    const int before = omp_get_max_threads();
    for (int threads : {1, 2, 3}) {
      omp_set_num_threads(threads);
      INFO(threads << " threads");
      CHECK(assemble().values() == K.values());
    }
    omp_set_num_threads(before);
#endif
  }
}

TEST_CASE("element ranges: every node written once per element, the same sums on 1, 2 and 3 threads",
          "[fem][elasticity][threads]") {
  // 3072 elements of a slender bar: in the generator's order (contiguous ranges share few nodes:
  // kept) and shuffled (ranges would share most nodes: the Morton order of the centroids instead).
  const TetMesh ordered = box_mesh_24(128, 1, 1, 8.0, 0.0625, 0.0625);
  TetMesh shuffled = ordered;
  std::shuffle(shuffled.tets.begin(), shuffled.tets.end(), std::mt19937(7));
  for (const TetMesh* mesh : std::vector<const TetMesh*>{&ordered, &shuffled}) {
    for (int p = 1; p <= 3; p += 2) {
      ElasticityModel model(*mesh, p, kSteelish);
      model.fix_where([](const Vec3& X) { return X.x() < 1e-12; });
      const ElementRanges& ranges = model.assembler().ranges();
      CHECK(ranges.reordered() == (mesh == &shuffled));
      INFO("degree " << p << (mesh == &shuffled ? ", shuffled" : ", generator's order"));
      const Vector u = 0.05 * model.interpolate(sine_field().value);
      const Rotations R = model.rotations(u);
      ElasticityOperator op(model);
      op.update(&R);
      struct Result {
        std::vector<double> K, M;
        Vector f, f_mf;
        double E = 0, E_mf = 0;
        std::vector<int> firsts, writes;
        int seconds = 0;  // second visits (elements on a border between ranges)
        int threads = 0;  // threads that ran a range
      };
      auto run = [&] {
        Result r;
        Bcsr K = model.assembler().make_matrix(), M = model.assembler().make_matrix();
        ElasticityModel::ElementPass pass;
        pass.u = &u;
        pass.R = &R;
        pass.stiffness = &K;
        pass.force = &r.f;
        pass.energy = &r.E;
        model.evaluate(pass);
        model.assemble_mass(M);
        r.K = K.values(), r.M = M.values();
        op.element_force(u, &R, r.f_mf, &r.E_mf);
        // Visits: each element once with first = true; each (element, node) written by one call.
        const int n = model.space().nodes_per_element();
        r.firsts.assign(static_cast<size_t>(mesh->num_tets()), 0);
        r.writes.assign(static_cast<size_t>(mesh->num_tets()) * n, 0);
        std::vector<char> ran(static_cast<size_t>(ranges.threads()), 0);  // one slot per thread
        ranges.for_each([&](int thread, index_t e, const ElementRanges::Writes& writes, bool first) {
          r.firsts[static_cast<size_t>(e)] += first;
          if (!first) ++r.seconds;  // second visits run on one thread
          if (first) ran[static_cast<size_t>(thread)] = 1;
          for (int a = 0; a < n; ++a) r.writes[static_cast<size_t>(e) * n + a] += writes(model.space().node(e, a));
          return 0.0;
        });
        r.threads = static_cast<int>(std::count(ran.begin(), ran.end(), 1));
        return r;
      };
      const Result one = [&] {
#ifdef _OPENMP
        const int before = omp_get_max_threads();
        omp_set_num_threads(1);
        Result r = run();
        omp_set_num_threads(before);
        return r;
#else
        return run();
#endif
      }();
      CHECK(std::all_of(one.firsts.begin(), one.firsts.end(), [](int c) { return c == 1; }));
      CHECK(std::all_of(one.writes.begin(), one.writes.end(), [](int c) { return c == 1; }));
      // The matrix-free forces are the assembled pass's.
      CHECK((one.f_mf - one.f).norm() <= 1e-12 * one.f.norm());
      CHECK(one.E_mf == Approx(one.E).epsilon(1e-12));
#ifdef _OPENMP
      const int before = omp_get_max_threads();
      for (int threads : {2, 3}) {
        omp_set_num_threads(threads);
        const Result r = run();
        INFO(threads << " threads");
        CHECK(std::all_of(r.firsts.begin(), r.firsts.end(), [](int c) { return c == 1; }));
        CHECK(std::all_of(r.writes.begin(), r.writes.end(), [](int c) { return c == 1; }));
        // Where the runtime gave several threads, some elements lie on a border and were visited
        // twice: the comparison below covers the second pass.
        if (r.threads > 1) CHECK(r.seconds > 0);
        // Each node's contributions in traversal order on any number of threads: bitwise equal.
        CHECK(r.K == one.K);
        CHECK(r.M == one.M);
        CHECK(r.f == one.f);
        CHECK(r.f_mf == one.f_mf);
        CHECK(r.E == Approx(one.E).epsilon(1e-14));
      }
      omp_set_num_threads(before);
#endif
    }
  }
}

TEST_CASE("a hierarchy's degrees share one rest geometry; a bad element or a foreign geometry is named",
          "[fem][elasticity][errors]") {
  const TetMesh mesh = box_mesh_24(3, 2, 2, 1.0, 0.5, 0.5);
  const Material steel{200e9, 0.3, 7800.0};
  const DegreeHierarchy h(mesh, 3, steel, [](const Vec3& X) { return X.x() < 1e-12; });
  for (int l = 1; l < h.num_levels(); ++l)
    CHECK(h.model(l).shared_geometry().get() == h.model(0).shared_geometry().get());
  // The shared geometry is the geometry each element has on its own.
  const ElasticityModel alone(mesh, 2, steel);
  for (index_t e = 0; e < mesh.num_tets(); ++e) {
    CHECK(alone.geometry(e).volume == h.model(1).geometry(e).volume);
    CHECK(alone.geometry(e).grad == h.model(1).geometry(e).grad);
  }
  const TetMesh other = box_mesh_24(2, 2, 2, 1.0, 0.5, 0.5);
  CHECK_THROWS_WITH(ElasticityModel(other, 2, steel, alone.shared_geometry()), Catch::Contains("shared geometry"));
  // The first inverted element is named, also when the geometry is computed on the threads.
  TetMesh bad = mesh;
  const index_t e = mesh.num_tets() / 2;
  std::swap(bad.tets[e][1], bad.tets[e][2]);
  std::swap(bad.tets[e + 7][1], bad.tets[e + 7][2]);
  CHECK_THROWS_WITH(ElasticityModel(bad, 1, steel), Catch::Contains("element " + std::to_string(e) + ":"));
}
