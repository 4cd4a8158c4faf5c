// Internal to pmg::sim: numbers in the notes and reports of a run.
#pragma once

#include <cstdio>
#include <string>

namespace pmg::sim::detail {

/// v with `digits` decimals ("%.*f").
inline std::string fixed(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

}  // namespace pmg::sim::detail
