// The ghost exchange of one level's numbering across MPI ranks (pmg/petsc/pcmg.hpp).
#include "pmg/petsc/pcmg.hpp"

#include "common.hpp"
#include "pmg/mpi/agreement.hpp"
#include "pmg/mpi/session.hpp"
#include "vectors.hpp"

#include <mutex>
#include <string>

namespace pmg::petsc {

using detail::check;

struct GhostExchange::Impl {
  Vec global = nullptr, local = nullptr;
  VecScatter scatter = nullptr;
  void destroy() {
    if (scatter) VecScatterDestroy(&scatter);
    for (Vec* v : {&global, &local})
      if (*v) VecDestroy(v);
  }
  ~Impl() {
    std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
    if (libraries_running()) destroy();
  }
};

GhostExchange::GhostExchange(MPI_Comm comm, index_t first, index_t owned, const std::vector<index_t>& global)
    : impl_(std::make_unique<Impl>()), owned_(owned), local_(static_cast<index_t>(global.size())) {
  detail::start();
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  mpi::agree_on_error(comm, owned < 0 || owned > local_ || first < 0
                           ? "ghost exchange: " + std::to_string(owned) + " owned nodes of " + std::to_string(local_) +
                                 " local nodes (first " + std::to_string(first) + ")"
                           : "",
                      /*input_error=*/true);
  Impl& d = *impl_;
  check(VecCreateMPI(comm, 3 * owned, PETSC_DETERMINE, &d.global), "VecCreateMPI");
  check(VecSetBlockSize(d.global, 3), "VecSetBlockSize");
  PetscInt start = 0;
  check(VecGetOwnershipRange(d.global, &start, nullptr), "VecGetOwnershipRange");
  mpi::agree_on_error(comm, start != 3 * first ? "ghost exchange: the rank's first owned node " + std::to_string(first) +
                                                " is not where its ranks' owned counts put it (" +
                                                std::to_string(start / 3) + ")"
                                          : "",
                      /*input_error=*/true);
  check(VecCreateSeq(PETSC_COMM_SELF, 3 * local_, &d.local), "VecCreateSeq");
  OwnedIS is;
  check(ISCreateBlock(PETSC_COMM_SELF, 3, local_, global.data(), PETSC_COPY_VALUES, &is.object), "ISCreateBlock");
  check(VecScatterCreate(d.global, is.object, d.local, nullptr, &d.scatter), "VecScatterCreate");
}

GhostExchange::~GhostExchange() = default;

void GhostExchange::to_local(const Vector& owned, Vector& local) const {
  if (owned.size() != owned_size())
    throw InputError("ghost exchange: " + std::to_string(owned.size()) + " owned values for " +
                     std::to_string(owned_size()) + " owned unknowns");
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  const Impl& d = *impl_;
  copy_in(owned, d.global);
  check(VecScatterBegin(d.scatter, d.global, d.local, INSERT_VALUES, SCATTER_FORWARD), "VecScatterBegin");
  check(VecScatterEnd(d.scatter, d.global, d.local, INSERT_VALUES, SCATTER_FORWARD), "VecScatterEnd");
  copy_out(d.local, local);
}

void GhostExchange::add_to_owners(const Vector& local, Vector& owned) const {
  if (local.size() != local_size())
    throw InputError("ghost exchange: " + std::to_string(local.size()) + " local values for " +
                     std::to_string(local_size()) + " local unknowns");
  std::lock_guard<std::recursive_mutex> lock(mpi::library_lock());
  const Impl& d = *impl_;
  copy_in(local, d.local);
  check(VecSet(d.global, 0.0), "VecSet");
  check(VecScatterBegin(d.scatter, d.local, d.global, ADD_VALUES, SCATTER_REVERSE), "VecScatterBegin");
  check(VecScatterEnd(d.scatter, d.local, d.global, ADD_VALUES, SCATTER_REVERSE), "VecScatterEnd");
  copy_out(d.global, owned);
}

}  // namespace pmg::petsc
