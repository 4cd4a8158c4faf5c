// pmg/mpi/session.hpp — MPI's lifetime in a pmgkit process: the one place that starts and ends
// it, shared by the adapters that need it (hypre's BoomerAMG, PETSc).
//
// MPI is started on first use (MPI_Init when nobody has: one rank, or under mpirun the job's
// ranks). A program that initialised MPI itself keeps it: pmgkit then neither starts nor ends it.
// When pmgkit started it, MPI is finalised at exit, after the finalisers registered with
// at_finalize() (PETSc's, which must run while MPI is still up) in reverse order of registration.
//
// Threads: MPI is started at MPI_THREAD_SERIALIZED (any thread may call it, one at a time), and
// library_lock() is the one lock that makes it so: every call into MPI or into a library built on
// it (PETSc with MUMPS, hypre: they keep process-wide state) holds it.
#pragma once

#include <functional>
#include <mutex>

namespace pmg::mpi {

/// Starts MPI if it is not running; returns the seconds this call took (about 0 when it was).
double start();
/// Rank of this process in MPI_COMM_WORLD (starting MPI if needed).
int rank();
/// Number of ranks of MPI_COMM_WORLD (starting MPI if needed).
int size();
/// Runs `finalize` at exit, before MPI_Finalize when pmgkit owns MPI. When the program owns MPI
/// it runs at exit too, possibly after the program's MPI_Finalize: a finaliser checks
/// MPI_Finalized before it calls MPI.
void at_finalize(std::function<void()> finalize);
/// The ranks of the job this process was launched in: MPI_COMM_WORLD's size once MPI runs, else
/// read from the launcher's environment without starting MPI (Open MPI's OMPI_COMM_WORLD_SIZE,
/// PMI_SIZE or SLURM_STEP_NUM_TASKS); 1 outside a launcher.
int launched_ranks();
/// This process's rank in its launch: MPI_COMM_WORLD's once MPI runs, else from the environment
/// (OMPI_COMM_WORLD_RANK, PMI_RANK, PMIX_RANK or SLURM_PROCID); 0 outside a launcher.
int launched_rank();
/// Ranks of the launch on this machine (OMPI_COMM_WORLD_LOCAL_SIZE, else launched_ranks()).
int launched_local_ranks();
/// Ends every rank of the job with `code` (MPI_Abort; MPI started first if needed): the one way
/// out of a collective that another rank will never reach.
[[noreturn]] void abort(int code);
/// The process-wide lock held around every call into MPI, PETSc and hypre (see the file comment).
/// Recursive: an adapter's call may reach another that takes it.
std::recursive_mutex& library_lock();

}  // namespace pmg::mpi
