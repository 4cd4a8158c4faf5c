// pmg — the pmgkit command-line tool. Each subcommand lives in its own file (commands.hpp).
#include "commands.hpp"

#include "pmg/solvers.hpp"
#include "pmg/sparse/monitor.hpp"

#include <filesystem>
#include <iostream>
#include <new>

namespace pmg::tools {

std::string find_data_file(const std::string& name) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = exe.parent_path().parent_path() / "share" / "pmgkit" / name;
    if (fs::exists(installed)) return installed.string();
  }
  const fs::path source = fs::path(PMG_TOOLS_SOURCE_DIR) / name;
  if (fs::exists(source)) return source.string();
  throw Error("data file " + name + " not found (looked in share/pmgkit and " PMG_TOOLS_SOURCE_DIR ")");
}

}  // namespace pmg::tools

int main(int argc, char** argv) {
  CLI::App app{"pmgkit: block-sparse formats, Krylov and direct solvers, p-multigrid"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "pmgkit " PMG_VERSION);
  // Every method of this build (the GPU ones where the CUDA module is built: they say so when there
  // is no device); the subcommands' help is generated from this registry.
  pmg::register_all_solvers();
  pmg::tools::register_solvers(app);
  pmg::tools::register_compare(app);
  pmg::tools::register_mesh(app);
  pmg::tools::register_coarse(app);
  pmg::tools::register_simulate(app);
  // The one error path: every failure becomes one "pmg: error:" line and a non-zero exit, never
  // an abort. Input errors (bad files, options, meshes) exit 2; failed solves and everything
  // else exit 1.
  const std::string command = argc > 1 ? std::string("pmg ") + argv[1] : "pmg";
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    std::cerr << "pmg: error: " << e.what() << "\nRun with --help for more information.\n";
    return e.get_exit_code();
  } catch (const pmg::tools::Exit& e) {
    return e.code;
  } catch (const pmg::InputError& e) {
    std::cerr << "pmg: error: " << e.what() << "\n";
    return pmg::tools::kBadInput;
  } catch (const pmg::Error& e) {
    std::cerr << "pmg: error: " << e.what() << "\n";
    return pmg::tools::kSolveFailed;
  } catch (const std::bad_alloc&) {
    std::cerr << "pmg: error: " << command
              << ": out of memory (the problem is larger than this machine can hold; try a smaller size)\n";
    return pmg::tools::kSolveFailed;
  } catch (const std::filesystem::filesystem_error& e) {
    std::cerr << "pmg: error: " << command << ": " << e.what() << "\n";
    return pmg::tools::kBadInput;
  } catch (const std::exception& e) {
    std::cerr << "pmg: error: " << command << ": unexpected failure: " << e.what() << "\n";
    return pmg::tools::kSolveFailed;
  } catch (...) {
    std::cerr << "pmg: error: " << command << ": unexpected failure of unknown type\n";
    return pmg::tools::kSolveFailed;
  }
  return pmg::tools::kOk;
}
