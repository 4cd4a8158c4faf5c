// pmg render — PNG stills and an animated GIF of a simulation's frames, drawn by the Python
// renderer (python/pmgkit/_render.py, installed to share/pmgkit) from an output folder of
// `pmg simulate` (its .pvd, .vtu or .pvtu frames) or from one such file. `pmg simulate --render`
// runs the same at the end of a run, into OUTPUT/render/.
//
//   1. Check the source (a folder holding frames, or a .vtu file) and make the output folder,
//      before the renderer starts.
//   2. Run `/usr/bin/python3 _render.py SOURCE -o OUTDIR ...` without a shell, its output in a
//      temporary log.
//   3. Print what it wrote; a failure is one error line, the renderer's last line in it (exit 1).
#include "commands.hpp"
#include "process.hpp"

#include "pmg/mpi/session.hpp"
#include "pmg/sparse/file_io.hpp"
#include "pmg/sparse/types.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

namespace pmg::tools {

namespace {

namespace fs = std::filesystem;

/// --size WxH: two whole numbers of pixels from 16 to 10000.
CLI::Validator ImageSize() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        const size_t x = text.find('x');
        auto pixels = [](const std::string& n) {
          if (n.empty() || n.size() > 5 || n.find_first_not_of("0123456789") != std::string::npos)
            return false;
          const int v = std::stoi(n);
          return v >= 16 && v <= 10000;
        };
        if (x == std::string::npos || !pixels(text.substr(0, x)) || !pixels(text.substr(x + 1)))
          return "'" + text + "' is not WIDTHxHEIGHT in pixels (16 to 10000 each, e.g. 800x600)";
        return {};
      },
      "WxH");
}

/// A line of the renderer's output as an error message shows it: control characters as '?'.
std::string one_line(std::string text) {
  for (char& c : text)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  return text;
}

/// The source checked before the renderer starts: a folder must hold frames, a file must be one.
void check_source(const std::string& source) {
  auto frames = [](const fs::path& p) {
    const std::string ext = p.extension().string();
    return ext == ".pvd" || ext == ".vtu" || ext == ".pvtu";
  };
  std::error_code ec;
  if (fs::is_directory(source, ec)) {
    for (const auto& entry : fs::directory_iterator(source, ec))
      if (frames(entry.path())) return;
    throw InputError(source + ": no frames in this folder (.pvd, .vtu or .pvtu: pmg simulate -o " +
                     source + " writes them)");
  }
  if (!frames(source))
    throw InputError(
        source + ": expected an output folder of pmg simulate, or one .pvd, .vtu or .pvtu file");
}

}  // namespace

void render_frames(const std::string& source, const std::string& outdir, const RenderOptions& o) {
  const std::string script = find_data_file("_render.py");
  std::vector<std::string> argv = {"/usr/bin/python3", script, source, "-o", outdir,
                                   "--field",          o.field};
  if (o.every > 0) argv.insert(argv.end(), {"--every", std::to_string(o.every)});
  if (!o.size.empty()) argv.insert(argv.end(), {"--size", o.size});
  if (!o.gif) argv.push_back("--no-gif");
  const ScratchDir scratch(fs::temp_directory_path() /
                           ("pmg_render_" + std::to_string(::getpid())));
  const std::string log = (scratch.path / "render.log").string();
  const int rc = run_program(argv, log);
  if (rc == -1) throw Error("render: /usr/bin/python3 could not be started (apt install python3)");
  // Ctrl-C reaches the renderer too (the same process group): it ends with SIGINT.
  if ((WIFSIGNALED(rc) && WTERMSIG(rc) == SIGINT) ||
      (WIFEXITED(rc) && WEXITSTATUS(rc) == 128 + SIGINT)) {
    std::cout << std::flush;
    std::cerr << "pmg: interrupted: rendering stopped; the stills written so far are in " << outdir
              << "\n";
    throw Exit{kInterrupted};
  }
  if (!WIFEXITED(rc) || WEXITSTATUS(rc) != 0) {
    std::string last = tail_of_file(log, 1);  // the renderer's one line: "render: error: ..."
    if (last.rfind("render: error: ", 0) == 0) last.erase(0, std::string("render: error: ").size());
    // Exit 2 is the renderer's bad input (a frame it cannot read, a field the frames lack): bad
    // input here too.
    if (WIFEXITED(rc) && WEXITSTATUS(rc) == 2 && !last.empty()) throw InputError(source + ": " + one_line(last));
    throw Error("render failed" + (last.empty() ? std::string() : ": " + one_line(last)) + " (" +
                script + ", " +
                (WIFSIGNALED(rc) ? "killed by signal " + std::to_string(WTERMSIG(rc))
                                 : "exit status " + std::to_string(WEXITSTATUS(rc))) +
                ")");
  }
  std::ifstream in(log);  // what it wrote: the stills and the animation
  for (std::string line; std::getline(in, line);) std::cout << line << "\n";
}

void register_render(CLI::App& app) {
  struct Args {
    std::string source, output;
    RenderOptions render;
  };
  auto a = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand(
      "render",
      "PNG stills and an animated GIF of a simulation's frames (an output folder of pmg simulate, "
      "or one .pvd, .vtu or .pvtu file)");
  sub->add_option("source", a->source,
                  "output folder of pmg simulate (its frames), or one .pvd, .vtu or .pvtu file")
      ->required()
      ->check(CLI::ExistingPath);
  sub->add_option("-o,--output", a->output,
                  "write OUTDIR/frame_XXXX.png and OUTDIR/animation.gif here")
      ->required();
  sub->add_option("--field", a->render.field, "colour by this field")
      ->check(CLI::IsMember({"displacement", "von_mises", "pressure"}))
      ->capture_default_str();
  sub->add_option("--every", a->render.every,
                  "render every k-th frame (default: at most about 50 stills)")
      ->check(CLI::Range(1, 1000000000));
  sub->add_option("--size", a->render.size, "image size in pixels (default: 800x600)")
      ->check(ImageSize());
  sub->add_flag("!--no-gif", a->render.gif, "stills only, no animated GIF");
  sub->callback([a] {
    check_source(a->source);
    prepare_output_directory(a->output, "-o");
    // Under mpirun rank 0 renders; the other ranks have nothing to do.
    if (mpi::launched_rank() != 0) return;
    render_frames(a->source, a->output, a->render);
  });
}

}  // namespace pmg::tools
