// The pmg command's subcommands: each registers its options and its callback on the app.
#pragma once

#include <CLI/CLI.hpp>

#include <csignal>
#include <string>

namespace pmg::tools {

/// pmg solvers: every registered method with its keys, defaults and descriptions (text or the
/// Markdown of docs/solvers.md).
void register_solvers(CLI::App& app);
/// The registered method names, comma-separated (for help texts).
std::string method_list();
/// pmg compare: run several solvers on one system, write the residual history, print a table.
void register_compare(CLI::App& app);
/// pmg mesh: closed surface to tetrahedral mesh (TetGen), or statistics of a mesh file.
void register_mesh(CLI::App& app);
/// pmg coarse: geometric vs Galerkin coarse operators (Table 2.8).
void register_coarse(CLI::App& app);
/// pmg simulate: implicit-Euler simulation of a JSON scene (default: the built-in cantilever).
void register_simulate(CLI::App& app);
/// pmg render: PNG stills and an animated GIF of a simulation's frames (python/pmgkit/render.py).
void register_render(CLI::App& app);

/// What pmg render and pmg simulate --render pass to render.py.
struct RenderOptions {
  std::string field = "displacement";  ///< displacement | von_mises | pressure
  int every = 0;                        ///< every k-th frame; 0: the renderer's (at most ~50 stills)
  std::string size;                     ///< WxH pixels; empty: the script's default
  bool gif = true;                      ///< also write OUTDIR/animation.gif
};
/// Runs `/usr/bin/python3 render.py SOURCE -o OUTDIR ...` (SOURCE: an output folder of pmg
/// simulate, or one .pvd, .vtu or .pvtu file) and prints what it wrote. Throws Error with the
/// script's last line when it fails (the caller's one error line, exit 1).
void render_frames(const std::string& source, const std::string& outdir, const RenderOptions& o);

/// Path of a data file shipped with the tools (installed share/pmgkit/, else the source tree).
std::string find_data_file(const std::string& name);

/// Exit codes shared by every subcommand.
/// kInterrupted: 128 + SIGINT, the shell's convention for a run ended by Ctrl-C.
enum ExitCode : int { kOk = 0, kSolveFailed = 1, kBadInput = 2, kInterrupted = 130 };

/// From now on SIGINT (Ctrl-C) only sets a flag, which the subcommand reads between steps to stop
/// with its outputs complete (and its temporary files removed); a second SIGINT ends the process
/// at once (the default action is restored by the first).
void catch_interrupt();
/// The flag catch_interrupt() arms: non-zero after a SIGINT.
const volatile std::sig_atomic_t* interrupt_flag();
/// True after a SIGINT since catch_interrupt().
bool interrupted();

/// Thrown by a subcommand that has reported its outcome and wants this exit code.
struct Exit {
  int code;
};

}  // namespace pmg::tools
