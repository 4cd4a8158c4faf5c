#include "pmg/sparse/file_io.hpp"

#include "pmg/sparse/types.hpp"

#include <nlohmann/json.hpp>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <atomic>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <set>
#include <sys/stat.h>
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

/// The file a path names, links followed (a dangling link: the file it would create). Throws Error
/// on a loop of links.
std::string link_target(const std::string& path) {
  std::string p = path;
  for (int depth = 0; depth < 40; ++depth) {
    struct stat st {};
    if (::lstat(p.c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) return p;
    std::error_code ec;
    const fs::path next = fs::read_symlink(p, ec);
    if (ec) throw Error(path + ": cannot read the link " + p + " (" + ec.message() + ")");
    p = next.is_absolute() ? next.string() : (fs::path(p).parent_path() / next).string();
  }
  throw Error(path + ": too many levels of symbolic links");
}

/// Writes into an existing file that is not a regular one (a device such as /dev/null, a FIFO, a
/// socket) in place: it is never replaced. A FIFO without a reader is an error, not a hang.
void write_in_place(const std::string& path, const std::string& target, const std::string& contents) {
  const int fd = ::open(target.c_str(), O_WRONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    const std::string why = errno == ENXIO ? "a FIFO with no reader" : reason();
    throw Error(path + ": cannot write (" + why + ")");
  }
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  const char* p = contents.data();
  std::size_t left = contents.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string why = n < 0 ? reason() : "nothing written";
      ::close(fd);
      throw Error(path + ": write failed (" + why + ")");
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  if (::close(fd) != 0) throw Error(path + ": write failed (" + reason() + ")");
}

}  // namespace

void write_file_atomically(const std::string& path, const std::string& contents) {
  // A link is followed and stays a link; what is not a regular file is written in place.
  const std::string target = link_target(path);
  struct stat st {};
  if (::stat(target.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    if (S_ISDIR(st.st_mode)) throw Error(path + ": is a folder, expected a file name");
    write_in_place(path, target, contents);
    return;
  }
  static std::atomic<unsigned> count{0};
  const std::string tmp = target + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(count++);
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
  if (std::rename(tmp.c_str(), target.c_str()) != 0) {
    const std::string why = reason();
    std::remove(tmp.c_str());
    throw Error(path + ": cannot put the written file in place (" + why + ")");
  }
}

void check_output_file(const std::string& path, const std::string& what) {
  if (path.empty()) throw InputError(what + ": empty path");
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw InputError(what + " " + path + ": is a folder, expected a file name");
  std::string target;
  try {
    target = link_target(path);
  } catch (const Error& e) {
    throw InputError(what + " " + e.what());
  }
  struct stat st {};
  if (::stat(target.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {  // a device or FIFO: written in place
    if (::access(target.c_str(), W_OK) != 0)
      throw InputError(what + " " + path + ": cannot write (" + reason() + ")");
    return;
  }
  const std::string dir = folder_of(target);
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
  // Deeper documents are refused while they are read: no option has more than a few levels, and
  // the recursive walks after parsing (dump, flatten) must not overflow the stack.
  constexpr int kMaxJsonDepth = 64;
  int depth = 0;
  std::vector<std::set<std::string>> open;
  std::vector<std::string> path;  // the key path to the current value, for messages
  std::string problem;
  try {
    const json document = json::parse(text, [&](int, json::parse_event_t event, json& parsed) {
      if (!problem.empty()) return false;
      switch (event) {
        case json::parse_event_t::object_start:
          open.emplace_back();
          path.emplace_back();
          if (++depth > kMaxJsonDepth) problem = "objects and arrays nested deeper than " + std::to_string(kMaxJsonDepth) + " levels";
          break;
        case json::parse_event_t::array_start:
          if (++depth > kMaxJsonDepth) problem = "objects and arrays nested deeper than " + std::to_string(kMaxJsonDepth) + " levels";
          break;
        case json::parse_event_t::array_end: --depth; break;
        case json::parse_event_t::object_end:
          --depth;
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

std::string read_text_file(const std::string& path, std::size_t max_bytes, const std::string& what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(what + ": cannot open '" + path + "'");
  std::string text;
  std::vector<char> chunk(1 << 16);
  while (in) {
    in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
    text.append(chunk.data(), static_cast<std::size_t>(in.gcount()));
    if (text.size() > max_bytes)
      throw InputError(what + ": '" + path + "' is longer than " + std::to_string(max_bytes) +
                       " bytes: not a file of this kind");
  }
  if (in.bad()) throw InputError(what + ": cannot read '" + path + "'");
  return text;
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

namespace {

/// The identity of a path for FilePlan: "inode:<dev>:<ino>" for an existing regular file or folder
/// (through links), "" for a device, FIFO or socket (never a conflict), else the normalised
/// absolute path.
std::string identity(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) {
    if (!S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode)) return "";
    return "inode:" + std::to_string(st.st_dev) + ":" + std::to_string(st.st_ino);
  }
  std::error_code ec;
  fs::path p = fs::weakly_canonical(fs::absolute(path, ec), ec);
  return "path:" + (ec ? fs::absolute(path).lexically_normal().string() : p.string());
}

/// The identity of the folder holding `path` and the file's name.
std::pair<std::string, std::string> place(const std::string& path) {
  fs::path p(path);
  const fs::path parent = p.parent_path().empty() ? fs::path(".") : p.parent_path();
  return {identity(parent.string()), p.filename().string()};
}

}  // namespace

void FilePlan::input(const std::string& path, const std::string& what) {
  if (!path.empty()) files_.push_back({path, what, false});
}

void FilePlan::output(const std::string& path, const std::string& what) {
  if (path.empty()) return;
  check_output_file(path, what);
  files_.push_back({path, what, true});
}

void FilePlan::output_folder(const std::string& path, const std::string& what,
                             std::function<bool(const std::string&)> writes) {
  if (!path.empty()) folders_.push_back({path, what, std::move(writes)});
}

void FilePlan::check() const {
  std::vector<std::string> ids;
  for (const Entry& e : files_) ids.push_back(identity(e.path));
  for (size_t i = 0; i < files_.size(); ++i) {
    if (!files_[i].output || ids[i].empty()) continue;
    for (size_t j = 0; j < files_.size(); ++j) {
      if (j == i || ids[j] != ids[i] || (files_[j].output && j > i)) continue;
      const Entry& o = files_[i];
      const Entry& other = files_[j];
      throw InputError(o.what + " '" + o.path + "' is " +
                       (other.output ? "also the output " + other.what + " '" + other.path + "': name two different files"
                                     : other.what + (other.path == o.path ? "" : " '" + other.path + "'") + ", an input" +
                                           ": an output would overwrite an input; name another file"));
    }
  }
  for (const Folder& f : folders_) {
    const std::string folder = identity(f.path);
    for (size_t j = 0; j < files_.size(); ++j) {
      const auto [parent, name] = place(files_[j].path);
      if (ids[j].empty() || parent != folder || !f.writes(name)) continue;
      throw InputError(files_[j].what + " '" + files_[j].path + "' is a file " + f.what + " '" + f.path + "' writes (" +
                       name + "): " + (files_[j].output ? "two outputs would be one file" : "an output would overwrite an input") +
                       "; name another file or folder");
    }
  }
}

}  // namespace pmg
