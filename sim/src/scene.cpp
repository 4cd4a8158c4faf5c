#include "pmg/sim/scene.hpp"
#include "pmg/sparse/defaults.hpp"

#include "pmg/fem/elasticity.hpp"
#include "pmg/fem/simulation.hpp"
#include "pmg/solvers.hpp"
#include "pmg/sparse/file_io.hpp"

#include <algorithm>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

namespace pmg::sim {

namespace {

using nlohmann::json;

/// One JSON object of the scene: typed getters that name the key path in every error, and a
/// check that no key was left unread (a misspelt key is an error, not a silent default).
class Section {
 public:
  Section(const std::string& file, const std::string& path, const json& j) : file_(file), path_(path), j_(j) {
    if (!j.is_object()) fail(path_.empty() ? "the scene must be a JSON object" : "expected an object");
  }
  ~Section() noexcept(false) {
    if (std::uncaught_exceptions()) return;
    for (auto it = j_.begin(); it != j_.end(); ++it)
      if (!read_.count(it.key())) {
        std::string known;
        for (const auto& k : read_) known += (known.empty() ? "" : ", ") + k;
        throw InputError(file_ + ": " + key(it.key()) + ": unknown key" +
                         (known.empty() ? "" : " (this section has: " + known + ")"));
      }
  }
  bool has(const std::string& k) {
    read_.insert(k);
    return j_.contains(k);
  }
  const json& at(const std::string& k) {
    read_.insert(k);
    return j_.at(k);
  }
  Section sub(const std::string& k) { return Section(file_, key(k), at(k)); }

