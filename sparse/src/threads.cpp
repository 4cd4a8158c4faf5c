#include "pmg/sparse/threads.hpp"

#include "pmg/sparse/types.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#if defined(__linux__)
#include <dirent.h>
#include <sched.h>
#include <unistd.h>
#endif

namespace pmg {

namespace {

/// -1: not yet read from PMG_THREADS.
std::atomic<int> g_policy{-1};

thread_local int t_depth = 0;  ///< open budgets of this thread

#if defined(__linux__)
/// The state letter of /proc/<path>/stat (the field after the parenthesised command name).
char task_state(const char* path) {
  char buf[512];
  FILE* f = std::fopen(path, "r");
  if (!f) return '?';
  const size_t n = std::fread(buf, 1, sizeof(buf) - 1, f);
  std::fclose(f);
  buf[n] = '\0';
  const char* close = std::strrchr(buf, ')');
  return close && close[1] == ' ' ? close[2] : '?';
}

/// CPUs of the process's affinity mask, and whether they are all the online CPUs.
int affinity_cpus(bool& whole_machine) {
  cpu_set_t set;
  const long online = sysconf(_SC_NPROCESSORS_ONLN);
  if (sched_getaffinity(0, sizeof(set), &set) != 0) {
    whole_machine = false;
    return online > 0 ? static_cast<int>(online) : 1;
  }
  const int cpus = CPU_COUNT(&set);
  whole_machine = online > 0 && cpus == online;
  return std::max(cpus, 1);
}
#endif

}  // namespace

ThreadPolicy thread_policy() {
  int p = g_policy.load();
  if (p < 0) {
    const char* env = std::getenv("PMG_THREADS");
    const std::string v = env ? env : "";
    if (v.empty() || v == "adaptive") p = static_cast<int>(ThreadPolicy::adaptive);
    else if (v == "fixed") p = static_cast<int>(ThreadPolicy::fixed);
    else throw InputError("PMG_THREADS=" + v + ": expected adaptive or fixed");
    g_policy.store(p);
  }
  return static_cast<ThreadPolicy>(p);
}

void set_thread_policy(ThreadPolicy policy) { g_policy.store(static_cast<int>(policy)); }

#if defined(__linux__)
namespace {
/// Runnable threads of other processes, system-wide (see other_runnable_threads()); -1 unread.
int others_system_wide() {
  // This process's running threads, counted before and after the system-wide count below and the
  // larger taken: an OpenMP worker still spinning after the last parallel region may stop in
  // between, and must not be counted as another process's.
  auto running_here = [] {
    int ours = 0;
    DIR* d = opendir("/proc/self/task");
    if (!d) return 1;
    while (const dirent* e = readdir(d)) {
      if (e->d_name[0] < '0' || e->d_name[0] > '9') continue;
      char path[300];
      std::snprintf(path, sizeof(path), "/proc/self/task/%s/stat", e->d_name);
      ours += task_state(path) == 'R';
    }
    closedir(d);
    return std::max(ours, 1);  // the calling thread runs
  };
  const int before = running_here();
  // The running count of /proc/loadavg: "0.52 0.58 0.59 3/512 12345" -> 3 (this thread included).
  FILE* f = std::fopen("/proc/loadavg", "r");
  if (!f) return -1;
  double l1, l5, l15;
  int running = 0, total = 0;
  const int got = std::fscanf(f, "%lf %lf %lf %d/%d", &l1, &l5, &l15, &running, &total);
  std::fclose(f);
  if (got != 5) return -1;
  const int ours = std::max(before, running_here());
  return std::max(running - ours, 0);
}
}  // namespace
#endif

int other_runnable_threads() {
#if defined(__linux__)
  bool whole = false;
  affinity_cpus(whole);
  return whole ? others_system_wide() : -1;
#else
  return -1;
#endif
}

ThreadBudget::ThreadBudget() {
  const ThreadPolicy policy = thread_policy();  // may throw: before this budget counts as open
  threads_ = omp_get_max_threads();
  outer_ = t_depth++ == 0;
  if (!outer_ || threads_ <= 1 || policy == ThreadPolicy::fixed) return;
#if defined(__linux__)
  bool whole = false;
  const int cpus = affinity_cpus(whole);
  if (!whole) return;  // a CPU set smaller than the machine: the system-wide count says nothing
  const int others = others_system_wide();
  if (others <= 0) return;
  const int n = std::clamp(cpus - others, 1, threads_);
  if (n < threads_) {
    restore_ = threads_;
    threads_ = n;
    omp_set_num_threads(n);
  }
#endif
}

ThreadBudget::~ThreadBudget() {
  --t_depth;
  if (restore_ > 0) omp_set_num_threads(restore_);
}

}  // namespace pmg
