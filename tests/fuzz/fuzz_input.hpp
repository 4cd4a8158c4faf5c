// Shared by the fuzz targets: the input as a seekable stream, and the one outcome a reader may have
// besides success. A reader given any bytes either returns or throws pmg::Error (InputError,
// MeshError) with a message; anything else — another exception, a crash, a sanitizer report, an
// allocation beyond libFuzzer's -malloc_limit_mb, a hang beyond -timeout — is a finding.
#pragma once

#include "pmg/sparse/types.hpp"

#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

namespace pmg::fuzz {

inline std::string text_of(const std::uint8_t* data, std::size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

/// Runs read(); an Error with a non-empty message is the expected way to refuse input.
template <class Read>
void expect_value_or_error(Read&& read) {
  try {
    read();
  } catch (const pmg::Error& e) {
    if (std::string(e.what()).empty()) __builtin_trap();  // an error must say what is wrong
  }
}

/// What a surface reader returns: every triangle's vertex indices in range.
template <class Surface>
void check_surface(const Surface& s) {
  for (const auto& t : s.triangles)
    for (auto v : t)
      if (v < 0 || static_cast<std::size_t>(v) >= s.vertices.size()) __builtin_trap();
}

}  // namespace pmg::fuzz
