#include "pmg/mpi/session.hpp"

#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <mutex>
#include <vector>

namespace pmg::mpi {

namespace {

/// Initialises MPI once; at exit runs the registered finalisers, then finalises MPI if it was
/// initialised here.
struct Session {
  bool owned = false;
  std::mutex mutex;
  std::vector<std::function<void()>> finalizers;
  Session() {
    int initialized = 0;
    MPI_Initialized(&initialized);
    if (!initialized) {
      int provided = 0;
      MPI_Init_thread(nullptr, nullptr, MPI_THREAD_SERIALIZED, &provided);
      owned = true;
    }
  }
  ~Session() {
    for (auto it = finalizers.rbegin(); it != finalizers.rend(); ++it) (*it)();
    int finalized = 0;
    MPI_Finalized(&finalized);
    if (owned && !finalized) MPI_Finalize();
  }
};

Session& session() {
  static Session s;
  return s;
}

}  // namespace

std::recursive_mutex& library_lock() {
  static std::recursive_mutex lock;
  return lock;
}

double start() {
  const auto t0 = std::chrono::steady_clock::now();
  std::lock_guard<std::recursive_mutex> lock(library_lock());
  session();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

int rank() {
  std::lock_guard<std::recursive_mutex> lock(library_lock());
  session();
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}

int size() {
  std::lock_guard<std::recursive_mutex> lock(library_lock());
  session();
  int s = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &s);
  return s;
}

namespace {
int env_int(const char* a, const char* b, int fallback) {
  for (const char* name : {a, b})
    if (name)
      if (const char* v = std::getenv(name)) {
        char* end = nullptr;
        const long n = std::strtol(v, &end, 10);
        if (end != v && *end == 0 && n >= 0 && n < (1 << 24)) return static_cast<int>(n);
      }
  return fallback;
}
}  // namespace

/// MPI_COMM_WORLD's rank or size once MPI runs (any launcher), else -1.
int running(bool want_rank) {
  int initialized = 0, finalized = 0;
  MPI_Initialized(&initialized);
  MPI_Finalized(&finalized);
  if (!initialized || finalized) return -1;
  std::lock_guard<std::recursive_mutex> lock(library_lock());
  int v = -1;
  if (want_rank) MPI_Comm_rank(MPI_COMM_WORLD, &v);
  else MPI_Comm_size(MPI_COMM_WORLD, &v);
  return v;
}

int launched_ranks() {
  if (const int n = running(false); n > 0) return n;
  return std::max({1, env_int("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", 1), env_int("SLURM_STEP_NUM_TASKS", nullptr, 1)});
}
int launched_rank() {
  if (const int r = running(true); r >= 0) return r;
  return std::max(env_int("OMPI_COMM_WORLD_RANK", "PMI_RANK", 0), env_int("PMIX_RANK", "SLURM_PROCID", 0));
}
int launched_local_ranks() {
  return std::max(1, env_int("OMPI_COMM_WORLD_LOCAL_SIZE", nullptr, launched_ranks()));
}

void abort(int code) {
  start();
  MPI_Abort(MPI_COMM_WORLD, code);
  std::_Exit(code);
}

void at_finalize(std::function<void()> finalize) {
  Session& s = session();
  std::lock_guard<std::mutex> lock(s.mutex);
  s.finalizers.push_back(std::move(finalize));
}

}  // namespace pmg::mpi
