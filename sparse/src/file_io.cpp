#include "pmg/sparse/file_io.hpp"

#include "pmg/sparse/types.hpp"

#include <nlohmann/json.hpp>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <unistd.h>
#include <vector>

namespace pmg {

namespace fs = std::filesystem;

namespace {

std::string reason() { return std::strerror(errno); }

std::string folder_of(const std::string& path) {
  const fs::path parent = fs::path(path).parent_path();
  return parent.empty() ? "." : parent.string();
}

std::string gigabytes(double bytes) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.1f GB", bytes / 1e9);
  return buf;
}

}  // namespace

void write_file_atomically(const std::string& path, const std::string& contents) {
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw Error(path + ": cannot write (creating " + tmp + ": " + reason() + ")");
    out.write(contents.data(), static_cast<std::streamsize>(contents.size()));
    out.flush();
    if (!out) {
      const std::string why = reason();
      std::remove(tmp.c_str());
      throw Error(path + ": write failed (" + why + ")");
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string why = reason();
    std::remove(tmp.c_str());
    throw Error(path + ": cannot put the written file in place (" + why + ")");
  }
}

void check_output_file(const std::string& path, const std::string& what) {
  if (path.empty()) throw InputError(what + ": empty path");
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw InputError(what + " " + path + ": is a folder, expected a file name");
  const std::string dir = folder_of(path);
  if (!fs::is_directory(dir, ec))
    throw InputError(what + " " + path + ": folder " + dir + " does not exist");
  if (::access(dir.c_str(), W_OK | X_OK) != 0)
    throw InputError(what + " " + path + ": cannot write in " + dir + " (" + reason() + ")");
}

void prepare_output_directory(const std::string& path, const std::string& what) {
  if (path.empty()) throw InputError(what + ": empty path");
  std::error_code ec;
  if (fs::exists(path, ec) && !fs::is_directory(path, ec))
    throw InputError(what + " " + path + ": exists and is not a folder");
  fs::create_directories(path, ec);
  if (ec) throw InputError(what + " " + path + ": cannot create the folder (" + ec.message() + ")");
  if (::access(path.c_str(), W_OK | X_OK) != 0)
    throw InputError(what + " " + path + ": cannot write in this folder (" + reason() + ")");
}

void check_json_text(const std::string& text, const std::string& origin) {
  using json = nlohmann::json;
  std::vector<std::set<std::string>> open;
  std::vector<std::string> path;  // the key path to the current value, for messages
  std::string problem;
  try {
    const json document = json::parse(text, [&](int, json::parse_event_t event, json& parsed) {
      if (!problem.empty()) return false;
      switch (event) {
        case json::parse_event_t::object_start: open.emplace_back(); path.emplace_back(); break;
        case json::parse_event_t::object_end:
          if (!open.empty()) open.pop_back();
          if (!path.empty()) path.pop_back();
          break;
        case json::parse_event_t::key: {
          const std::string k = parsed.get<std::string>();
          if (!path.empty()) path.back() = k;
          if (!open.empty() && !open.back().insert(k).second) {
            std::string where;
            for (const auto& p : path) where += (where.empty() ? "" : ".") + p;
            problem = "key '" + where + "' appears twice (the last value would win silently)";
          }
          break;
        }
        default: break;
      }
      return true;
    });
    (void)document;
  } catch (const json::out_of_range& e) {
    // nlohmann reports a number beyond double range (1e400) as out_of_range 406.
    std::string where;
    for (const auto& p : path) where += (where.empty() ? "" : ".") + p;
    throw InputError(origin + ": " + (where.empty() ? "" : where + ": ") +
                     "a number outside the range of a double (" + e.what() + ")");
  } catch (const json::exception& e) {
    throw InputError(origin + ": not valid JSON: " + e.what());
  }
  if (!problem.empty()) throw InputError(origin + ": " + problem);
}

std::size_t physical_memory_bytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page <= 0) return 0;
  return static_cast<std::size_t>(pages) * static_cast<std::size_t>(page);
}

void require_memory(double bytes, const std::string& what) {
  const double have = static_cast<double>(physical_memory_bytes());
  if (!(bytes >= 0) || (have > 0 && bytes > have))
    throw InputError(what + " would need an estimated " + gigabytes(bytes) + " of memory; this machine has " +
                     gigabytes(have));
}

}  // namespace pmg
