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
      MPI_Init(nullptr, nullptr);
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

double start() {
  const auto t0 = std::chrono::steady_clock::now();
  session();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

int rank() {
  session();
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}

int size() {
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
