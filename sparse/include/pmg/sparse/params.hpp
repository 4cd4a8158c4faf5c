// pmg/sparse/params.hpp — one home per option set: a parameter struct names, bounds and describes
// each of its keys once, in its visit() (AMGCL's `params(ptree)` with the key list derived from
// it). Two visitors walk the same function:
//
//   ParamReader  reads the keys from a Config (range-checked, the key named on failure) into the
//                struct's fields, whose initial values are the defaults;
//   ParamLister  records each key with its type, default, range and description (KeyInfo): what
//                the registry, `pmg solvers`, `pmg compare --help` and docs/solvers.md show.
//
//   struct SmootherParams {
//     int sweeps = 5;
//     void visit(pmg::ParamVisitor& v) { v.integer("sweeps", sweeps, 0, 1000, "sweeps before and after"); }
//   };
//   SmootherParams p = pmg::read_params<SmootherParams>(config);   // reads config's "sweeps"
//   std::vector<pmg::KeyInfo> keys = pmg::list_params<SmootherParams>();
#pragma once

#include "pmg/sparse/config.hpp"

#include <string>
#include <utility>
#include <vector>

namespace pmg {

/// One option key of a method, as listed by the registry.
struct KeyInfo {
  std::string key;            ///< "sweeps"; a sub-solver is listed as "smoother.*"
  std::string type;           ///< int, real, bool, text, choice or solver
  std::string default_value;  ///< as text; empty when the key has no default (optional text)
  std::string range;          ///< "[1, 1000]", "first | fourth", or the sub-solver's default method
  std::string description;    ///< one line
};

/// Walks a parameter struct's keys (see the file comment). Bounds are inclusive.
class ParamVisitor {
 public:
  virtual ~ParamVisitor() = default;
  /// An integer key in [lo, hi]; `value` holds the default and receives what is read. `what` is
  /// the one-line description.
  virtual void integer(const char* key, int& value, int lo, int hi, const char* what) = 0;
  /// A real key in [lo, hi]; `value` holds the default and receives what is read.
  virtual void real(const char* key, double& value, double lo, double hi, const char* what) = 0;
  /// A boolean key; `value` holds the default and receives what is read.
  virtual void boolean(const char* key, bool& value, const char* what) = 0;
  /// A free-text key; `value` holds the default and receives what is read.
  virtual void text(const char* key, std::string& value, const char* what) = 0;
  /// One of `allowed` (the first that the value equals).
  virtual void choice(const char* key, std::string& value, const std::vector<std::string>& allowed,
                      const char* what) = 0;
  /// A choice stored as an enumeration: `names` maps each accepted word to its value.
  template <class Enum>
  void choice(const char* key, Enum& value, const std::vector<std::pair<const char*, Enum>>& names,
              const char* what) {
    std::vector<std::string> allowed;
    std::string word;
    for (const auto& [name, e] : names) {
      allowed.push_back(name);
      if (e == value && word.empty()) word = name;
    }
    choice(key, word, allowed, what);
    for (const auto& [name, e] : names)
      if (word == name) value = e;
  }
  /// A sub-solver under `key`: its options lie below `key` (`key=m` is short for `key.method=m`).
  /// Listed only; the builder reads it with build_solver(config.child(key), ...).
  virtual void solver(const char* key, const char* default_method, const char* what) = 0;
  /// Whether the key was given (always false when listing).
  virtual bool given(const char* key) const = 0;
  /// Whether this visitor reads values (false for the lister): checks across keys run only then.
  virtual bool reading() const = 0;
  /// Throws InputError naming the key (readers); listers ignore it.
  virtual void fail(const char* key, const std::string& what) const = 0;
};

/// Reads keys from a Config view into the visited struct.
class ParamReader final : public ParamVisitor {
 public:
  /// Reads from `config` (a view: keys the reader uses are marked used in the config's tree).
  /// Values out of range or of the wrong type throw InputError naming the key.
  explicit ParamReader(const Config& config) : c_(config) {}
  void integer(const char* key, int& value, int lo, int hi, const char*) override {
    value = c_.get_int(key, value, lo, hi);
  }
  void real(const char* key, double& value, double lo, double hi, const char*) override {
    value = c_.get_double(key, value, lo, hi);
  }
  void boolean(const char* key, bool& value, const char*) override { value = c_.get_bool(key, value); }
  void text(const char* key, std::string& value, const char*) override { value = c_.get_string(key, value); }
  void choice(const char* key, std::string& value, const std::vector<std::string>& allowed,
              const char*) override {
    value = c_.get_choice(key, value, allowed);
  }
  using ParamVisitor::choice;
  void solver(const char*, const char*, const char*) override {}
  bool given(const char* key) const override { return c_.has(key); }
  bool reading() const override { return true; }
  void fail(const char* key, const std::string& what) const override { c_.fail(key, what); }

 private:
  Config c_;
};

/// Records each visited key as a KeyInfo, the field's current value as its default.
class ParamLister final : public ParamVisitor {
 public:
  void integer(const char* key, int& value, int lo, int hi, const char* what) override;
  void real(const char* key, double& value, double lo, double hi, const char* what) override;
  void boolean(const char* key, bool& value, const char* what) override;
  void text(const char* key, std::string& value, const char* what) override;
  void choice(const char* key, std::string& value, const std::vector<std::string>& allowed,
              const char* what) override;
  using ParamVisitor::choice;
  void solver(const char* key, const char* default_method, const char* what) override;
  bool given(const char*) const override { return false; }
  bool reading() const override { return false; }
  void fail(const char*, const std::string&) const override {}
  /// The keys visited so far, in visiting order.
  const std::vector<KeyInfo>& keys() const { return keys_; }

 private:
  std::vector<KeyInfo> keys_;
};

/// The struct P read from a config over P's defaults (or over `base`).
template <class P>
P read_params(const Config& config, P base = P{}) {
  ParamReader r(config);
  base.visit(r);
  return base;
}

/// The keys of P with its defaults (or those of `base`).
template <class P>
std::vector<KeyInfo> list_params(P base = P{}) {
  ParamLister l;
  base.visit(l);
  return l.keys();
}

/// a followed by b (key lists of composed methods).
std::vector<KeyInfo> operator+(std::vector<KeyInfo> a, const std::vector<KeyInfo>& b);

}  // namespace pmg
