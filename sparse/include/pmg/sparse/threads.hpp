// pmg/sparse/threads.hpp — how many OpenMP threads a solve or a time step runs on.
//
// pmgkit's cycles run many short parallel regions, each ending in a barrier. When another process
// keeps one of the cores busy, a team as large as the core count waits at every barrier for the
// thread the scheduler has set aside, and a solve that takes 2 s on a quiet 2-core machine takes
// 5–50 s (libgomp's threads spin while they wait, which makes it worse; a passive wait costs
// 15–25% on a quiet machine instead). The adaptive policy (the default) therefore sizes each solve
// and each time step to the cores that are free when it starts:
//
//   threads = clamp(cpus - others, 1, max)
//
// with max the OpenMP maximum of the calling thread (OMP_NUM_THREADS, --threads,
// omp_set_num_threads()), cpus the CPUs of the process's affinity mask, and others the runnable
// threads of other processes at that moment (Linux: the running count of /proc/loadavg less this
// process's running threads in /proc/self/task). The count is taken where it is meaningful: where
// the process may run on every online CPU (a whole machine or VM); under a CPU set smaller than
// the machine (a container, a batch job's share) the system-wide count says nothing of the CPUs
// the process has, and max is used. PMG_THREADS=fixed (or set_thread_policy()) always uses max.
//
// A load that starts during a solve is not seen until the next one.
#pragma once

namespace pmg {

/// How a solve or a time step chooses its thread count (see the file comment).
enum class ThreadPolicy {
  adaptive,  ///< each solve and time step on the cores free when it starts (the default)
  fixed      ///< always the OpenMP maximum
};

/// The process-wide policy; the default is PMG_THREADS (adaptive or fixed) when set, else adaptive.
/// An unknown PMG_THREADS value is an InputError at the first solve.
ThreadPolicy thread_policy();
/// Sets the process-wide policy (overrides PMG_THREADS).
void set_thread_policy(ThreadPolicy policy);

/// Runnable threads of other processes now, where that can be known (see the file comment); -1
/// where it cannot.
int other_runnable_threads();

/// For the lifetime of the object, the calling thread's OpenMP maximum lowered to the cores free
/// now (adaptive policy; see the file comment), restored on destruction. Only the outermost budget
/// of a thread counts: one opened inside another (a solve inside a time step) keeps the outer one's
/// count.
class ThreadBudget {
 public:
  ThreadBudget();
  ~ThreadBudget();
  ThreadBudget(const ThreadBudget&) = delete;
  ThreadBudget& operator=(const ThreadBudget&) = delete;
  /// The threads this budget runs on.
  int threads() const { return threads_; }

 private:
  int restore_ = 0;  ///< the maximum to restore (0: nothing to restore)
  int threads_ = 1;
  bool outer_ = false;
};

}  // namespace pmg
