#include "pmg/mpi/agreement.hpp"

#include "pmg/mpi/session.hpp"

#include <algorithm>
#include <climits>
#include <cstdio>
#include <mutex>

namespace pmg::mpi {

namespace {

/// The items as one byte string: name and value, each with its length, so that no two different
/// lists serialise alike.
std::string serialise(const std::vector<Item>& items) {
  std::string s;
  for (const Item& it : items) {
    for (const std::string* t : {&it.name, &it.value}) {
      s += std::to_string(t->size());
      s += ':';
      s += *t;
    }
  }
  return s;
}

std::string shown(const std::string& value) {
  if (value.size() < 80) return "'" + value + "'";
  return "a value of " + std::to_string(value.size()) + " characters, digest " + digest(value.data(), value.size());
}

/// `text` of rank `root` on every rank.
std::string broadcast(MPI_Comm comm, const std::string& text, int root) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  unsigned long long length = text.size();
  MPI_Bcast(&length, 1, MPI_UNSIGNED_LONG_LONG, root, comm);
  std::string out(static_cast<std::size_t>(length), '\0');
  if (rank == root) out = text;
  for (std::size_t done = 0; done < out.size();) {  // in pieces below INT_MAX
    const int piece = static_cast<int>(std::min<std::size_t>(out.size() - done, 1u << 30));
    MPI_Bcast(out.data() + done, piece, MPI_CHAR, root, comm);
    done += static_cast<std::size_t>(piece);
  }
  return out;
}

/// The lowest rank for which `mine` is true, or -1.
int lowest_rank(MPI_Comm comm, bool mine) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  int candidate = mine ? rank : INT_MAX, lowest = INT_MAX;
  MPI_Allreduce(&candidate, &lowest, 1, MPI_INT, MPI_MIN, comm);
  return lowest == INT_MAX ? -1 : lowest;
}

}  // namespace

void Digest::add(const void* data, std::size_t bytes) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < bytes; ++i) {
    h_ ^= p[i];
    h_ *= 1099511628211ull;
  }
}

std::string Digest::hex() const {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h_));
  return buf;
}

std::string digest(const void* data, std::size_t bytes) {
  Digest d;
  d.add(data, bytes);
  return d.hex();
}

std::string digest(const Vector& v) {
  const auto n = static_cast<std::uint64_t>(v.size());
  Digest d;
  d.add(&n, sizeof n);
  d.add(v.data(), sizeof(double) * static_cast<std::size_t>(v.size()));
  return d.hex();
}

void check_agreement(MPI_Comm comm, const std::vector<Item>& items, const std::string& context) {
  std::string message;
  {
    std::lock_guard<std::recursive_mutex> lock(library_lock());
    int size = 1;
    MPI_Comm_size(comm, &size);
    if (size < 2) return;
    const std::string mine = serialise(items);
    Digest d;
    d.add(mine.data(), mine.size());
    const unsigned long long h = d.value();
    // Equal digests on every rank: min(h) == max(h), the max read as ~min(~h).
    unsigned long long local[2] = {h, ~h}, reduced[2] = {0, 0};
    MPI_Allreduce(local, reduced, 2, MPI_UNSIGNED_LONG_LONG, MPI_MIN, comm);
    if (reduced[0] == ~reduced[1]) return;
    // They differ: rank 0's items to every rank, each finds its first difference, the lowest
    // rank that differs describes it to all.
    const std::string first = broadcast(comm, mine, 0);
    std::vector<Item> zero;
    for (std::size_t at = 0; at < first.size();) {  // parse rank 0's serialisation
      std::string fields[2];
      for (std::string& f : fields) {
        const std::size_t colon = first.find(':', at);
        const std::size_t n = std::stoull(first.substr(at, colon - at));
        f = first.substr(colon + 1, n);
        at = colon + 1 + n;
      }
      zero.push_back({fields[0], fields[1]});
    }
    int rank = 0;
    MPI_Comm_rank(comm, &rank);
    const std::string me = "rank " + std::to_string(rank);
    std::string mismatch;
    for (std::size_t i = 0; i < std::max(zero.size(), items.size()); ++i) {
      const Item* z = i < zero.size() ? &zero[i] : nullptr;
      const Item* m = i < items.size() ? &items[i] : nullptr;
      if (z && m && z->name == m->name && z->value == m->value) continue;
      const auto holds = [](const std::vector<Item>& list, const std::string& name) {
        return std::any_of(list.begin(), list.end(), [&](const Item& it) { return it.name == name; });
      };
      if (z && m && z->name != m->name) {
        if (!holds(zero, m->name))  // given on this rank only
          mismatch = "the ranks disagree on " + m->name + ": rank 0 lacks it, " + me + " has " + shown(m->value);
        else if (!holds(items, z->name))  // given on rank 0 only
          mismatch = "the ranks disagree on " + z->name + ": rank 0 has " + shown(z->value) + ", " + me + " lacks it";
        else
          mismatch = "the ranks disagree on what is given: rank 0 has " + z->name + " where " + me + " has " + m->name;
      } else
        mismatch = "the ranks disagree on " + (z ? z->name : m->name) + ": rank 0 " +
                   (z ? "has " + shown(z->value) : std::string("lacks it")) + ", " + me + " " +
                   (m ? "has " + shown(m->value) : std::string("lacks it"));
      break;
    }
    const int culprit = lowest_rank(comm, !mismatch.empty());
    message = broadcast(comm, mismatch, culprit < 0 ? 0 : culprit);
    if (message.empty()) message = "the ranks disagree on what they were given";
  }
  throw InputError(context + ": " + message + " (every rank must be given the same input)");
}

void agree_on_error(MPI_Comm comm, const std::string& error, bool input_error) {
  std::string message;
  int culprit = -1, rank = 0, kind = 0;
  {
    std::lock_guard<std::recursive_mutex> lock(library_lock());
    int size = 1;
    MPI_Comm_size(comm, &size);
    if (size < 2) {
      if (error.empty()) return;
      if (input_error) throw InputError(error);
      throw Error(error);
    }
    MPI_Comm_rank(comm, &rank);
    culprit = lowest_rank(comm, !error.empty());
    if (culprit < 0) return;
    message = broadcast(comm, error, culprit);
    kind = input_error ? 1 : 0;
    MPI_Bcast(&kind, 1, MPI_INT, culprit, comm);
  }
  // (Named once: a message that names its rank already, from a nested together(), stays.)
  if (rank != culprit && message.rfind("rank ", 0) != 0) message = "rank " + std::to_string(culprit) + ": " + message;
  if (kind == 1) throw InputError(message);
  throw Error(message);
}

void together(MPI_Comm comm, const std::function<void()>& f) {
  std::string error;
  bool input_error = false;
  try {
    f();
  } catch (const InputError& e) {
    error = e.what();
    input_error = true;
  } catch (const std::exception& e) {
    error = e.what();
    if (error.empty()) error = "unknown failure";
  }
  agree_on_error(comm, error, input_error);
}

}  // namespace pmg::mpi
