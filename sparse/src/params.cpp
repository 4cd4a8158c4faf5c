#include "pmg/sparse/params.hpp"

#include <cmath>
#include <cstdio>
#include <limits>

namespace pmg {

namespace {

std::string number(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

std::string interval(double lo, double hi, bool unbounded) {
  if (unbounded) return ">= " + number(lo);
  return "[" + number(lo) + ", " + number(hi) + "]";
}

std::string join(const std::vector<std::string>& words, const char* sep) {
  std::string out;
  for (const auto& w : words) out += (out.empty() ? "" : sep) + w;
  return out;
}

}  // namespace

void ParamLister::integer(const char* key, int& value, int lo, int hi, const char* what) {
  keys_.push_back({key, "int", std::to_string(value),
                   interval(lo, hi, hi == std::numeric_limits<int>::max()), what});
}

void ParamLister::real(const char* key, double& value, double lo, double hi, const char* what) {
  keys_.push_back({key, "real", number(value), interval(lo, hi, std::isinf(hi)), what});
}

void ParamLister::boolean(const char* key, bool& value, const char* what) {
  keys_.push_back({key, "bool", value ? "true" : "false", "true | false", what});
}

void ParamLister::text(const char* key, std::string& value, const char* what) {
  keys_.push_back({key, "text", value, "", what});
}

void ParamLister::choice(const char* key, std::string& value, const std::vector<std::string>& allowed,
                         const char* what) {
  keys_.push_back({key, "choice", value, join(allowed, " | "), what});
}

void ParamLister::solver(const char* key, const char* default_method, const char* what) {
  keys_.push_back({std::string(key) + ".*", "solver", default_method, "any method", what});
}

std::vector<KeyInfo> operator+(std::vector<KeyInfo> a, const std::vector<KeyInfo>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

}  // namespace pmg
