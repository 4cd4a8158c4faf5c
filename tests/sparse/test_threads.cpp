// The adaptive thread budget (pmg/sparse/threads.hpp).
#include "pmg/sparse/threads.hpp"

#include <catch2/catch.hpp>
#include <omp.h>

#include <chrono>
#include <csignal>
#include <spawn.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

extern char** environ;

using namespace pmg;

namespace {
/// The process-wide policy, restored at the end of a test.
struct KeepPolicy {
  ThreadPolicy kept = thread_policy();
  ~KeepPolicy() { set_thread_policy(kept); }
};
/// A child process kept busy until this object ends.
struct BusyProcess {
  pid_t pid = 0;
  BusyProcess() {
    char sh[] = "/bin/sh", c[] = "-c", loop[] = "while :; do :; done";
    char* argv[] = {sh, c, loop, nullptr};
    if (posix_spawn(&pid, "/bin/sh", nullptr, nullptr, argv, environ) != 0) pid = 0;
  }
  ~BusyProcess() {
    if (pid > 0) kill(pid, SIGKILL), waitpid(pid, nullptr, 0);
  }
};
}  // namespace

TEST_CASE("a thread budget restores the OpenMP maximum, and only the outermost one counts", "[threads]") {
  const KeepPolicy keep_policy;
  set_thread_policy(ThreadPolicy::adaptive);
  const int keep = omp_get_max_threads();
  omp_set_num_threads(3);
  {
    const ThreadBudget outer;
    CHECK(outer.threads() >= 1);
    CHECK(outer.threads() <= 3);
    CHECK(omp_get_max_threads() == outer.threads());
    {
      const ThreadBudget inner;  // nested: keeps the outer count
      CHECK(inner.threads() == outer.threads());
      CHECK(omp_get_max_threads() == outer.threads());
    }
    CHECK(omp_get_max_threads() == outer.threads());
  }
  CHECK(omp_get_max_threads() == 3);
  set_thread_policy(ThreadPolicy::fixed);
  omp_set_num_threads(3);
  {
    const ThreadBudget b;
    CHECK(b.threads() == 3);
    CHECK(omp_get_max_threads() == 3);
  }
  CHECK(omp_get_max_threads() == 3);
  omp_set_num_threads(keep);
}

TEST_CASE("a thread budget leaves a core to a busy process", "[threads]") {
  if (other_runnable_threads() < 0) {
    WARN("the runnable count of other processes is not known here (a CPU set smaller than the machine)");
    return;
  }
  const KeepPolicy keep_policy;
  set_thread_policy(ThreadPolicy::adaptive);
  const int cpus = static_cast<int>(sysconf(_SC_NPROCESSORS_ONLN));
  // A busy process: a shell loop, spawned (no fork of this multithreaded process).
  const BusyProcess busy;
  REQUIRE(busy.pid > 0);
  // The scheduler's count is an instant: the busy process is seen within a few samples.
  int seen = 0;
  for (int i = 0; i < 50 && seen < 1; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    seen = other_runnable_threads();
  }
  const int keep = omp_get_max_threads();
  omp_set_num_threads(cpus);
  int threads = cpus;
  for (int i = 0; i < 50 && threads == cpus; ++i) {
    const ThreadBudget b;
    threads = b.threads();
    if (threads == cpus) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  omp_set_num_threads(keep);
  CHECK(seen >= 1);
  CHECK(threads <= std::max(cpus - 1, 1));
  CHECK(threads >= 1);
}
