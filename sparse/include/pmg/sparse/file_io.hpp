// pmg/sparse/file_io.hpp — writing files so that an interrupted run never leaves half a file.
#pragma once

#include <string>

namespace pmg {

/// Writes contents to "path.tmp.<pid>" and renames it to path (atomic on POSIX file systems).
void write_file_atomically(const std::string& path, const std::string& contents);

}  // namespace pmg
