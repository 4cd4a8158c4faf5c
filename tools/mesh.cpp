// pmg mesh — closed surface (.off/.stl) to tetrahedral mesh with TetGen, at about a requested
// number of elements; or statistics of an existing mesh (.msh/.node/.ele); --refine k splits every
// element into 8, k times (an h-refinement sequence on the same geometry).
//
//   1. Read the surface, compute its volume (divergence theorem); decimate it (CGAL edge collapse)
//      when it has more triangles than a mesh of the requested size can keep.
//   2. Run `tetgen -pq<ratio>a<V/N>` in a scratch folder; TetGen's quality refinement adds
//      elements, so the volume bound is rescaled from the counts obtained (up to 6 runs) until the
//      count is within 15% of the request.
//   3. Read TetGen's output back (checks every element), write .node/.ele, print the counts.
#include "process.hpp"
#include "pmg/sparse/text_reader.hpp"
#include "checks.hpp"
#include "commands.hpp"
#include "surface_simplify.hpp"
#include "table.hpp"

#include "pmg/fem/bb_space.hpp"
#include "pmg/fem/mesh_io.hpp"
#include "pmg/fem/vtk_writer.hpp"
#include "pmg/sparse/file_io.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>
#include <sys/wait.h>
#include <unistd.h>

namespace pmg::tools {

namespace {

namespace fs = std::filesystem;

struct MeshOptions {
  std::string input, output;
  long tets = 5000;
  long surface_triangles = -1;  // -1: automatic, 0: keep the surface
  double quality = 1.414;
  std::string tetgen = "tetgen";
  int refine = 0;
  bool vtu = false;
  std::vector<std::string> allow;
};

void write_off(const fs::path& path, const fem::Surface& s) {
  std::ostringstream out;
  out.precision(17);
  out << "OFF\n" << s.vertices.size() << " " << s.triangles.size() << " 0\n";
  for (const auto& v : s.vertices) out << v.x() << " " << v.y() << " " << v.z() << "\n";
  for (const auto& t : s.triangles) out << "3 " << t[0] << " " << t[1] << " " << t[2] << "\n";
  write_file_atomically(path.string(), out.str());
}

/// Peak memory of a run per tetrahedron asked for (TetGen's runs, reading and checking the mesh,
/// the node counts of degrees 1-3): `/usr/bin/time -f %M pmg mesh tests/tools/data/cube.off
/// -n 300000` peaked at 516 MB, 1.7 kB per tetrahedron asked (its first TetGen run made 589k).
constexpr double kMeshBytesPerTet = 2e3;

/// Ends the run with exit status 130 after Ctrl-C (the scratch folder is removed on the way out).
void stop_if_interrupted() {
  if (!interrupted()) return;
  std::cout << std::flush;
  std::cerr << "pmg: interrupted: nothing was written, the temporary folder was removed\n";
  throw Exit{kInterrupted};
}

fem::TetMesh run_tetgen(const MeshOptions& o, const fs::path& input, const fs::path& scratch,
                        double max_volume) {  for (const char* ext : {".1.node", ".1.ele", ".1.face", ".1.edge"})
    fs::remove(input.parent_path() / (input.stem().string() + ext));
  char switches[128];
  std::snprintf(switches, sizeof switches, "-pq%ga%.6g", o.quality, max_volume);
  const std::string log = (scratch / "tetgen.log").string();
  const int rc = run_program({o.tetgen, "-Q", switches, input.string()}, log);
  // Ctrl-C reaches TetGen too (the same process group): it ends with SIGINT.
  if ((WIFSIGNALED(rc) && WTERMSIG(rc) == SIGINT) || (WIFEXITED(rc) && WEXITSTATUS(rc) == 128 + SIGINT)) {
    std::cout << std::flush;
    std::cerr << "pmg: interrupted: TetGen was stopped, nothing was written, the temporary folder was removed\n";
    throw Exit{kInterrupted};
  }
  stop_if_interrupted();
  // TetGen may exit with 134 even after writing a good mesh: judge by its output files.
  const fs::path base = input.parent_path() / (input.stem().string() + ".1");
  if (!fs::exists(base.string() + ".ele"))
    throw Error("tetgen failed (" +
                (rc == -1 ? std::string("could not be started: ") + o.tetgen
                          : (WIFSIGNALED(rc) ? "killed by signal " + std::to_string(WTERMSIG(rc))
                                              : "exit status " + std::to_string(WEXITSTATUS(rc))) +
                                ", its last words: " + printable(tail_of_file(log, 3))) +
                "); is the surface closed and free of self-intersections? Is tetgen installed (apt install tetgen)?");
  fem::TetMesh mesh = fem::read_tetgen(base.string());
  stop_if_interrupted();
  return mesh;
}

void print_counts(const fem::TetMesh& m) {
  Table t({"degree", "nodes", "dofs"});
  for (int p = 1; p <= 3; ++p) {
    const fem::BBSpace s(m, p);
    t.add({std::to_string(p), std::to_string(s.num_nodes()), std::to_string(3 * s.num_nodes())});
  }
  t.print(std::cout);
}

void run(const MeshOptions& o) {
  catch_interrupt();
  if (!o.output.empty()) check_output_file(o.output + ".node", "-o");  // before TetGen runs
  if (!o.allow.empty() && (fs::path(o.input).extension() == ".off" || fs::path(o.input).extension() == ".stl"))
    throw InputError("--allow applies to mesh files (.msh, .node, .ele), not to surfaces");
  const std::string ext = fs::path(o.input).extension().string();
  fem::TetMesh mesh;
  if (ext == ".off" || ext == ".stl") {
    fem::Surface surface = fem::read_surface(o.input);
    const double volume = std::abs(surface.volume());
    if (!(volume > 0)) throw InputError(o.input + ": the surface encloses no volume (not closed?)");
    std::cout << "surface: " << o.input << ", " << surface.vertices.size() << " vertices, "
              << surface.triangles.size() << " triangles, volume " << fmt("%.6g", volume) << "\n";
    const double estimate = kMeshBytesPerTet * static_cast<double>(o.tets) * std::pow(8.0, o.refine);
    std::cout << "estimated peak memory: " << fmt("%.3g", estimate / 1e9) << " GB (-n " << o.tets
              << (o.refine > 0 ? ", --refine " + std::to_string(o.refine) : std::string()) << ")\n";
    require_memory(estimate, "-n " + std::to_string(o.tets) + " tetrahedra" +
                                 (o.refine > 0 ? " refined " + std::to_string(o.refine) + "x" : std::string()));
    stop_if_interrupted();
    // TetGen keeps every surface triangle and refines inwards from them to meet the quality bound:
    // measured on the CGAL models, about N^(2/3) surface triangles give N elements at -q1.414, so a
    // finer surface is decimated to that first (before the scratch folder exists: a Ctrl-C during
    // the decimation leaves nothing behind).
    const long keep = o.surface_triangles >= 0
                          ? o.surface_triangles
                          : static_cast<long>(std::pow(static_cast<double>(o.tets), 2.0 / 3.0));
    const bool simplify = keep > 0 && static_cast<long>(surface.triangles.size()) > keep;
    if (simplify) {
      surface = simplify_surface(surface, static_cast<size_t>(keep));
      stop_if_interrupted();
      std::cout << "surface simplified to " << surface.triangles.size() << " triangles (volume "
                << fmt("%.6g", std::abs(surface.volume())) << ")\n";
    }
    const ScratchDir scratch_dir(fs::temp_directory_path() / ("pmg_mesh_" + std::to_string(::getpid())));
    const fs::path& scratch = scratch_dir.path;
    fs::path input = scratch / ("surface" + fs::path(o.input).extension().string());
    if (simplify) {
      input = scratch / "surface.off";
      write_off(input, surface);
    } else {
      fs::copy_file(o.input, input, fs::copy_options::overwrite_existing);
    }
    // count ~ C a^-k: k = 1 would hold without quality refinement; estimate it from the runs.
    double max_volume = volume / o.tets, previous_volume = 0.0, previous_count = 0.0, k = 1.0;
    for (int attempt = 1;; ++attempt) {
      stop_if_interrupted();
      mesh = run_tetgen(o, input, scratch, max_volume);
      const double count = mesh.num_tets();
      std::cout << "tetgen run " << attempt << ": max volume " << fmt("%.3g", max_volume) << " -> "
                << mesh.num_tets() << " tetrahedra\n";
      if (std::abs(count / o.tets - 1.0) <= 0.15 || attempt == 6) break;
      if (count == previous_count) {
        std::cout << "warning: the element count no longer follows the volume bound; the surface's "
                  << surface.triangles.size() << " triangles set the minimum (--surface-triangles "
                  << "lowers it)\n";
        break;
      }
      if (previous_count > 0)
        k = std::clamp(std::log(previous_count / count) / std::log(max_volume / previous_volume), 0.2, 2.0);
      previous_volume = max_volume;
      previous_count = count;
      max_volume *= std::pow(count / o.tets, 1.0 / k);
    }
  } else {
    std::vector<std::string> warnings;
    fem::MeshCheckOptions checks;
    for (const auto& a : o.allow) fem::allow_mesh_defect(checks, a);
    mesh = fem::read_mesh(o.input, &warnings, checks);
    for (const auto& w : warnings) std::cout << "warning: " << w << "\n";
  }
  if (o.refine > 0) {
    require_memory(kMeshBytesPerTet * mesh.num_tets() * std::pow(8.0, o.refine),
                   "--refine " + std::to_string(o.refine) + " of " + std::to_string(mesh.num_tets()) + " tetrahedra");
    mesh = fem::refine_uniform(mesh, o.refine);
    std::cout << "refined uniformly " << o.refine << "x (each tetrahedron into 8, geometry unchanged)\n";
  }
  std::cout << "mesh: " << mesh.num_tets() << " tetrahedra, " << mesh.num_vertices()
            << " vertices (all elements checked)\n";
  print_counts(mesh);
  stop_if_interrupted();
  if (!o.output.empty()) {
    std::string base = o.output;
    for (const char* e : {".node", ".ele"})
      if (base.size() > 5 && base.substr(base.size() - std::string(e).size()) == e)
        base.erase(base.size() - std::string(e).size());
    fem::write_tetgen(base, mesh);
    std::cout << "written: " << base << ".node, " << base << ".ele\n";
    if (o.vtu) {
      fem::write_vtu(base + ".vtu", fem::BBSpace(mesh, 1), Vector());
      std::cout << "written: " << base << ".vtu\n";
    }
  } else {
    // As pmg simulate and pmg compare, no output unless one is named; the run says so.
    std::cout << "not written: no -o given (pmg mesh " << o.input << " -o BASE writes BASE.node and BASE.ele)\n";
  }
}

}  // namespace

void register_mesh(CLI::App& app) {
  auto o = std::make_shared<MeshOptions>();
  CLI::App* sub = app.add_subcommand(
      "mesh", "Tetrahedralise a closed surface (.off/.stl) with TetGen, or check a mesh");
  sub->add_option("input", o->input, "surface (.off, .stl) or mesh (.msh, .node, .ele)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("-o,--output", o->output,
                  "output base name (writes BASE.node and BASE.ele; without it the mesh is checked and "
                  "nothing is written)");
  sub->add_option("-n,--tets", o->tets, "target number of tetrahedra (within 15%)")
      ->check(CLI::Range(10L, 100000000L))
      ->capture_default_str();
  sub->add_option("--surface-triangles", o->surface_triangles,
                  "decimate the surface to this many triangles first (default: N^(2/3); 0: never)")
      ->check(CLI::Range(-1L, 100000000L));
  sub->add_option("-q,--quality", o->quality, "TetGen radius-edge bound (-q)")
      ->check(FiniteRange(1.1, 10.0))
      ->capture_default_str();
  sub->add_option("--tetgen", o->tetgen, "TetGen executable")->capture_default_str();
  sub->add_option("--refine", o->refine, "then refine uniformly this many times (8x elements each)")
      ->check(CLI::Range(0, 4));
  sub->add_flag("--vtu", o->vtu, "also write BASE.vtu for viewing")->needs("--output");
  add_allow_option(sub, o->allow);
  sub->callback([o] { run(*o); });
}

}  // namespace pmg::tools
