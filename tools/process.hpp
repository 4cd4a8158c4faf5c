// tools/process.hpp — running a helper program (TetGen, the plotting and rendering scripts) without
// a shell, and the temporary folder it works in.
#pragma once

#include "pmg/sparse/types.hpp"

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace pmg::tools {

/// A temporary folder for a helper program's files (a plot's data, TetGen's runs, a log), created
/// at once and removed with its contents when it goes out of scope, on every way out (errors,
/// Ctrl-C).
struct ScratchDir {
  std::filesystem::path path;
  /// A new folder named `base` plus six random characters (mkdtemp: created with mode 0700, never
  /// an existing folder or a link planted under that name). Throws Error when none can be made.
  explicit ScratchDir(const std::filesystem::path& base) {
    std::string name = base.string() + "_XXXXXX";
    if (!::mkdtemp(name.data())) throw Error("cannot create a temporary folder " + name + ": " + std::strerror(errno));
    path = name;
  }
  ~ScratchDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path, ignored);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
};

/// Runs argv[0] (searched on PATH when it has no '/') with the arguments argv[1..], no shell in
/// between: paths and titles reach the program byte for byte, whatever quotes or ';' they hold.
/// Standard output and error go to `log` (created or truncated) when it is non-empty. As system(),
/// this process ignores SIGINT and SIGQUIT until the program ends (the program gets them). Returns the
/// wait status as system() does (WIFEXITED / WEXITSTATUS / WIFSIGNALED apply), or -1 when the
/// program could not be started.
int run_program(const std::vector<std::string>& argv, const std::string& log = "");

/// The last `lines` lines of a text file ("" when it cannot be read), for error messages that
/// must not point at a file about to be removed.
std::string tail_of_file(const std::string& path, int lines);

}  // namespace pmg::tools
