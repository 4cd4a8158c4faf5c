// pmg — the pmgkit command-line tool. Each subcommand lives in its own file (commands.hpp).
#include "commands.hpp"

#include "pmg/sparse/monitor.hpp"

#include <iostream>

int main(int argc, char** argv) {
  CLI::App app{"pmgkit: block-sparse formats, Krylov and direct solvers, p-multigrid"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "pmgkit 0.1.0");
  pmg::tools::register_compare(app);
  pmg::tools::register_mesh(app);
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
