// The solver registry and the methods of the core: Krylov solvers and point/block Jacobi.
#include "pmg/sparse/factory.hpp"

#include "pmg/sparse/layout.hpp"

#include "pmg/sparse/krylov.hpp"
#include "pmg/sparse/preconditioners.hpp"
#include "pmg/sparse/timer.hpp"

#include <chrono>
#include <mutex>
#include <set>

namespace pmg {

namespace {

struct Entry {
  SolverInfo info;
  SolverBuilder build;
};

std::unique_ptr<Solver> pcg_with(const Config& c, std::unique_ptr<Solver> M) {
  return std::make_unique<Cg>(read_krylov(c), std::move(M));
}

struct Registry {
  std::vector<Entry> entries;
  std::mutex mutex;
  std::set<std::string> started;  ///< methods whose start-up hook ran
  Registry();
  const Entry* find(const std::string& name) const {
    for (const auto& e : entries)
      if (e.info.name == name) return &e;
    return nullptr;
  }
};

Registry& registry() {
  static Registry r;
  return r;
}

Registry::Registry() {
  auto add = [&](SolverInfo info, SolverBuilder b) { entries.push_back({std::move(info), std::move(b)}); };
  ParamLister preconditioner;
  preconditioner.solver("preconditioner", "none",
                        "a symmetric solver as preconditioner (one that varies, such as an inner "
                        "solve, makes CG flexible); none: plain CG; keys preconditioner.* without a "
                        "method: block-jacobi");
  add({"cg", "conjugate gradients, optionally preconditioned by any symmetric solver (flexible CG where it varies)",
       krylov_keys() + preconditioner.keys()},
      [](const Config& c, const SolverContext& ctx) {
        std::unique_ptr<Solver> M;
        if (c.has_child("preconditioner") || c.has("preconditioner"))
          M = build_solver(c.child("preconditioner"), ctx, "block-jacobi");
        return pcg_with(c, std::move(M));
      });
  add({"jacobi-pcg", "CG preconditioned by point Jacobi", krylov_keys()},
      [](const Config& c, const SolverContext&) { return pcg_with(c, std::make_unique<JacobiPreconditioner>()); });
  add({"block-jacobi-pcg", "CG preconditioned by 3x3 block Jacobi", krylov_keys(), false, true},
      [](const Config& c, const SolverContext&) { return pcg_with(c, std::make_unique<BlockJacobiPreconditioner>()); });
  add({"mcg", "merged CG (three fused steps) with block Jacobi", krylov_keys() + check_every_key(), false, true},
      [](const Config& c, const SolverContext&) {
        KrylovParams p = read_krylov(c);
        ParamReader r(c);
        p.visit_check_every(r);
        return std::make_unique<MergedCg>(p);
      });
  add({"jacobi", "point Jacobi D^-1", {}},
      [](const Config&, const SolverContext&) { return std::make_unique<JacobiPreconditioner>(); });
  add({"block-jacobi", "3x3 block Jacobi D^-1", {}, false, true},
      [](const Config&, const SolverContext&) { return std::make_unique<BlockJacobiPreconditioner>(); });
}

/// Every value in the tree: the methods it names are among them, whether as a "method" key or in
/// the shorthand `lowest_level=boomeramg` (stored under the plain key until the tree is built).
std::vector<std::string> named_methods(const Config& c) {
  std::vector<std::string> out;
  for (const auto& kv : c.items()) out.push_back(kv.second);
  return out;
}

/// Whether some registered method reads `key` (relative to the method's own tree): listed as one
/// of its keys, or inside one of its sub-solvers ("smoother.*" covers smoother.anything).
bool is_known_key(const std::string& key) {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  const std::string head = key.substr(0, key.find('.'));
  for (const auto& e : r.entries)
    for (const auto& k : e.info.keys)
      if (k.key == key || (key.size() > head.size() && k.key == head + ".*")) return true;
  return false;
}

}  // namespace

std::vector<KeyInfo> factory_keys() {
  return {{"layout", "choice", "interleaved", "interleaved | component",
           "order of the unknowns: component-major (x0 x1 ... y0 ...) is permuted to interleaved once "
           "(multigrid levels take theirs where they are built)"},
          {"unused_keys", "choice", "error", "error | known | ignore",
           "a key no builder read: an error; allowed when some method reads it (one option set for "
           "several methods); or ignored"}};
}

KrylovParams read_krylov(const Config& c, KrylovParams p) { return read_params(c, p); }

std::vector<KeyInfo> krylov_keys(KrylovParams defaults) { return list_params(defaults); }

std::vector<KeyInfo> check_every_key(KrylovParams defaults) {
  ParamLister l;
  defaults.visit_check_every(l);
  return l.keys();
}

SolverInfo solver_info(const std::string& method) {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  if (const Entry* e = r.find(method)) return e->info;
  std::string list;
  for (const auto& e : r.entries) list += (list.empty() ? "" : ", ") + e.info.name;
  throw InputError("unknown method '" + method + "' (registered: " + list +
                   "; the multigrid, CHOLMOD, hypre, PETSc and GPU methods are registered by "
                   "pmg::register_all_solvers() or their component's register_solvers())");
}

std::unique_ptr<Solver> build_solver(const Config& config, const SolverContext& context,
                                     const std::string& fallback_method) {
  const std::string method = config.get_string("method", fallback_method);
  SolverBuilder build;
  {
    Registry& r = registry();
    std::lock_guard<std::mutex> lock(r.mutex);
    if (const Entry* e = r.find(method)) build = e->build;
  }
  if (!build) {
    try {
      solver_info(method);
    } catch (const InputError& e) {
      config.fail("method", e.what());
    }
  }
  return build(config, context);
}

void check_keys_used(const Config& config) {
  const std::string unused = config.get_choice("unused_keys", "error", {"error", "known", "ignore"});
  std::set<std::string> allowed;
  if (unused != "error")
    for (const std::string& k : config.unused_keys())
      if (unused == "ignore" || is_known_key(k.substr(config.full_key("").size()))) allowed.insert(k);
  config.check_all_used(allowed);
}

bool unused_options_allowed(const Config& config) {
  return config.root().get_choice("unused_keys", "error", {"error", "known", "ignore"}) != "error";
}

std::unique_ptr<Solver> make_solver(const Config& config, const SolverContext& context,
                                    const std::string& fallback_method) {
  config.get_choice("unused_keys", "error", {"error", "known", "ignore"});  // refused before the build
  auto s = adapt_to_input(build_solver(config, context, fallback_method), config, context, fallback_method);
  check_keys_used(config);
  return s;
}

std::unique_ptr<Solver> adapt_to_input(std::unique_ptr<Solver> s, const Config& config, const SolverContext& context,
                                       const std::string& fallback_method) {
  // layout=component: any method on a component-major matrix (pmg/sparse/layout.hpp).
  const std::string layout = config.get_choice("layout", "interleaved", {"interleaved", "component"});
  if (layout == "component" && context.levels)
    config.fail("layout", "multigrid levels take their layout where they are built (mg::UserLevels with "
                          "DofLayout::component, Python multigrid(layout=\"component\")); the levels "
                          "the solver reads are interleaved");
  const std::string method = config.get_string("method", fallback_method);
  const bool blocks = method_needs_blocks(method);
  if (layout == "component") return std::make_unique<ComponentLayout>(std::move(s), blocks);
  if (context.levels) return s;
  // A block method, or a Krylov method preconditioned by one, set up on a matrix (not on levels):
  // a scalar Csr is read as blocks or refused (BlockInput).
  std::string preconditioner;  // read without marking keys used (the builder's reads decide that)
  const std::string prefix = config.full_key("");
  for (const auto& [key, value] : config.items()) {
    const std::string k = key.substr(prefix.size());
    if (k == "preconditioner" || k == "preconditioner.method") preconditioner = value;
    else if (preconditioner.empty() && k.rfind("preconditioner.", 0) == 0) preconditioner = "block-jacobi";
  }
  const bool declared = config.has("layout");  // layout=interleaved given: the blocks are declared
  if (blocks) return std::make_unique<BlockInput>(std::move(s), "method " + method, declared);
  if (!preconditioner.empty() && method_needs_blocks(preconditioner))
    return std::make_unique<BlockInput>(std::move(s), "method " + method + " with preconditioner " + preconditioner,
                                        declared);
  return s;
}

namespace {
/// Adds a method, or replaces the one of that name when `replace` (else keeps it).
void insert(const SolverInfo& info, SolverBuilder builder, bool replace) {
  if (info.name.empty() || !builder) throw InputError("register_solver: a name and a builder are needed");
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  for (auto& e : r.entries)
    if (e.info.name == info.name) {
      if (replace) e = {info, std::move(builder)};
      return;
    }
  r.entries.push_back({info, std::move(builder)});
}
}  // namespace

void register_solver(const SolverInfo& info, SolverBuilder builder) { insert(info, std::move(builder), true); }

void register_builtin_solver(const SolverInfo& info, SolverBuilder builder) {
  insert(info, std::move(builder), false);
}

std::vector<SolverInfo> registered_solvers() {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  std::vector<SolverInfo> out;
  for (const auto& e : r.entries) out.push_back(e.info);
  return out;
}

double start_libraries(const Config& config) {
  std::vector<std::function<void()>> hooks;
  {
    Registry& r = registry();
    std::lock_guard<std::mutex> lock(r.mutex);
    for (const std::string& m : named_methods(config)) {
      const Entry* e = r.find(m);
      if (e && e->info.start && r.started.insert(m).second) hooks.push_back(e->info.start);
    }
  }
  if (hooks.empty()) return -1.0;
  const auto t0 = Clock::now();
  for (auto& h : hooks) h();  // outside the lock: a hook may take long (MPI_Init)
  return seconds_since(t0);
}

bool method_uses_levels(const std::string& method) {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  const Entry* e = r.find(method);
  return e && e->info.uses_levels;
}

bool method_needs_blocks(const std::string& method) {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  const Entry* e = r.find(method);
  return e && e->info.needs_blocks;
}

bool method_accepts_key(const std::string& method, const std::string& key) {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  const Entry* e = r.find(method);
  if (!e) return false;
  for (const auto& k : e->info.keys)
    if (k.key == key) return true;
  return false;
}

}  // namespace pmg
