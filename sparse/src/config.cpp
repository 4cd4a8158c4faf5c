#include "pmg/sparse/config.hpp"
#include "pmg/sparse/text_reader.hpp"

#include "pmg/sparse/file_io.hpp"

#include <nlohmann/json.hpp>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

namespace pmg {

namespace {

bool valid_key(const std::string& key) {
  if (key.empty() || key.front() == '.' || key.back() == '.' || key.find("..") != std::string::npos)
    return false;
  for (char c : key)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) return false;
  return true;
}

using json = nlohmann::json;

/// Whether setting `key` would replace a value already given: the key itself, or a method given
/// both as `a=m` and as `a.method=m`.
bool given_already(const Config& c, const std::string& key) {
  constexpr const char* kMethod = ".method";
  const bool is_method = key.size() > 7 && key.compare(key.size() - 7, 7, kMethod) == 0;
  return c.has(key) || c.has(key + kMethod) || (is_method && c.has(key.substr(0, key.size() - 7)));
}

/// Sections nested deeper than this are refused (no option has more than a few levels; the limit
/// keeps the recursion's stack bounded whatever the input).
constexpr int kMaxDepth = 64;

void flatten(const json& j, const std::string& prefix, Config& out, const std::string& origin, int depth = 0) {
  if (depth > kMaxDepth)
    throw InputError(origin + ": " + prefix.substr(0, 80) + "...: sections nested deeper than " + std::to_string(kMaxDepth) +
                     " levels");
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string key = prefix + it.key();
    const json& v = it.value();
    // The same key twice ("a.b" beside {"a": {"b": ...}}): refused, never resolved silently.
    if (!v.is_object() && given_already(out, key))
      throw InputError(origin + ": " + key + ": given twice (as a dotted key and inside its section)");
    if (v.is_object()) flatten(v, key + ".", out, origin, depth + 1);
    else if (v.is_string()) out.set(key, v.get<std::string>());
    else if (v.is_boolean()) out.set(key, v.get<bool>() ? "true" : "false");
    else if (v.is_number()) out.set(key, v.dump());
    else throw InputError(origin + ": " + key + ": expected a string, number, boolean or object");
  }
}

}  // namespace

Config::Config() : tree_(std::make_shared<Tree>()) {}

Config Config::from_json(const std::string& text, const std::string& origin) {
  // Duplicate keys and numbers beyond double range are errors, not a silent last-wins or an abort.
  check_json_text(text, origin);
  const json j = json::parse(text);
  if (!j.is_object()) throw InputError(origin + ": expected a JSON object of solver options");
  Config c;
  c.tree_->origin = origin;
  flatten(j, "", c, origin);
  return c;
}

Config Config::from_pairs(const std::vector<std::string>& pairs, const std::string& origin) {
  Config c;
  c.tree_->origin = origin;
  for (const std::string& p : pairs) {
    const auto eq = p.find('=');
    if (eq == std::string::npos || eq == 0)
      throw InputError(origin + ": '" + p + "' is not of the form key=value");
    const std::string key = p.substr(0, eq);
    if (given_already(c, key)) throw InputError(origin + ": " + key + ": given twice");
    c.set(key, p.substr(eq + 1));
  }
  return c;
}

Config Config::clone() const {
  Config c;
  *c.tree_ = *tree_;
  c.prefix_ = prefix_;
  return c;
}

std::string Config::full_key(const std::string& key) const { return prefix_ + key; }

void Config::set(const std::string& key, const std::string& value) {
  const std::string k = full_key(key);
  if (!valid_key(k)) throw InputError(tree_->origin + ": '" + k + "' is not a valid key");
  // A value and a subtree under the same name: a string value of an object key is its method.
  if (has_child(key)) {
    if (has_child(key + ".method"))
      throw InputError(tree_->origin + ": '" + k + "' = '" + value + "' has no place: '" + k +
                       ".method' is a section of its own");
    tree_->values[k + ".method"] = value;
    return;
  }
  for (size_t dot = k.find('.'); dot != std::string::npos; dot = k.find('.', dot + 1)) {
    const std::string parent = k.substr(0, dot);
    auto it = tree_->values.find(parent);
    if (it != tree_->values.end()) {  // "smoother=chebyshev" then "smoother.sweeps=3"
      const std::string method = it->second;
      // The value moves to parent.method, so nothing may live below that name (found by fuzzing:
      // "method" then "method.method.x" left a value and a section under one key).
      if (k.compare(0, parent.size() + 8, parent + ".method.") == 0)
        throw InputError(tree_->origin + ": '" + k + "' reaches below '" + parent + ".method', which holds '" +
                         method + "' (the value given to '" + parent + "')");
      tree_->values.erase(it);
      tree_->values[parent + ".method"] = method;
    }
  }
  tree_->values[k] = value;
}

void Config::set_default(const std::string& key, const std::string& value) {
  if (!has(key)) set(key, value);
}

void Config::merge(const Config& other) {
  for (const auto& [k, v] : other.items()) set(k.substr(other.prefix_.size()), v);
}

const std::string* Config::find(const std::string& key) const {
  auto it = tree_->values.find(full_key(key));
  return it == tree_->values.end() ? nullptr : &it->second;
}

bool Config::has(const std::string& key) const { return find(key) != nullptr; }

