#include "ranks.hpp"

#include "pmg/mpi/agreement.hpp"
#include "pmg/mpi/session.hpp"
#include "pmg/sparse/types.hpp"

#include <fstream>
#include <vector>

namespace pmg::tools {

namespace {

/// The digest of a file's bytes, read in blocks ("missing" when it cannot be read: another rank
/// may read it).
std::string file_digest(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return "missing or unreadable";
  mpi::Digest d;
  std::vector<char> block(1 << 20);
  std::size_t total = 0;
  while (in.read(block.data(), static_cast<std::streamsize>(block.size())) || in.gcount() > 0) {
    d.add(block.data(), static_cast<std::size_t>(in.gcount()));
    total += static_cast<std::size_t>(in.gcount());
  }
  return std::to_string(total) + " bytes, digest " + d.hex();
}

}  // namespace

void agree_across_ranks(const CLI::App& sub, const std::vector<std::string>& inputs) {
  if (mpi::launched_ranks() < 2) return;
  mpi::start();
  std::vector<mpi::Item> items;
  for (const CLI::Option* opt : sub.get_options()) {
    const std::string name = opt->get_name();
    if (opt->count() == 0 || name == "--threads" || name == "--quiet" || name == "-q" || name == "--help") continue;
    std::string value;
    for (const std::string& r : opt->results()) value += (value.empty() ? "" : " ") + r;
    items.push_back({name, value});
  }
  for (const std::string& path : inputs)
    if (!path.empty()) items.push_back({"the file " + path, file_digest(path)});
  mpi::check_agreement(MPI_COMM_WORLD, items, "pmg " + sub.get_name());
}

}  // namespace pmg::tools
