// pmg — the pmgkit command-line tool. Each subcommand lives in its own file (commands.hpp).
#include "pmg/sparse/text_reader.hpp"
#include "commands.hpp"

#include "pmg/mpi/session.hpp"
#include "pmg/solvers.hpp"
#include "pmg/sparse/monitor.hpp"

#include <cerrno>
#include <omp.h>
#include <sched.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <new>
#include <string>
#include <thread>

#include <sys/auxv.h>
#include <unistd.h>

namespace pmg::tools {

std::string find_data_file(const std::string& name) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = exe.parent_path().parent_path() / "share" / "pmgkit" / name;
    if (fs::exists(installed)) return installed.string();
  }
  // The source tree: the tools' scripts, and the Python package's (_render.py).
  for (const char* dir : {PMG_TOOLS_SOURCE_DIR, PMG_PYTHON_SOURCE_DIR}) {
    const fs::path source = fs::path(dir) / name;
    if (fs::exists(source)) return source.string();
  }
  throw Error("data file " + name +
              " not found (looked in share/pmgkit, " PMG_TOOLS_SOURCE_DIR " and " PMG_PYTHON_SOURCE_DIR ")");
}

/// CLI11's help writes a flag that stores a value other than true (a "!"-negated one) with that
/// value after its name ("--no-reference{false}"), which reads as a default of false. pmg's flags
/// take no value, so their names are written bare.
class HelpFormatter : public CLI::Formatter {
 public:
  std::string make_option_name(const CLI::Option* opt, bool is_positional) const override {
    std::string name = CLI::Formatter::make_option_name(opt, is_positional);
    if (is_positional || opt->get_items_expected_max() != 0) return name;  // options that take values
    for (size_t open = name.find('{'); open != std::string::npos; open = name.find('{', open)) {
      const size_t close = name.find('}', open);
      if (close == std::string::npos) break;
      name.erase(open, close - open + 1);
    }
    return name;
  }
};

/// An error message for the command line: the solver registry's unknown-method message ends with
/// a hint for C++ callers (which function registers which methods); on the command line, `pmg
/// solvers` is the list to look at.
std::string for_the_command_line(std::string message) {
  const size_t cpp = message.find("pmg::register_all_solvers()");
  if (message.find("unknown method '") == std::string::npos || cpp == std::string::npos) return message;
  const size_t from = message.rfind("; ", cpp);
  const char* last = "register_solvers()";
  const size_t to = message.find(last, cpp + 1);
  if (from == std::string::npos || to == std::string::npos) return message;
  return message.replace(from, to + std::strlen(last) - from, "; pmg solvers lists them with their keys");
}

/// Transparent huge pages for the process's heap, where the kernel offers them on request
/// (/sys/kernel/mm/transparent_hugepage/enabled is "madvise"): glibc's tunable
/// glibc.malloc.hugetlb=1 makes malloc ask for them, so a large model's arrays (and those hypre
/// and CHOLMOD allocate inside their set-ups) fault in 2 MiB pages instead of 4 KiB ones
/// (docs/scaling.md: the set-up at 2.3M unknowns about halved). Tunables are read when a process
/// starts, so the tool re-executes itself once with the tunable added, marked by
/// PMG_HUGEPAGES_REEXEC so that it never does so twice. Nothing happens when the user set
/// glibc.malloc.hugetlb (either way), set PMG_HUGEPAGES=0, THP is "always" or "never", the process
/// runs with elevated privileges (AT_SECURE: glibc ignores the tunable there), /proc/self/exe is
/// the dynamic loader (started as `ld.so pmg ...`), or the re-execution fails (the run then goes
/// on as it is).
void use_transparent_huge_pages(char** argv) {
  if (std::getenv("PMG_HUGEPAGES_REEXEC")) {  // this is the re-executed process
    unsetenv("PMG_HUGEPAGES_REEXEC");
    return;
  }
  const char* opt_out = std::getenv("PMG_HUGEPAGES");
  if (opt_out && std::strcmp(opt_out, "0") == 0) return;
  if (getauxval(AT_SECURE)) return;
  std::error_code ec;
  const std::string exe = std::filesystem::read_symlink("/proc/self/exe", ec).filename().string();
  if (ec || exe.rfind("ld-", 0) == 0 || exe.rfind("ld.so", 0) == 0) return;
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  const std::string current = tunables ? tunables : "";
  if (current.find("glibc.malloc.hugetlb") != std::string::npos) return;
  std::ifstream thp("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string mode;
  std::getline(thp, mode);
  if (mode.find("[madvise]") == std::string::npos) return;
  const std::string value = current.empty() ? "glibc.malloc.hugetlb=1" : current + ":glibc.malloc.hugetlb=1";
  if (setenv("GLIBC_TUNABLES", value.c_str(), 1) != 0) return;
  setenv("PMG_HUGEPAGES_REEXEC", "1", 1);
  execv("/proc/self/exe", argv);
  // Not re-executed: go on without, and leave the environment as it was for child processes.
  unsetenv("PMG_HUGEPAGES_REEXEC");
  if (tunables) setenv("GLIBC_TUNABLES", current.c_str(), 1);
  else unsetenv("GLIBC_TUNABLES");
}

/// Under mpirun with several ranks: MPI started at once (so that any rank's failure can end the
/// job), rank 0 alone printing to standard output, and unless OMP_NUM_THREADS says otherwise each
/// rank running cores / ranks-on-this-machine OpenMP threads (--threads still overrides), so that
/// ranks x threads never exceed the cores the job was given.
void start_ranks() {
  if (mpi::launched_ranks() < 2) return;
  mpi::start();
  if (mpi::launched_rank() != 0 && !std::freopen("/dev/null", "w", stdout))
    throw Error("cannot silence standard output on rank " + std::to_string(mpi::launched_rank()));
  if (!std::getenv("OMP_NUM_THREADS")) {
    cpu_set_t set;
    const int cores = sched_getaffinity(0, sizeof(set), &set) == 0 ? CPU_COUNT(&set)
                                                                   : static_cast<int>(std::thread::hardware_concurrency());
    omp_set_num_threads(std::max(1, cores / mpi::launched_local_ranks()));
  }
}

/// The one error line, and under mpirun the end of every rank: rank 0 prints and ends the job;
/// another rank waits a moment first (when rank 0 fails too, its message is the only one), then
/// prints naming itself and ends the job. Either waits half a second after printing, so that
/// mpirun has forwarded the line before the abort ends the job.
int fail(int code, const std::string& line) {
  if (mpi::launched_ranks() < 2) {
    std::cerr << line;
    return code;
  }
  const int rank = mpi::launched_rank();
  if (rank != 0) {
    std::this_thread::sleep_for(std::chrono::seconds(2));
    std::cerr << "(rank " << rank << ") ";
  }
  std::cerr << line << std::flush;
  // The line is in the pipe to mpirun, which forwards it asynchronously; MPI_Abort right away can
  // end the job before mpirun has read it (the message then lost under load). A pause lets it
  // arrive first.
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  mpi::abort(code);
}

}  // namespace pmg::tools