bool Config::has_child(const std::string& key) const {
  const std::string p = full_key(key) + ".";
  auto it = tree_->values.lower_bound(p);
  return it != tree_->values.end() && it->first.compare(0, p.size(), p) == 0;
}

Config Config::child(const std::string& key) const {
  // A plain value under this name ("smoother=chebyshev") becomes the child's method.
  const std::string k = full_key(key);
  auto it = tree_->values.find(k);
  if (it != tree_->values.end()) {
    const std::string method = it->second;
    tree_->values.erase(it);
    tree_->values[k + ".method"] = method;
  }
  return Config(tree_, k + ".");
}

void Config::mark_used(const std::string& key) const { tree_->used.insert(full_key(key)); }

void Config::fail(const std::string& key, const std::string& what) const {
  throw InputError((tree_->origin.empty() ? std::string("solver options") : tree_->origin) + ": " +
                   full_key(key) + ": " + what);
}

std::string Config::get_string(const std::string& key, const std::string& fallback) const {
  mark_used(key);
  const std::string* v = find(key);
  return v ? *v : fallback;
}

std::string Config::get_choice(const std::string& key, const std::string& fallback,
                               const std::vector<std::string>& allowed) const {
  const std::string v = get_string(key, fallback);
  for (const auto& a : allowed)
    if (v == a) return v;
  std::string list;
  for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
  fail(key, "'" + printable(v) + "' is not one of " + list);
}

int Config::get_int(const std::string& key, int fallback, int lo, int hi) const {
  mark_used(key);
  const std::string* v = find(key);
  if (!v) return fallback;
  char* end = nullptr;
  errno = 0;
  const long x = std::strtol(v->c_str(), &end, 10);
  // The whole value must be the number (an embedded NUL ends strtol early).
  if (v->empty() || end != v->c_str() + v->size() || errno == ERANGE)
    fail(key, "expected an integer, got '" + printable(*v) + "'");
  if (x < lo || x > hi)
    fail(key, "must lie in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + printable(*v));
  return static_cast<int>(x);
}

double Config::get_double(const std::string& key, double fallback, double lo, double hi) const {
  mark_used(key);
  const std::string* v = find(key);
  if (!v) return fallback;
  char* end = nullptr;
  errno = 0;
  const double x = std::strtod(v->c_str(), &end);
  // The whole value must be the number; underflow (ERANGE with a tiny result) is a number.
  if (v->empty() || end != v->c_str() + v->size() || (errno == ERANGE && std::abs(x) >= 1.0) || !std::isfinite(x))
    fail(key, "expected a finite number, got '" + printable(*v) + "'");
  if (!(x >= lo && x <= hi)) {
    std::ostringstream s;
    s << "must lie in [" << lo << ", " << hi << "], got " << printable(*v);
    fail(key, s.str());
  }
  return x;
}

bool Config::get_bool(const std::string& key, bool fallback) const {
  mark_used(key);
  const std::string* v = find(key);
  if (!v) return fallback;
  if (*v == "true" || *v == "1" || *v == "on") return true;
  if (*v == "false" || *v == "0" || *v == "off") return false;
  fail(key, "expected true or false, got '" + printable(*v) + "'");
}

void Config::check_all_used(const std::set<std::string>& except) const {
  std::string unknown;
  for (const auto& [k, v] : items())
    if (!tree_->used.count(k) && !except.count(k)) unknown += (unknown.empty() ? "" : ", ") + k;
  if (!unknown.empty())
    throw InputError((tree_->origin.empty() ? std::string("solver options") : tree_->origin) +
                     ": unknown or unused key" + (unknown.find(',') != std::string::npos ? "s " : " ") +
                     unknown + " (for the solver chosen; see docs/solvers.md)");
}

std::vector<std::string> Config::unused_keys() const {
  std::vector<std::string> out;
  for (const auto& kv : items())
    if (!tree_->used.count(kv.first)) out.push_back(kv.first);
  return out;
}

std::vector<std::pair<std::string, std::string>> Config::items() const {
  std::vector<std::pair<std::string, std::string>> out;
  for (auto it = tree_->values.lower_bound(prefix_); it != tree_->values.end(); ++it) {
    if (it->first.compare(0, prefix_.size(), prefix_) != 0) break;
    out.push_back(*it);
  }
  return out;
}

std::string Config::to_string() const {
  std::string s;
  for (const auto& [k, v] : items()) s += (s.empty() ? "" : " ") + k.substr(prefix_.size()) + "=" + v;
  return s;
}

std::string Config::to_json() const {
  json j = json::object();
  for (const auto& [k, v] : items()) {
    json* node = &j;
    const std::string rel = k.substr(prefix_.size());
    size_t start = 0;
    for (size_t dot = rel.find('.'); dot != std::string::npos; dot = rel.find('.', start)) {
      node = &(*node)[rel.substr(start, dot - start)];
      start = dot + 1;
    }
    // Numbers and booleans back as JSON values, everything else as strings.
    json value;
    try {
      value = json::parse(v);
      if (!value.is_number() && !value.is_boolean()) value = v;
    } catch (const json::exception&) {
      value = v;
    }
    (*node)[rel.substr(start)] = value;
  }
  return j.dump();
}

}  // namespace pmg
