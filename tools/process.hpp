// tools/process.hpp — running a helper program (TetGen, the plotting script) without a shell.
#pragma once

#include <string>
#include <vector>

namespace pmg::tools {

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