int main(int argc, char** argv) {
  pmg::tools::use_transparent_huge_pages(argv);
  using pmg::tools::fail;
  // OMP_NUM_THREADS as --threads takes it (1 to 1024 per item of a nested list, blanks around a
  // number allowed, an empty value ignored as OpenMP ignores it), checked before the first parallel
  // region: OpenMP itself ignores a bad value with a warning and tries to start any number of threads.
  if (const char* env = std::getenv("OMP_NUM_THREADS")) {
    const std::string all(env);
    bool ok = true;
    if (all.find_first_not_of(" \t") != std::string::npos) {
      for (size_t start = 0; ok && start <= all.size();) {
        const size_t comma = std::min(all.find(',', start), all.size());
        const std::string item = all.substr(start, comma - start);
        const size_t b = item.find_first_not_of(" \t"), e = item.find_last_not_of(" \t");
        const std::string num = b == std::string::npos ? "" : item.substr(b, e - b + 1);
        char* end = nullptr;
        errno = 0;
        const long n = num.empty() ? 0 : std::strtol(num.c_str(), &end, 10);
        ok = !num.empty() && num.find_first_not_of("0123456789") == std::string::npos && errno == 0 && n >= 1 && n <= 1024;
        start = comma + 1;
      }
    }
    if (!ok)
      return fail(pmg::tools::kBadInput, "pmg: error: OMP_NUM_THREADS='" + pmg::printable(env) +
                                             "': expected a whole number of threads from 1 to 1024 (or a list of them)\n");
  }
  try {
    pmg::tools::start_ranks();
  } catch (const std::exception& e) {
    return fail(pmg::tools::kSolveFailed, std::string("pmg: error: ") + e.what() + "\n");
  }
  CLI::App app{"pmgkit: block-sparse formats, Krylov and direct solvers, p-multigrid"};
  app.formatter(std::make_shared<pmg::tools::HelpFormatter>());  // before the subcommands: they copy it
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
  pmg::tools::register_render(app);
  // The one error path: every failure becomes one "pmg: error:" line and a non-zero exit, never
  // an abort. Input errors (bad files, options, meshes; every option CLI11 refuses while parsing)
  // exit 2; failed solves and everything else exit 1.
  const std::string command = argc > 1 ? std::string("pmg ") + argv[1] : "pmg";
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    // CLI11's own codes (105-114) would say nothing a script can act on: a refused option is bad
    // input like any other. The help to read is the subcommand's where one was named.
    std::string help = "pmg --help";
    if (argc > 1) {
      try {
        help = "pmg " + app.get_subcommand(std::string(argv[1]))->get_name() + " --help";
      } catch (const CLI::Error&) {  // argv[1] is not a subcommand
      }
    }
    return fail(pmg::tools::kBadInput, std::string("pmg: error: ") + e.what() + " (options: " + help + ")\n");
  } catch (const pmg::tools::Exit& e) {
    return e.code;
  } catch (const pmg::InputError& e) {
    return fail(pmg::tools::kBadInput, "pmg: error: " + pmg::tools::for_the_command_line(e.what()) + "\n");
  } catch (const pmg::Error& e) {
    return fail(pmg::tools::kSolveFailed, "pmg: error: " + pmg::tools::for_the_command_line(e.what()) + "\n");
  } catch (const std::bad_alloc&) {
    return fail(pmg::tools::kSolveFailed, "pmg: error: " + command +
                                              ": out of memory (the problem is larger than this machine can hold; try a smaller size)\n");
  } catch (const std::filesystem::filesystem_error& e) {
    return fail(pmg::tools::kBadInput, "pmg: error: " + command + ": " + e.what() + "\n");
  } catch (const std::exception& e) {
    return fail(pmg::tools::kSolveFailed, "pmg: error: " + command + ": unexpected failure: " + e.what() + "\n");
  } catch (...) {
    return fail(pmg::tools::kSolveFailed, "pmg: error: " + command + ": unexpected failure of unknown type\n");
  }
  return pmg::tools::kOk;
}
