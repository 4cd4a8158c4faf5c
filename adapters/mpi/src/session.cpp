#include "pmg/mpi/session.hpp"

#include <mpi.h>

#include <chrono>
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

void at_finalize(std::function<void()> finalize) {
  Session& s = session();
  std::lock_guard<std::mutex> lock(s.mutex);
  s.finalizers.push_back(std::move(finalize));
}

}  // namespace pmg::mpi
