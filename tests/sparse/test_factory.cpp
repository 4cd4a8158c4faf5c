// The solver core's registry on its own: the core methods need no registration and no other
// component, each key is read and listed from one visit(), and unknown methods name the remedy.
#include "pmg/sparse/factory.hpp"
#include "pmg/sparse/generators.hpp"

#include <catch2/catch.hpp>

#include <limits>
#include <set>

using namespace pmg;

namespace {

/// A parameter struct of the shape every component uses.
struct Example {
  int sweeps = 5;
  double omega = 0.6;
  bool on = true;
  std::string mode = "a";
  void visit(ParamVisitor& v) {
    v.integer("sweeps", sweeps, 0, 10, "sweeps");
    v.real("omega", omega, 0.0, 2.0, "damping");
    v.boolean("on", on, "switch");
    v.choice("mode", mode, {"a", "b"}, "mode");
    v.solver("inner", "jacobi", "an inner solver");
  }
};

}  // namespace

TEST_CASE("a parameter struct's visit() both reads and lists its keys", "[sparse][factory]") {
  const std::vector<KeyInfo> keys = list_params<Example>();
  REQUIRE(keys.size() == 5);
  CHECK(keys[0].key == "sweeps");
  CHECK(keys[0].default_value == "5");
  CHECK(keys[0].range == "[0, 10]");
  CHECK(keys[1].default_value == "0.6");
  CHECK(keys[2].default_value == "true");
  CHECK(keys[3].range == "a | b");
  CHECK(keys[4].key == "inner.*");
  CHECK(keys[4].type == "solver");

  const Config c = Config::from_pairs({"sweeps=7", "omega=1.5", "on=false", "mode=b"}, "test");
  const Example e = read_params<Example>(c);
  CHECK(e.sweeps == 7);
  CHECK(e.omega == 1.5);
  CHECK_FALSE(e.on);
  CHECK(e.mode == "b");
  CHECK_NOTHROW(c.check_all_used());
  // Out of range and a word outside the choice name the key.
  CHECK_THROWS_WITH(read_params<Example>(Config::from_pairs({"sweeps=11"}, "test")), Catch::Contains("sweeps"));
  CHECK_THROWS_WITH(read_params<Example>(Config::from_pairs({"mode=c"}, "test")), Catch::Contains("mode"));
}

TEST_CASE("the listed defaults are the values a reader returns for an empty config", "[sparse][factory]") {
  const KrylovParams read = read_krylov(Config::from_pairs({}, "test"));
  const KrylovParams defaults;
  CHECK(read.rel_tol == defaults.rel_tol);
  CHECK(read.max_iterations == defaults.max_iterations);
  for (const KeyInfo& k : krylov_keys()) {
    if (k.key == "tol") CHECK(k.default_value == "1e-08");
    if (k.key == "max_iterations") CHECK(k.default_value == std::to_string(defaults.max_iterations));
  }
  // Krylov keys are CG's keys: what the registry lists is what the builder reads.
  std::set<std::string> listed;
  for (const KeyInfo& k : solver_info("cg").keys) listed.insert(k.key);
  for (const KeyInfo& k : krylov_keys()) CHECK(listed.count(k.key));
  CHECK(listed.count("preconditioner.*"));
  CHECK(method_accepts_key("mcg", "check_every"));
  CHECK_FALSE(method_accepts_key("cg", "check_every"));
}