  double number(const std::string& k, double fallback) {
    if (!has(k)) return fallback;
    const json& v = j_.at(k);
    if (!v.is_number()) fail_key(k, "expected a number, got " + std::string(v.type_name()));
    const double d = v.get<double>();
    if (!std::isfinite(d)) fail_key(k, "must be finite");
    return d;
  }
  double positive(const std::string& k, double fallback) {
    const double d = number(k, fallback);
    if (!(d > 0)) fail_key(k, "must be > 0, got " + fmt(d));
    return d;
  }
  double nonnegative(const std::string& k, double fallback) {
    const double d = number(k, fallback);
    if (!(d >= 0)) fail_key(k, "must be >= 0, got " + fmt(d));
    return d;
  }
  int integer(const std::string& k, int fallback, int lo, int hi) {
    if (!has(k)) return fallback;
    const json& v = j_.at(k);
    if (!v.is_number_integer()) fail_key(k, "expected an integer, got " + std::string(v.type_name()));
    const long long i = v.get<long long>();
    if (i < lo || i > hi) fail_key(k, "must lie in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + std::to_string(i));
    return static_cast<int>(i);
  }
  bool boolean(const std::string& k, bool fallback) {
    if (!has(k)) return fallback;
    const json& v = j_.at(k);
    if (!v.is_boolean()) fail_key(k, "expected true or false, got " + std::string(v.type_name()));
    return v.get<bool>();
  }
  std::string string(const std::string& k, const std::string& fallback, const std::set<std::string>& allowed = {}) {
    if (!has(k)) return fallback;
    const json& v = j_.at(k);
    if (!v.is_string()) fail_key(k, "expected a string, got " + std::string(v.type_name()));
    std::string s = v.get<std::string>();
    if (!allowed.empty() && !allowed.count(s)) {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      fail_key(k, "'" + s + "' is not one of: " + list);
    }
    return s;
  }
  template <size_t N>
  std::array<double, N> numbers(const std::string& k, std::array<double, N> fallback) {
    if (!has(k)) return fallback;
    const json& v = j_.at(k);
    if (!v.is_array() || v.size() != N) fail_key(k, "expected an array of " + std::to_string(N) + " numbers");
    for (size_t i = 0; i < N; ++i) {
      if (!v[i].is_number()) fail_key(k, "entry " + std::to_string(i) + " is not a number");
      fallback[i] = v[i].get<double>();
      if (!std::isfinite(fallback[i])) fail_key(k, "entry " + std::to_string(i) + " is not finite");
    }
    return fallback;
  }
  fem::Vec3 vec3(const std::string& k, const fem::Vec3& fallback) {
    const auto a = numbers<3>(k, {fallback.x(), fallback.y(), fallback.z()});
    return {a[0], a[1], a[2]};
  }
  [[noreturn]] void fail_key(const std::string& k, const std::string& what) const {
    throw InputError(file_ + ": " + key(k) + ": " + what);
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(file_ + (path_.empty() ? "" : ": " + path_) + ": " + what);
  }

 private:
  std::string key(const std::string& k) const { return path_.empty() ? k : path_ + "." + k; }
  static std::string fmt(double d) {
    std::ostringstream s;
    s << d;
    return s.str();
  }
  std::string file_, path_;
  const json& j_;
  std::set<std::string> read_;
};

int axis_index(Section& sec, const std::string& k, const std::string& name) {
  if (name == "x" || name == "y" || name == "z") return name[0] - 'x';
  sec.fail_key(k, "expected \"x\", \"y\" or \"z\", got '" + name + "'");
}

}  // namespace

Scene read_scene(const std::string& path) {
  return parse_scene(read_text_file(path, kMaxConfigBytes, "scene"), path);
}

namespace {

/// The "mesh" section: a file (relative to the scene's folder) or a box, refinement, allowed defects.
void read_mesh(Section& root, const std::string& path, Scene& s) {
  if (root.has("mesh")) {
    Section m = root.sub("mesh");
    if (m.has("file")) {
      s.mesh_file = m.string("file", "");
      if (s.mesh_file.empty()) m.fail_key("file", "must name a mesh file");
      // Relative to the scene file's folder.
      if (s.mesh_file[0] != '/' && path.find('/') != std::string::npos)
        s.mesh_file = path.substr(0, path.rfind('/') + 1) + s.mesh_file;
      if (!std::ifstream(s.mesh_file)) m.fail_key("file", "cannot open '" + s.mesh_file + "'");
      if (m.has("box") || m.has("size")) m.fail("give either file or box/size, not both");
    } else {
      const auto b = m.numbers<3>("box", {10, 2, 2});
      for (int d = 0; d < 3; ++d) {
        if (b[d] < 1 || b[d] > 1000 || b[d] != std::floor(b[d]))
          m.fail_key("box", "expected three whole numbers of boxes in [1, 1000]");
        s.box[d] = static_cast<int>(b[d]);
      }
      s.size = m.numbers<3>("size", s.size);
      for (double L : s.size)
        if (!(L > 0)) m.fail_key("size", "side lengths must be > 0");
    }
    s.refine = m.integer("refine", 0, 0, 4);
    if (m.has("allow")) {
      const json& a = m.at("allow");
      if (!a.is_array()) m.fail_key("allow", "expected an array of \"tangled\", \"cracked\"");
      for (const json& v : a) {
        try {
          fem::allow_mesh_defect(s.mesh_checks, v.is_string() ? v.get<std::string>() : v.dump());
        } catch (const InputError& e) {
          m.fail_key("allow", e.what());
        }
      }
    }
  }
}

/// The "material" section, with its optional stiffer inclusion.
void read_material(Section& root, Scene& s) {
  if (root.has("material")) {
    Section m = root.sub("material");
    s.corotational = m.string("model", "corotational", {"corotational", "linear"}) == "corotational";
    s.young = m.positive("young", s.young);
    s.poisson = m.number("poisson", s.poisson);
    if (!(s.poisson > -1.0 && s.poisson <= 0.5)) m.fail_key("poisson", "must lie in (-1, 0.5)");
    s.density = m.nonnegative("density", s.density);
    if (m.has("inclusion")) {
      Section inc = m.sub("inclusion");
      s.inclusion = true;
      s.inclusion_min = inc.vec3("min", s.inclusion_min);
      s.inclusion_max = inc.vec3("max", s.inclusion_max);
      s.inclusion_young = inc.positive("young", 0.0);
      if (!(s.inclusion_min.array() < s.inclusion_max.array()).all())
        inc.fail("min must lie below max in every coordinate");
    }
  }
}

/// "clamp", "supports" and "symmetry": what holds the body.
void read_constraints(Section& root, const std::string& path, Scene& s) {
  if (root.has("clamp")) {
    if (root.at("clamp").is_string() && root.at("clamp").get<std::string>() == "none") {
      s.clamp_axis = -1;
    } else {
      Section c = root.sub("clamp");
      s.clamp_axis = axis_index(c, "axis", c.string("axis", "x"));
      s.clamp_fraction = c.nonnegative("fraction", 0.0);
      if (s.clamp_fraction >= 1) c.fail_key("fraction", "must be < 1");
    }
  }
  for (const char* kind : {"supports", "symmetry"}) {
    if (!root.has(kind)) continue;
    const json& list = root.at(kind);
    if (!list.is_array()) root.fail_key(kind, "expected an array of objects ({\"axis\": \"y\", \"at\": \"min\"})");
    for (size_t i = 0; i < list.size(); ++i) {
      Section e(path, std::string(kind) + "[" + std::to_string(i) + "]", list[i]);
      Scene::Support sup;
      if (!e.has("axis")) e.fail("needs an axis (\"x\", \"y\" or \"z\")");
      sup.axis = axis_index(e, "axis", e.string("axis", "x"));
      sup.at_max = e.string("at", "min", {"min", "max"}) == "max";
      if (std::string(kind) == "symmetry") {
        sup.components = 1 << sup.axis;
      } else {
        const std::string comps = e.string("components", "xyz");
        for (char ch : comps) {
          if (ch < 'x' || ch > 'z' || (sup.components & (1 << (ch - 'x'))))
            e.fail_key("components", "expected distinct letters among x, y, z, got '" + comps + "'");
          sup.components |= 1 << (ch - 'x');
        }
        if (sup.components == 0) e.fail_key("components", "holds nothing: name at least one of x, y, z");
      }
      s.supports.push_back(sup);
    }
  }
}

/// "loads", "initial", "time" and "damping".
void read_loads_and_time(Section& root, Scene& s) {
  if (root.has("loads")) {
    Section l = root.sub("loads");
    s.gravity = l.vec3("gravity", s.gravity);
    s.end_force = l.vec3("end_force", s.end_force);
  }
  if (root.has("initial")) {
    Section i = root.sub("initial");
    s.initial = i.string("state", "rest", {"rest", "deflected", "compressed", "twisted", "spinning"});
    if (s.initial == "deflected") s.initial_force = i.vec3("force", s.initial_force);
    if (s.initial == "compressed") {
      s.strain = i.positive("strain", s.strain);
      if (s.strain >= 1) i.fail_key("strain", "must be < 1");
    }
    if (s.initial == "twisted") s.twist_degrees = i.number("degrees", s.twist_degrees);
    if (s.initial == "spinning") s.omega = i.vec3("omega", s.omega);
  } else {
    s.initial = "rest";
  }
  if (root.has("time")) {
    if (root.at("time").is_string() && root.at("time").get<std::string>() == "static") {
      s.dynamic = false;
    } else {
      Section t = root.sub("time");
      s.dt = t.positive("dt", s.dt);
      s.duration = t.positive("duration", s.duration);
      if (const std::string why = s.check_time(); !why.empty()) t.fail(why);
    }
  }
  if (root.has("damping")) {
    Section d = root.sub("damping");
    s.rayleigh_alpha = d.nonnegative("alpha", 0.0);
    s.rayleigh_beta = d.nonnegative("beta", 0.0);
  }
}

/// The "solver" options (completed by the registry's defaults) and "output".
void read_solver_and_output(Section& root, const std::string& path, Scene& s) {
  if (root.has("solver")) {
    // Keys the solver factory renamed (pmgkit 0.1 scene files): a clear pointer, not "unknown key".
    const json& sj = root.at("solver");
    if (!sj.is_object()) root.fail_key("solver", "expected an object of solver options");
    static const std::pair<const char*, const char*> renamed[] = {
        {"sweeps", "smoother.sweeps"}, {"lowest_level_cycles", "lowest_level.cycles"},
        {"lowest_level_tol", "lowest_level.tol"}};
    for (const auto& [old_key, new_key] : renamed)
      if (sj.contains(old_key))
        root.fail_key(std::string("solver.") + old_key, std::string("renamed \"") + new_key +
                                                            "\" (nested: {\"" +
                                                            std::string(new_key).substr(0, std::string(new_key).find('.')) +
                                                            "\": {...}})");
    s.solver = Config::from_json(sj.dump(), path + ": solver");
    Scene::set_solver_defaults(s.solver, s.dynamic, s.formulation == "mixed");
  } else if (!s.dynamic || s.formulation == "mixed") {
    s.solver = Scene::default_solver(s.dynamic, s.formulation == "mixed");
  }
  if (root.has("output")) {
    Section o = root.sub("output");
    s.output = o.string("directory", "");
    s.frame_every = o.integer("frame_every", s.frame_every, 0, 1000000000);
    s.energy = o.boolean("energy", s.energy);
    if (o.has("probe")) s.probe = o.vec3("probe", fem::Vec3::Zero());
  }
}

/// "formulation": "auto" made concrete (Scene::formulation_choice says why).
void resolve_auto_formulation(Scene& s) {
  if (s.formulation != "auto") return;
  char nu[32];
  std::snprintf(nu, sizeof nu, "%g", s.poisson);
  char limit[32];
  std::snprintf(limit, sizeof limit, "%g", kMixedFromPoisson);
  const char* why = outside_mixed_scope(s);
  if (s.poisson < kMixedFromPoisson) {
    s.formulation = "displacement";
    s.formulation_choice = std::string("formulation auto: displacement (nu = ") + nu + " < " + limit + ")";
  } else if (why) {
    s.formulation = "displacement";
    s.formulation_choice = std::string("formulation auto: displacement, although nu = ") + nu + " >= " + limit +
                           " (the mixed formulation needs " + why + "); expect locking and slow solves";
  } else {
    s.formulation = "mixed";
    s.formulation_choice = std::string("formulation auto: mixed (nu = ") + nu + " >= " + limit + ")";
  }
}

/// Combinations of sections, checked before any work.
void check_combinations(Section& root, const Scene& s) {
  // Combinations, checked before any work.
  if (!s.dynamic && s.clamp_axis < 0) root.fail("a static scene needs a clamp (nothing holds the body)");
  if (s.dynamic && s.density == 0) root.fail("material.density: a dynamic scene needs a density > 0");
  if (s.initial == "spinning" && s.clamp_axis >= 0)
    root.fail("initial.state spinning needs \"clamp\": \"none\" (a clamped body cannot spin freely)");
  if ((s.initial == "deflected" || s.initial == "compressed" || s.initial == "twisted") && s.clamp_axis < 0)
    root.fail("initial.state " + s.initial + " is measured from the clamp: give a clamp");
  if (s.poisson == 0.5 && s.formulation != "mixed")
    root.fail("material.poisson: must lie in (-1, 0.5) for the displacement formulation; 0.5 (incompressible) "
              "needs \"formulation\": \"mixed\"" +
              (s.formulation_choice.empty() ? std::string() : " (" + s.formulation_choice + ")"));
  if (s.formulation == "mixed") {
    if (const char* why = outside_mixed_scope(s))
      root.fail(std::string("formulation mixed: ") + why + " (the mixed route's scope for now)");
    if (s.poisson == 0.5 && (s.initial == "compressed" || s.initial == "twisted"))
      root.fail("initial.state " + s.initial + " at material.poisson 0.5: a deformed start changes the volume, which "
                "an incompressible material cannot (no finite energy); start at rest or deflected");
  }
  if (!s.supports.empty() && (s.initial == "compressed" || s.initial == "twisted" || s.initial == "spinning"))
    root.fail("initial.state " + s.initial + " prescribes a displacement or motion that supports and symmetry "
              "planes would contradict: use rest or deflected with them");
}

}  // namespace

Scene parse_scene(const std::string& text, const std::string& path) {
  // Syntax, duplicate keys and numbers beyond double range, named before the content is read.
  check_json_text(text, path);
  const json j = json::parse(text);
  Scene s;
  s.source = path;
  Section root(path, "", j);
  read_mesh(root, path, s);
  s.degree = root.integer("degree", s.degree, 1, 3);
  s.formulation = root.string("formulation", s.formulation, {"displacement", "mixed", "auto"});
  read_material(root, s);
  read_constraints(root, path, s);
  read_loads_and_time(root, s);
  resolve_auto_formulation(s);  // before the solver's defaults, which depend on it
  read_solver_and_output(root, path, s);
  if (root.has("name")) s.source = root.string("name", s.source) + " (" + path + ")";
  check_combinations(root, s);
  return s;
}

const char* outside_mixed_scope(const Scene& s) {
  return s.degree < 2 ? "degree 2 or 3 (a pressure of degree k - 1 >= 1)"
         : !(s.poisson > 0) ? "material.poisson in (0, 0.5]"
         : s.inclusion ? "no material.inclusion"
         : s.rayleigh_beta != 0 ? "no stiffness-proportional damping (damping.beta 0)"
                                : nullptr;
}

std::string Scene::check_time() const {
  std::ostringstream why;
  if (!(std::isfinite(dt) && dt > 0)) why << "dt must be a finite time > 0, got " << dt;
  else if (!(std::isfinite(duration) && duration > 0)) why << "duration must be a finite time > 0, got " << duration;
  else if (duration / dt > kMaxSteps)
    why << "duration " << duration << " s at dt " << dt << " s is " << duration / dt << " steps, more than "
        << kMaxSteps;
  else if (duration < 0.5 * dt)
    why << "duration " << duration << " s is shorter than half a step of dt " << dt << " s: no step would run";
  else if (const double max_dt = fem::max_time_step(std::max(young, inclusion_young), rayleigh_beta); dt > max_dt)
    why << "dt " << dt << " s makes the step matrix M + dt^2 K overflow double precision (dt^2 times "
        << "Young's modulus); use a time step below " << max_dt << " s";
  return why.str();
}

Scene table_bar() {
  Scene s;
  s.source = "the seed's box bar";
  s.box = {5, 1, 1};
  s.size = {1.0, 0.2, 0.2};
  const fem::Material m;
  s.young = m.young, s.poisson = m.poisson, s.density = m.density;
  s.clamp_axis = 0;
  s.end_force = fem::Vec3(0, 0, -10.0);
  s.dynamic = false;
  s.solver = Scene::default_solver(false);
  return s;
}

Config Scene::default_solver(bool dynamic, bool mixed) {
  Config c = Config::from_pairs({}, "scene solver");
  set_solver_defaults(c, dynamic, mixed);
  return c;
}

void Scene::set_solver_defaults(Config& c, bool dynamic, bool mixed) {
  register_all_solvers();
  if (mixed) {
    c.set_default("method", "mixed-gmres");
    // 1e-5 per step: GMRES to 1e-3 let the energy of scenes/rubber_mixed.json rise by 0.6% in a
    // step and end 1% off; 1e-5 ends within 1e-4 of 1e-6's (docs/robustness.md). 1e-10 static.
    if (method_accepts_key(c.get_string("method", "mixed-gmres"), "max_iterations")) {
      c.set_default("tol", dynamic ? "1e-5" : "1e-10");
      c.set_default("max_iterations", dynamic ? "1000" : "10000");
    }
    return;
  }
  // Dynamic: PMG to 1e-3 per step (the seed's setting), at most 1000 iterations. Static: CHOLMOD,
  // or an iterative method to 1e-10 (the fixed point's accuracy is the solves').
  c.set_default("method", dynamic ? kDefaultDynamicMethod : kDefaultDirectMethod);
  const std::string method = c.get_string("method", kDefaultDynamicMethod);
  // Iterative methods (those with an iteration limit) get the scene's stopping rule; a direct
  // solver keeps its own check (DirectSolveParams: a residual any sound factorisation meets).
  if (!c.has("fixed_iterations") && method_accepts_key(method, "max_iterations")) {
    c.set_default("tol", dynamic ? "1e-3" : "1e-10");
    c.set_default("max_iterations", dynamic ? "1000" : "10000");
  }
}

std::string scene_to_json(const Scene& s) {
  json j;
  if (s.mesh_file.empty()) j["mesh"] = {{"box", s.box}, {"size", s.size}};
  else j["mesh"] = {{"file", s.mesh_file}};
  if (s.refine > 0) j["mesh"]["refine"] = s.refine;
  if (const auto allowed = fem::allowed_mesh_defects(s.mesh_checks); !allowed.empty()) j["mesh"]["allow"] = allowed;
  j["degree"] = s.degree;
  if (s.formulation != "displacement") j["formulation"] = s.formulation;
  j["material"] = {{"model", s.corotational ? "corotational" : "linear"},
                   {"young", s.young}, {"poisson", s.poisson}, {"density", s.density}};
  if (s.inclusion)
    j["material"]["inclusion"] = {{"min", std::array<double, 3>{s.inclusion_min.x(), s.inclusion_min.y(), s.inclusion_min.z()}},
                                  {"max", std::array<double, 3>{s.inclusion_max.x(), s.inclusion_max.y(), s.inclusion_max.z()}},
                                  {"young", s.inclusion_young}};
  if (s.clamp_axis < 0) j["clamp"] = "none";
  else j["clamp"] = {{"axis", std::string(1, static_cast<char>('x' + s.clamp_axis))}, {"fraction", s.clamp_fraction}};
  if (!s.supports.empty()) {
    json list = json::array();
    for (const auto& sup : s.supports) {
      std::string comps;
      for (int c = 0; c < 3; ++c)
        if (sup.components & (1 << c)) comps += static_cast<char>('x' + c);
      list.push_back({{"axis", std::string(1, static_cast<char>('x' + sup.axis))},
                      {"at", sup.at_max ? "max" : "min"}, {"components", comps}});
    }
    j["supports"] = list;
  }
  auto vec = [](const fem::Vec3& v) { return std::array<double, 3>{v.x(), v.y(), v.z()}; };
  j["loads"] = {{"gravity", vec(s.gravity)}, {"end_force", vec(s.end_force)}};
  json init = {{"state", s.initial}};
  if (s.initial == "deflected") init["force"] = vec(s.initial_force);
  if (s.initial == "compressed") init["strain"] = s.strain;
  if (s.initial == "twisted") init["degrees"] = s.twist_degrees;
  if (s.initial == "spinning") init["omega"] = vec(s.omega);
  j["initial"] = init;
  if (s.dynamic) j["time"] = {{"dt", s.dt}, {"duration", s.duration}};
  else j["time"] = "static";
  j["damping"] = {{"alpha", s.rayleigh_alpha}, {"beta", s.rayleigh_beta}};
  j["solver"] = json::parse(s.solver.to_json());
  json out = {{"directory", s.output}, {"frame_every", s.frame_every}, {"energy", s.energy}};
  if (s.probe) out["probe"] = vec(*s.probe);
  j["output"] = out;
  return j.dump(2) + "\n";
}

}  // namespace pmg::sim
