// pmg/mpi/agreement.hpp — ranks that agree or stop together.
//
// Two collective checks every distributed entry of pmgkit uses (the CLI under mpirun, petsc-mgpcg,
// dist::DistributedEuler, the Python module on mpi4py):
//
//  - check_agreement(comm, items, context): what must be equal on every rank (options, the mesh,
//    materials, a right-hand side) is compared collectively before any work. Equal: one
//    MPI_Allreduce of a 64-bit digest. Different: every rank throws the same InputError naming the
//    first item that differs, rank 0's value and that of the lowest rank that differs.
//  - together(comm, what, f): runs f on every rank; when it throws on any rank, every rank throws
//    (the lowest failing rank's message, its type kept: InputError stays InputError), so that no rank
//    waits in a collective call for one that left.
//
// Both are collective: every rank of `comm` must call them in the same order. They hold
// library_lock() around their MPI calls.
#pragma once

#include "pmg/sparse/types.hpp"

#include <mpi.h>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace pmg::mpi {

/// One thing that must be equal on every rank: its name (as the user knows it: "--poisson", "the
/// right-hand side") and its value, shown in the error when shorter than 80 characters (use
/// digest() for arrays).
struct Item {
  std::string name;   ///< what it is, as the user knows it ("--poisson", "the right-hand side")
  std::string value;  ///< its value on this rank (a digest for arrays)
};

/// A 64-bit FNV-1a digest built piece by piece (a file read in blocks), written as 16 hex digits.
class Digest {
 public:
  /// Adds `bytes` bytes.
  void add(const void* data, std::size_t bytes);
  /// The digest so far.
  std::uint64_t value() const { return h_; }
  /// The digest so far, as 16 hex digits.
  std::string hex() const;

 private:
  std::uint64_t h_ = 1469598103934665603ull;
};
/// The Digest of `bytes` bytes: a short value for an array.
std::string digest(const void* data, std::size_t bytes);
/// digest() of a vector's entries; empty vectors and vectors of different length differ.
std::string digest(const Vector& v);

/// Collective: throws the same InputError on every rank when `items` differ between ranks
/// ("<context>: the ranks disagree on <name>: rank 0 has <value>, rank k has <value>"), or when the
/// ranks hold different numbers of items. Returns at once on one rank.
void check_agreement(MPI_Comm comm, const std::vector<Item>& items, const std::string& context);

/// Collective: every rank learns whether `error` is non-empty on any rank. If so, every rank throws
/// the lowest such rank's error, as an InputError when that rank's `input_error` is set, else as an
/// Error; a rank other than the failing one prefixes "rank k: ".
void agree_on_error(MPI_Comm comm, const std::string& error, bool input_error = false);

/// Collective: runs `f`; if it throws a std::exception on any rank, every rank throws (see
/// agree_on_error). Exceptions that are not std::exception propagate on their rank only.
void together(MPI_Comm comm, const std::function<void()>& f);

}  // namespace pmg::mpi
