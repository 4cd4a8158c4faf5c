// pmg — the pmgkit command-line tool. Each subcommand lives in its own file (commands.hpp).
#include "commands.hpp"

#include "pmg/sparse/monitor.hpp"

#include <filesystem>
#include <iostream>

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
  app.set_version_flag("--version", "pmgkit 0.1.0");
  pmg::tools::register_compare(app);
  pmg::tools::register_mesh(app);
  pmg::tools::register_coarse(app);
  pmg::tools::register_simulate(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const pmg::tools::Exit& e) {
    return e.code;
  } catch (const pmg::InputError& e) {
    std::cerr << "pmg: error: " << e.what() << "\n";
    return pmg::tools::kBadInput;
  } catch (const pmg::Error& e) {
    std::cerr << "pmg: error: " << e.what() << "\n";
    return pmg::tools::kSolveFailed;
  }
  return pmg::tools::kOk;
}
