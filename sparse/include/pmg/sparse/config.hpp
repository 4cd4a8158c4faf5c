// pmg/sparse/config.hpp — the parameters of a solver as a tree of dotted keys (AMGCL's property
// tree): `method=mgpcg smoother.sweeps=3 lowest_level.method=boomeramg`, or the same as nested JSON
// ({"method": "mgpcg", "smoother": {"sweeps": 3}, "lowest_level": {"method": "boomeramg"}}).
//
// A string where an object is expected is short for its "method": `smoother=chebyshev` is
// `smoother.method=chebyshev`. Every reader records the key it read, so that after building a
// solver the keys nobody read can be reported (check_all_used), naming the key and where it came
// from: a misspelt option is an error, never silently ignored. Values are kept as text and
// converted by the typed readers, which check ranges and name the key on failure.
#pragma once

#include "pmg/sparse/types.hpp"

#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

namespace pmg {

/// A solver's options as a tree of dotted keys with a record of the keys read (see the file
/// comment). A Config is a view: copies and child() views share the values and the record.
class Config {
 public:
  /// An empty tree with no origin.
  Config();

  /// Nested JSON object; arrays are refused, numbers and booleans kept as their JSON text.
  /// `origin` names the source in messages (a file name, "--solver-config").
  static Config from_json(const std::string& text, const std::string& origin);
  /// `key=value` pairs.
  static Config from_pairs(const std::vector<std::string>& pairs, const std::string& origin);

  /// A deep copy (a plain copy shares the values with the original, as child() views do).
  Config clone() const;
  /// Where the values came from, as named in messages (empty when not given).
  const std::string& origin() const { return tree_->origin; }

  /// Sets (or replaces) a value; `key` is relative to this view's prefix.
  void set(const std::string& key, const std::string& value);
  /// Sets the value only when the key is not set yet (defaults of presets).
  void set_default(const std::string& key, const std::string& value);
  /// Every key of `other` (same prefix rules) set here, replacing existing values.
  void merge(const Config& other);
  /// Whether the key has a value (does not mark it used).
  bool has(const std::string& key) const;
  /// Whether any key lies under `key.` (the subtree exists).
  bool has_child(const std::string& key) const;

  /// The subtree under `key.`, sharing this tree's values and its record of used keys.
  Config child(const std::string& key) const;
  /// The whole tree (the view without a prefix), sharing values and record: the keys that belong
  /// to the solver tree as a whole (unused_keys) read from any view.
  Config root() const { return Config(tree_, ""); }
  /// Full dotted name of a key of this view ("preconditioner.smoother.sweeps").
  std::string full_key(const std::string& key) const;

  /// The key's value as text, or `fallback` when it is not set. Every get_* reader marks the key
  /// used and throws InputError naming the key (see fail()) when the value does not parse or lies
  /// out of range.
  std::string get_string(const std::string& key, const std::string& fallback) const;
  /// One of `allowed` (the message lists them).
  std::string get_choice(const std::string& key, const std::string& fallback,
                         const std::vector<std::string>& allowed) const;
  /// A decimal integer in [lo, hi], or `fallback` when the key is not set.
  int get_int(const std::string& key, int fallback, int lo, int hi) const;
  /// A finite number in [lo, hi], or `fallback` when the key is not set.
  double get_double(const std::string& key, double fallback, double lo, double hi) const;
  /// true/1/on or false/0/off, or `fallback` when the key is not set.
  bool get_bool(const std::string& key, bool fallback) const;
  /// Marks a key as read without reading it (a key a caller handles itself).
  void mark_used(const std::string& key) const;

  /// Throws InputError naming every key of this view that no reader used (keys in `except`, full
  /// names, are not checked).
  void check_all_used(const std::set<std::string>& except = {}) const;
  /// The keys of this view that no reader used (full names), in order: after make_solver() with
  /// unused_keys=known or ignore, what the solver left unused (PETSc's -options_left).
  std::vector<std::string> unused_keys() const;
  /// Whether a reader used the key.
  bool was_used(const std::string& key) const { return tree_->used.count(full_key(key)) > 0; }
  /// Every key and value of this view, in order (full names).
  std::vector<std::pair<std::string, std::string>> items() const;
  /// The view as `key=value` pairs separated by spaces (for printing what a solver used).
  std::string to_string() const;
  /// The view as nested JSON.
  std::string to_json() const;

  /// Throws InputError "origin: key: what".
  [[noreturn]] void fail(const std::string& key, const std::string& what) const;

 private:
  struct Tree {
    std::map<std::string, std::string> values;
    std::set<std::string> used;
    std::string origin;
  };
  Config(std::shared_ptr<Tree> tree, std::string prefix)
      : tree_(std::move(tree)), prefix_(std::move(prefix)) {}
  const std::string* find(const std::string& key) const;

  std::shared_ptr<Tree> tree_;
  std::string prefix_;  ///< "" or "a.b."
};

}  // namespace pmg