TEST_CASE("the core's methods solve without registering any component", "[sparse][factory]") {
  const Bcsr A = spring_lattice(6);
  const Vector x_true = smooth_field(6);
  Vector b;
  A.apply(x_true, b);
  for (const char* method : {"cg", "jacobi-pcg", "block-jacobi-pcg", "mcg"}) {
    auto s = make_solver(Config::from_pairs({std::string("method=") + method, "tol=1e-10"}, "test"));
    s->setup(A);
    Vector x;
    const SolveResult r = s->solve(b, x);
    CHECK(r.status == SolveStatus::converged);
    CHECK((x - x_true).norm() <= 1e-6 * x_true.norm());
  }
  // A core method needs nothing from an FEM hierarchy and starts no library.
  auto cg = make_solver(Config::from_pairs({"method=cg", "preconditioner=block-jacobi"}, "test"));
  CHECK_FALSE(cg->needs().lower_levels);
  CHECK_FALSE(cg->needs().matrix_free);
  CHECK(cg->timings().empty());
  CHECK(start_libraries(Config::from_pairs({"method=cg"}, "test")) < 0);
}

TEST_CASE("an unregistered method names the registered ones and how to add the rest", "[sparse][factory][errors]") {
  // This program links the core alone (tests/sparse), so mgpcg is not registered.
  CHECK_THROWS_WITH(make_solver(Config::from_pairs({"method=mgpcg"}, "test")),
                    Catch::Contains("unknown method 'mgpcg'") && Catch::Contains("register_all_solvers") &&
                        Catch::Contains("block-jacobi-pcg"));
}

TEST_CASE("a registered method's start-up hook runs once per process, before the clocks", "[sparse][factory]") {
  int started = 0;
  SolverInfo info{"test-started", "a method with a start-up hook", {}, false, false, "test"};
  info.start = [&started] { ++started; };
  register_solver(info, [](const Config&, const SolverContext&) { return make_solver(Config::from_pairs({}, "x")); });
  const Config c = Config::from_pairs({"method=cg", "preconditioner.method=test-started"}, "test");
  CHECK(start_libraries(c) >= 0);
  CHECK(start_libraries(c) < 0);  // started already: no time to charge
  CHECK(started == 1);
}

TEST_CASE("unused_keys: error by default, known keys allowed for a shared option set, or ignored",
          "[sparse][factory][errors]") {
  const Bcsr A = spring_lattice(4);
  // block-jacobi reads no key: tol, which the Krylov methods read, is left unused.
  CHECK_THROWS_WITH(make_solver(Config::from_pairs({"method=block-jacobi", "tol=1e-8"}, "loop")),
                    Catch::Contains("unused key tol"));
  const Config known = Config::from_pairs({"method=block-jacobi", "tol=1e-8", "unused_keys=known"}, "loop");
  auto s = make_solver(known);
  s->setup(A);
  CHECK(known.unused_keys() == std::vector<std::string>{"tol"});
  // A key no method reads is still an error under `known` (a misspelt tol)...
  CHECK_THROWS_WITH(make_solver(Config::from_pairs({"method=block-jacobi", "tpl=1e-8", "unused_keys=known"}, "loop")),
                    Catch::Contains("unused key tpl"));
  // ... as are keys of a sub-solver no method has, while one some method has passes.
  CHECK_THROWS_WITH(make_solver(Config::from_pairs({"method=jacobi", "colour.x=1", "unused_keys=known"}, "loop")),
                    Catch::Contains("colour.x"));
  const Config nested = Config::from_pairs({"method=jacobi", "preconditioner.method=jacobi", "unused_keys=known"}, "loop");
  make_solver(nested);
  CHECK(nested.unused_keys() == std::vector<std::string>{"preconditioner.method"});
  // ignore: anything goes, still listed.
  const Config ignore = Config::from_pairs({"method=block-jacobi", "tpl=1", "unused_keys=ignore"}, "loop");
  make_solver(ignore);
  CHECK(ignore.unused_keys() == std::vector<std::string>{"tpl"});
  CHECK_THROWS_WITH(make_solver(Config::from_pairs({"method=cg", "unused_keys=warn"}, "loop")),
                    Catch::Contains("unused_keys"));
  // The factory's own keys are listed like a method's.
  std::set<std::string> names;
  for (const KeyInfo& k : factory_keys()) names.insert(k.key);
  CHECK(names == std::set<std::string>{"layout", "unused_keys"});
}
