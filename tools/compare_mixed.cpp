#include "compare_mixed.hpp"

#include "commands.hpp"
#include "process.hpp"
#include "table.hpp"

#include "pmg/fem/mixed.hpp"
#include "pmg/fem/simulation.hpp"
#include "pmg/sim/setup.hpp"
#include "pmg/sparse/factory.hpp"
#include "pmg/sparse/file_io.hpp"
#include "pmg/sparse/timer.hpp"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <iostream>

namespace pmg::tools {

namespace {

struct MixedRow {
  std::string name;
  fem::MixedResult r;
  bool ok = false;
  std::string message;
  double du = 0.0, dp = 0.0;  ///< relative differences to the first run that succeeded
};

void print_rows(const std::vector<MixedRow>& rows) {
  std::printf("%-16s %6s %10s %10s %10s %12s %10s %10s\n", "solver", "its", "set-up s", "solve s", "total s",
              "true rel res", "du rel", "dp rel");
  for (const MixedRow& row : rows) {
    if (!row.ok) {
      std::printf("%-16s failed: %s\n", row.name.c_str(), row.message.c_str());
      continue;
    }
    std::printf("%-16s %6d %10.3f %10.3f %10.3f %12.3e %10.2e %10.2e\n", row.name.c_str(), row.r.solve.iterations,
                row.r.setup_seconds, row.r.solve_seconds, row.r.setup_seconds + row.r.solve_seconds,
                row.r.solve.true_rel_residual, row.du, row.dp);
  }
}

void write_json(const std::string& path, const std::string& description, const fem::MixedElasticity& m,
                double load_s, const std::vector<MixedRow>& rows) {
  nlohmann::ordered_json j;
  j["system"] = description;
  j["formulation"] = "mixed";
  j["displacement_unknowns"] = m.num_displacement();
  j["pressure_unknowns"] = m.num_pressure();
  j["poisson"] = m.material().poisson;
  j["load_s"] = load_s;
  for (const MixedRow& row : rows) {
    nlohmann::ordered_json r;
    r["solver"] = row.name;
    r["ok"] = row.ok;
    if (!row.ok) r["message"] = row.message;
    r["iterations"] = row.r.solve.iterations;
    r["setup_s"] = row.r.setup_seconds;
    r["solve_s"] = row.r.solve_seconds;
    r["true_rel_residual"] = row.r.solve.true_rel_residual;
    r["u_difference"] = row.du;
    r["p_difference"] = row.dp;
    r["description"] = row.r.description;
    j["runs"].push_back(r);
  }
  write_file_atomically(path, j.dump(2) + "\n");
}

}  // namespace

void add_formulation_option(CLI::App* sub, std::string& formulation) {
  sub->add_option("--formulation", formulation,
                  "displacement: the elasticity system K u = f; mixed: the displacement-pressure saddle point of "
                  "Taylor-Hood elements (degree 2 or 3 with a pressure of one degree less, nu up to 0.5; solvers "
                  "mixed-gmres, mixed-minres, and on the assembled system PETSc's fieldsplit-gmres and mumps)")
      ->check(CLI::IsMember({"displacement", "mixed"}))
      ->capture_default_str();
}

void run_mixed(const SceneOptions& o, const std::vector<std::pair<std::string, Config>>& configs,
               const std::string& json_report) {
  if (o.degree != 2 && o.degree != 3)
    throw InputError("--formulation mixed needs --degree 2 or 3 (Taylor-Hood: a pressure of degree k - 1 >= 1)");
  for (const auto& nc : configs) start_libraries(nc.second);
  const auto t0 = Clock::now();
  sim::Scene scene = scene_of(o);
  scene.formulation = "mixed";  // set_up() builds the displacement levels on the shear material
  sim::SceneSetup setup = sim::set_up(scene);
  fem::MixedElasticity m(fem::Material{o.young, o.poisson, o.density}, *setup.hierarchy);
  Vector f = setup.f_ext;
  if (o.dt > 0) {  // the system of one undamped implicit-Euler step, as sim::system_of makes it
    fem::SimulationParams sp;
    sp.dt = o.dt;
    const fem::StepWeights w = fem::step_weights(sp);
    m.set_weights({w.mass, w.stiffness});
    f *= o.dt;
  }
  const double load_s = seconds_since(t0);
  const std::string description = (o.mesh.empty() ? "box bar" : o.mesh) + ", degree " + std::to_string(o.degree) +
                                  "/" + std::to_string(o.degree - 1) + " Taylor-Hood, " +
                                  std::to_string(setup.mesh->num_tets()) + " tets, nu = " + fmt("%g", o.poisson) + ", " +
                                  o.load + (o.dt > 0 ? ", implicit-Euler step dt = " + fmt("%g", o.dt) : ", static");
  std::cout << "system: mixed displacement-pressure, " << description << "\n"
            << "unknowns: " << m.num_displacement() << " displacement + " << m.num_pressure() << " pressure\n"
            << "load: " << fmt("%.3f", load_s) << " s\n";
  std::vector<MixedRow> rows;
  rows.reserve(configs.size());  // `first` points into it
  const MixedRow* first = nullptr;
  for (const auto& [name, config] : configs) {
    MixedRow row;
    row.name = name;
    try {
      row.r = fem::solve_mixed_static(m, f, config);
      row.ok = row.r.solve.ok();
      row.message = row.r.solve.message;
    } catch (const InputError&) {
      throw;  // bad input ends the run (exit 2)
    } catch (const Error& e) {
      row.message = e.what();  // a failed solve or set-up (a factorisation): this row only
    }
    if (row.ok && first) {
      row.du = (row.r.u - first->r.u).norm() / std::max(first->r.u.norm(), 1e-300);
      row.dp = (row.r.p - first->r.p).norm() / std::max(first->r.p.norm(), 1e-300);
    }
    rows.push_back(std::move(row));
    if (!first && rows.back().ok) first = &rows.back();
    if (interrupted()) break;
  }
  print_rows(rows);
  for (const MixedRow& row : rows)
    if (row.ok) std::cout << row.r.description << "\n";
  if (!json_report.empty()) write_json(json_report, description, m, load_s, rows);
  for (const MixedRow& row : rows)
    if (!row.ok) throw Exit{kSolveFailed};
}

}  // namespace pmg::tools
