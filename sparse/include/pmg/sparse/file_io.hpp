// pmg/sparse/file_io.hpp — files in and out, safely: writes that an interrupted run never leaves
// half done, output paths checked before any work, JSON text checked strictly, and sizes checked
// against the machine's memory before they are allocated.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace pmg {

/// Writes contents so that an interrupted run never leaves a half-written file and nothing but the
/// named file changes: a regular (or new) file is written to "path.tmp.<pid>.<n>" beside it and
/// renamed over it (atomic on POSIX file systems); a symbolic link is followed, so the link stays
/// and its target is written; a device (/dev/null), FIFO or socket is written in place, never
/// replaced (a FIFO without a reader is an error, not a hang). Errors name `path` and the reason
/// (errno's text: /dev/full says "No space left on device").
void write_file_atomically(const std::string& path, const std::string& contents);

/// Checks, before any work, that a file can be written at `path`: its folder exists and is
/// writable, and `path` is not a folder. `what` names the option in the message ("--json").
/// Throws InputError.
void check_output_file(const std::string& path, const std::string& what);

/// Creates the folder `path` (and its parents) if needed and checks that it is a writable folder,
/// not a file. `what` names the option. Throws InputError.
void prepare_output_directory(const std::string& path, const std::string& what);

/// The files one run reads and writes, checked together before any work, so that no output
/// destroys an input or another output: two paths are the same file when they name the same
/// inode (links and relative paths resolved) or, where a file does not exist yet, the same
/// normalised absolute path. Devices, FIFOs and sockets (/dev/null) are never a conflict.
class FilePlan {
 public:
  /// A file the run reads; `what` names it in messages ("the scene file", "--matrix").
  void input(const std::string& path, const std::string& what);
  /// A file the run writes ("--json"); checked at once as check_output_file() checks it.
  void output(const std::string& path, const std::string& what);
  /// A folder the run writes into: `writes(name)` says whether a file of that name there is one
  /// the run writes (steps.csv, frame_000010.vtu), which then may be no input or other output.
  void output_folder(const std::string& path, const std::string& what, std::function<bool(const std::string&)> writes);
  /// Throws InputError naming the first conflict ("--json 's.json' is the scene file: ...").
  void check() const;

 private:
  struct Entry {
    std::string path, what;
    bool output = false;
  };
  struct Folder {
    std::string path, what;
    std::function<bool(const std::string&)> writes;
  };
  std::vector<Entry> files_;
  std::vector<Folder> folders_;
};

/// The whole of a small text file (a scene, a solver configuration): at most max_bytes bytes, read
/// without trusting the file's size (a device or a pipe is read up to max_bytes + 1 and refused
/// when longer). `what` names the file in messages. Throws InputError (missing, unreadable, too long).
std::string read_text_file(const std::string& path, std::size_t max_bytes, const std::string& what);

/// The limit of read_text_file() for configuration files (scenes, solver configurations): 16 MiB.
inline constexpr std::size_t kMaxConfigBytes = std::size_t(16) << 20;

/// Checks JSON text strictly: valid syntax, no key twice in one object (the last value would win
/// silently), every number within double range. Throws InputError "origin: ...".
void check_json_text(const std::string& text, const std::string& origin);

/// Physical memory of this machine in bytes (0 if unknown).
std::size_t physical_memory_bytes();

/// Throws InputError when `bytes` (an estimate of what `what` will need) exceeds the machine's
/// physical memory, naming both; a run that would be killed for memory is refused before it starts.
void require_memory(double bytes, const std::string& what);

}  // namespace pmg
