#include "engine/config_schema.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>

namespace vimd {

namespace {

using Read = std::function<void(const KeyInput&, RunConfig&)>;
using Value = std::function<std::string(const RunConfig&)>;
constexpr OnContinue kMustMatch = OnContinue::must_match;
constexpr OnContinue kMayChange = OnContinue::may_change;

std::string integer_text(long x) { return std::to_string(x); }

// FNV-1a over the bytes of what is added: any change shows.
class Fingerprint {
 public:
  template <class T>
  void add(const T& x) {
    const auto* p = reinterpret_cast<const unsigned char*>(&x);
    for (std::size_t k = 0; k < sizeof x; ++k) hash_ = (hash_ ^ p[k]) * 1099511628211ull;
  }
  void add_all(const Eigen::MatrixXd& m) {
    for (Eigen::Index k = 0; k < m.size(); ++k) add(m.data()[k]);
  }
  std::string text() const {
    char buf[20];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(hash_));
    return buf;
  }

 private:
  std::uint64_t hash_ = 14695981039346656037ull;
};

std::string tableau_text(const std::optional<TableauConfig>& tableau) {
  if (!tableau) return "(none)";
  Fingerprint f;
  for (const auto& row : tableau->a)
    for (double x : row) f.add(x);
  for (double x : tableau->b) f.add(x);
  for (double x : tableau->c) f.add(x);
  f.add(tableau->order);
  return "fingerprint " + f.text();
}

std::size_t levenshtein(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

// A key whose value is a number (or integer) field checked on its own, or a string field with a
// fixed set of choices: the reader, the check and the value text from the field alone.
template <auto Section, auto Field>
ConfigKey number_key(std::string section, std::string name, std::string type, OnContinue on_continue, std::string help,
                     bool (*valid)(double), std::string problem) {
  return {std::move(section),
          std::move(name),
          std::move(type),
          {},
          on_continue,
          std::move(help),
          [valid, problem](const KeyInput& in, RunConfig& c) {
            (c.*Section).*Field = in.number();
            in.require(valid((c.*Section).*Field), problem);
          },
          [](const RunConfig& c) { return exact_text((c.*Section).*Field); }};
}

template <auto Section, auto Field>
ConfigKey integer_key(std::string section, std::string name, std::string type, OnContinue on_continue, std::string help,
                      bool (*valid)(long), std::string problem) {
  return {std::move(section),
          std::move(name),
          std::move(type),
          {},
          on_continue,
          std::move(help),
          [valid, problem](const KeyInput& in, RunConfig& c) {
            const long value = in.integer();
            in.require(valid(value), problem);
            (c.*Section).*Field = value;
          },
          [](const RunConfig& c) { return std::to_string((c.*Section).*Field); }};
}

template <auto Section, auto Field>
ConfigKey choice_key(std::string section, std::string name, std::vector<std::string> choices, OnContinue on_continue,
                     std::string help) {
  return {std::move(section),
          std::move(name),
          "string",
          std::move(choices),
          on_continue,
          std::move(help),
          [](const KeyInput& in, RunConfig& c) { (c.*Section).*Field = in.choice(); },
          [](const RunConfig& c) { return (c.*Section).*Field; }};
}

std::vector<ConfigKey> make_keys() {
  const std::vector<std::string> vdw_modifiers = {"none", "potential-shift", "force-switch", "potential-switch"};
  std::vector<ConfigKey> k;
  // --- [system]
  k.push_back({"system",
               "structure",
               "path",
               {},
               kMayChange,
               "GROMACS .gro with positions (and velocities); relative to the run file. Required",
               [](const KeyInput& in, RunConfig& c) { c.structure = in.existing_file(); },
               [](const RunConfig& c) { return c.structure.string(); }});
  k.push_back({"system",
               "topology",
               "path",
               {},
               kMayChange,
               "GROMACS .top; #include resolves next to the file, then GMXLIB or /usr/share/gromacs/top. Required",
               [](const KeyInput& in, RunConfig& c) { c.topology = in.existing_file(); },
               [](const RunConfig& c) { return c.topology.string(); }});
  k.push_back({"system",
               "constraints",
               "string",
               {"none", "h-bonds", "all-bonds"},
               kMustMatch,
               "bonds made rigid constraints at their b0, as GROMACS's mdp option (h-bonds: bonds to an atom "
               "whose name starts with H)",
               [](const KeyInput& in, RunConfig& c) { c.constraints = in.choice(); },
               [](const RunConfig& c) { return c.constraints; }});
  // --- [forcefield]
  k.push_back(number_key<&RunConfig::forcefield, &ForceFieldConfig::cutoff>(
      "forcefield", "cutoff", "number, nm", kMustMatch, "cut-off of LJ and Coulomb (rvdw = rcoulomb)",
      [](double v) { return v > 0; }, "cutoff must be positive (nm)"));
  k.push_back(choice_key<&RunConfig::forcefield, &ForceFieldConfig::vdw_modifier>(
      "forcefield", "vdw_modifier", vdw_modifiers, kMustMatch, "LJ at the cut-off, as GROMACS's vdw-modifier"));
  k.push_back(number_key<&RunConfig::forcefield, &ForceFieldConfig::vdw_switch>(
      "forcefield", "vdw_switch", "number, nm", kMustMatch, "start of the LJ switch (force-switch, potential-switch)",
      [](double v) { return v >= 0; }, "vdw_switch must not be negative (nm)"));
  k.push_back(choice_key<&RunConfig::forcefield, &ForceFieldConfig::coulomb>(
      "forcefield", "coulomb", {"reaction-field", "cutoff", "pme", "none"}, kMustMatch,
      "electrostatics: reaction field (epsilon_rf), plain cut-off, smooth particle-mesh Ewald, or none"));
  k.push_back(choice_key<&RunConfig::forcefield, &ForceFieldConfig::coulomb_modifier>(
      "forcefield", "coulomb_modifier", {"none", "potential-shift", "potential-switch"}, kMustMatch,
      "as GROMACS's; reaction field is shifted either way; potential-switch multiplies Coulomb (PME: its real "
      "space) by the switch (not a GROMACS option)"));
  k.push_back(number_key<&RunConfig::forcefield, &ForceFieldConfig::coulomb_switch>(
      "forcefield", "coulomb_switch", "number, nm", kMustMatch,
      "start of the Coulomb switch (required with coulomb_modifier = \"potential-switch\")",
      [](double v) { return v >= 0; }, "coulomb_switch must not be negative (nm)"));
  k.push_back({"forcefield",
               "switch_smoothness",
               "integer, 2-6",
               {},
               kMustMatch,
               "k: potential-switched pair potentials are C^k at both ends of the switch (2 is GROMACS's)",
               [](const KeyInput& in, RunConfig& c) {
                 const long smoothness = in.integer();
                 in.require(smoothness >= 2 && smoothness <= 6,
                            "switch_smoothness must be between 2 and 6 (continuous derivatives of a potential-switch "
                            "pair potential; 2 is GROMACS's), got " +
                                std::to_string(smoothness));
                 c.forcefield.switch_smoothness = static_cast<int>(smoothness);
               },
               [](const RunConfig& c) { return integer_text(c.forcefield.switch_smoothness); }});
  k.push_back(number_key<&RunConfig::forcefield, &ForceFieldConfig::epsilon_r>(
      "forcefield", "epsilon_r", "number", kMustMatch, "relative dielectric constant", [](double v) { return v > 0; },
      "epsilon_r must be positive"));
  k.push_back(number_key<&RunConfig::forcefield, &ForceFieldConfig::epsilon_rf>(
      "forcefield", "epsilon_rf", "number", kMustMatch, "reaction-field dielectric constant; 0 means infinity",
      [](double v) { return v >= 0; }, "epsilon_rf must not be negative (0 means infinity)"));
  k.push_back(number_key<&RunConfig::forcefield, &ForceFieldConfig::ewald_rtol>(
      "forcefield", "ewald_rtol", "number", kMustMatch,
      "PME: erfc(beta r) at the cut-off, or at coulomb_switch when the real space is switched",
      [](double v) { return v > 0 && v < 0.1; }, "ewald_rtol must be between 0 and 0.1 (exclusive)"));
  k.push_back(integer_key<&RunConfig::forcefield, &ForceFieldConfig::pme_order>(
      "forcefield", "pme_order", "integer, 4-12", kMustMatch, "PME: B-spline interpolation order (GROMACS's pme-order)",
      [](long v) { return v >= 4 && v <= 12; }, "pme_order must be between 4 and 12"));
  k.push_back(number_key<&RunConfig::forcefield, &ForceFieldConfig::fourier_spacing>(
      "forcefield", "fourier_spacing", "number, nm", kMustMatch,
      "PME: largest grid spacing; the grid sizes follow as GROMACS chooses them", [](double v) { return v > 0; },
      "fourier_spacing must be positive (nm)"));
  for (int d = 0; d < 3; ++d) {
    const std::string name = std::string("fourier_n") + "xyz"[d];
    k.push_back({"forcefield",
                 name,
                 "integer",
                 {},
                 kMustMatch,
                 std::string("PME: grid points along ") + "xyz"[d] + " (unset or 0: from fourier_spacing)",
                 [d, name](const KeyInput& in, RunConfig& c) {
                   const long n = in.integer();
                   in.require(n >= 0 && n <= 4096, name + " must be between 0 and 4096");
                   c.forcefield.fourier_n[d] = static_cast<int>(n);
                 },
                 [d](const RunConfig& c) { return integer_text(c.forcefield.fourier_n[d]); }});
  }
  k.push_back(number_key<&RunConfig::forcefield, &ForceFieldConfig::neighbor_skin>(
      "forcefield", "neighbor_skin", "number, nm", kMustMatch,
      "buffer of the pair list the kernels run over; re-pruned when an atom moved half of it",
      [](double v) { return v >= 0; }, "neighbor_skin must not be negative (nm)"));
  k.push_back({"forcefield",
               "neighbor_search_skin",
               "number, nm",
               {},
               kMustMatch,
               "buffer of the searched list it is pruned from (unset: neighbor_skin + 0.6, as the box allows)",
               [](const KeyInput& in, RunConfig& c) { c.forcefield.neighbor_search_skin = in.number(); },
               [](const RunConfig& c) {
                 return c.forcefield.neighbor_search_skin ? exact_text(*c.forcefield.neighbor_search_skin)
                                                          : std::string("(automatic)");
               }});
  k.push_back(choice_key<&RunConfig::forcefield, &ForceFieldConfig::precision>(
      "forcefield", "precision", {"double", "mixed"}, kMustMatch,
      "mixed: pair forces in single precision, as GROMACS's default build (not with vi or rk)"));
  // --- [integrator]
  k.push_back(choice_key<&RunConfig::integrator, &IntegratorConfig::type>(
      "integrator", "type", {"verlet", "shake", "rattle", "vi", "rk", "minimize"}, kMustMatch,
      "the integrator (vi: variational from a Runge-Kutta method; rk: projected Runge-Kutta)"));
  k.push_back(number_key<&RunConfig::integrator, &IntegratorConfig::dt>(
      "integrator", "dt", "number, ps", kMustMatch, "time step", [](double v) { return v > 0; },
      "dt must be positive (ps)"));
  k.push_back(integer_key<&RunConfig::integrator, &IntegratorConfig::steps>(
      "integrator", "steps", "integer", kMayChange, "steps to run (a continued run goes on up to it)",
      [](long v) { return v >= 0; }, "steps must not be negative"));
  k.push_back(number_key<&RunConfig::integrator, &IntegratorConfig::constraint_tolerance>(
      "integrator", "constraint_tolerance", "number", kMustMatch,
      "relative deviation |r - d|/d each constraint is solved to", [](double v) { return v > 0 && v < 1; },
      "constraint_tolerance is relative and must be in (0, 1)"));
  k.push_back({"integrator",
               "temperature",
               "number, K",
               {},
               kMustMatch,
               "generates velocities when the .gro has none; the thermostat's reference",
               [](const KeyInput& in, RunConfig& c) {
                 c.integrator.temperature = in.number();
                 in.require(*c.integrator.temperature >= 0, "temperature must not be negative (K)");
               },
               [](const RunConfig& c) {
                 return c.integrator.temperature ? exact_text(*c.integrator.temperature) : std::string("(none)");
               }});
  k.push_back({"integrator",
               "seed",
               "integer",
               {},
               kMustMatch,
               "seed of the velocity generation and the thermostat's random stream",
               [](const KeyInput& in, RunConfig& c) {
                 const long seed = in.integer();
                 in.require(seed >= 0, "seed must not be negative");
                 c.integrator.seed = static_cast<std::uint64_t>(seed);
               },
               [](const RunConfig& c) { return std::to_string(c.integrator.seed); }});
  k.push_back(choice_key<&RunConfig::integrator, &IntegratorConfig::thermostat>(
      "integrator", "thermostat", {"none", "v-rescale"}, kMustMatch,
      "v-rescale (Bussi) with verlet and rattle; needs temperature"));
  k.push_back(number_key<&RunConfig::integrator, &IntegratorConfig::tau_t>(
      "integrator", "tau_t", "number, ps", kMustMatch, "the thermostat's time constant",
      [](double v) { return v >= 0; }, "tau_t must not be negative (ps)"));
  k.push_back(choice_key<&RunConfig::integrator, &IntegratorConfig::composition>(
      "integrator", "composition", {"none", "yoshida4", "suzuki4", "kahan-li6", "kahan-li8", "user"}, kMustMatch,
      "rattle: each step a symmetric composition of RATTLE sub-steps, orders 4, 4, 6, 8 in 3, 5, 9, 17 sub-steps "
      "(one force evaluation each), or user (composition_weights, composition_order)"));
  k.push_back({"integrator",
               "composition_weights",
               "array of numbers",
               {},
               kMustMatch,
               "composition = \"user\": the sub-steps as fractions of dt, symmetric, summing to 1",
               [](const KeyInput& in, RunConfig& c) {
                 c.integrator.composition_weights = in.numbers();
                 in.require(!c.integrator.composition_weights.empty(), "composition_weights must not be empty");
               },
               [](const RunConfig& c) {
                 if (c.integrator.composition_weights.empty()) return std::string("(none)");
                 std::string text;
                 for (double w : c.integrator.composition_weights) text += (text.empty() ? "[" : ", ") + exact_text(w);
                 return text + "]";
               }});
  k.push_back({"integrator",
               "composition_order",
               "integer, 2-10",
               {},
               kMustMatch,
               "composition = \"user\": the order composition_weights claim, checked against the order conditions",
               [](const KeyInput& in, RunConfig& c) {
                 const long order = in.integer();
                 in.require(order >= 2 && order <= 10 && order % 2 == 0,
                            "composition_order must be 2, 4, 6, 8 or 10 (a symmetric composition has even order), "
                            "got " + std::to_string(order));
                 c.integrator.composition_order = static_cast<int>(order);
               },
               [](const RunConfig& c) {
                 return c.integrator.composition_order ? integer_text(c.integrator.composition_order)
                                                       : std::string("(none)");
               }});
  k.push_back(number_key<&RunConfig::integrator, &IntegratorConfig::emtol>(
      "integrator", "emtol", "number, kJ/mol/nm", kMustMatch,
      "minimize: stop when the largest constrained force is below this", [](double v) { return v > 0; },
      "emtol must be positive (kJ/mol/nm)"));
  k.push_back(number_key<&RunConfig::integrator, &IntegratorConfig::emstep>(
      "integrator", "emstep", "number, nm", kMustMatch, "minimize: the first step's largest displacement",
      [](double v) { return v > 0; }, "emstep must be positive (nm)"));
  k.push_back({"integrator",
               "method",
               "string",
               {},
               kMustMatch,
               "vi, rk: the tableau: euler heun2 midpoint rk3 rk4 rk38 rk6 rk8, or user ([integrator.tableau])",
               [](const KeyInput& in, RunConfig& c) {
                 c.integrator.method = in.string();
                 in.require(!c.integrator.method.empty(), "method must not be empty");
               },
               [](const RunConfig& c) { return c.integrator.method; }});
  k.push_back({"integrator",
               "method_minus",
               "string",
               {},
               kMustMatch,
               "vi: the method of the left discrete Lagrangian (unset: the same as method)",
               [](const KeyInput& in, RunConfig& c) {
                 c.integrator.method_minus = in.string();
                 in.require(!c.integrator.method_minus->empty(), "method_minus must not be empty");
               },
               [](const RunConfig& c) { return c.integrator.method_minus.value_or("(same)"); }});
  k.push_back({"integrator",
               "bias",
               "array of two numbers",
               {},
               kMustMatch,
               "vi: [alpha_minus, alpha_plus], where the discrete Lagrangians sit in the step",
               [](const KeyInput& in, RunConfig& c) {
                 const auto bias = in.numbers();
                 in.require(bias.size() == 2, "bias must have two numbers [alpha_minus, alpha_plus]");
                 c.integrator.bias = {bias[0], bias[1]};
               },
               [](const RunConfig& c) {
                 return "[" + exact_text(c.integrator.bias[0]) + ", " + exact_text(c.integrator.bias[1]) + "]";
               }});
  k.push_back(choice_key<&RunConfig::integrator, &IntegratorConfig::projection>(
      "integrator", "projection", {"euclidean", "mass"}, kMustMatch,
      "vi: the metric of the projection onto the constraint manifold"));
  k.push_back({"integrator",
               "solver_tolerance",
               "number, nm/ps, or \"auto\"",
               {},
               kMustMatch,
               "vi: the step equations' tolerance (unset: the method's default; \"auto\": a fraction of the last "
               "step's truncation-error scale)",
               [](const KeyInput& in, RunConfig& c) {
                 if (in.is_string()) {
                   in.require(in.string() == "auto",
                              "solver_tolerance must be a positive number (nm/ps) or \"auto\", not \"" + in.string() +
                                  "\"");
                   c.integrator.solver_tolerance_auto = true;
                   return;
                 }
                 c.integrator.solver_tolerance = in.number();
                 in.require(*c.integrator.solver_tolerance > 0, "solver_tolerance must be positive");
               },
               [](const RunConfig& c) {
                 if (c.integrator.solver_tolerance_auto) return std::string("auto");
                 return c.integrator.solver_tolerance ? exact_text(*c.integrator.solver_tolerance)
                                                      : std::string("(default)");
               }});
  k.push_back({"integrator",
               "max_iterations",
               "integer",
               {},
               kMustMatch,
               "vi: iterations of a step's solve before it is an error",
               [](const KeyInput& in, RunConfig& c) {
                 const long iterations = in.integer();
                 in.require(iterations >= 1 && iterations <= 1000000, "max_iterations must be between 1 and 1000000");
                 c.integrator.max_iterations = static_cast<int>(iterations);
               },
               [](const RunConfig& c) { return integer_text(c.integrator.max_iterations); }});
  k.push_back(choice_key<&RunConfig::integrator, &IntegratorConfig::acceleration>(
      "integrator", "acceleration", {"none", "anderson"}, kMustMatch,
      "vi: Anderson mixing of the step's fixed-point iteration"));
  k.push_back(choice_key<&RunConfig::integrator, &IntegratorConfig::solver_precision>(
      "integrator", "solver_precision", {"mixed", "double"}, kMustMatch,
      "vi: mixed runs the pair kernels in single precision where the solve absorbs the rounding"));
  k.push_back({"integrator",
               "tableau",
               "table: a, b, c, order",
               {},
               kMustMatch,
               "[integrator.tableau]: a user's explicit tableau (a square, b, c = row sums of a if left out, "
               "the order it claims, checked); method = \"user\"",
               [](const KeyInput& in, RunConfig& c) { c.integrator.tableau = in.tableau(); },
               [](const RunConfig& c) { return tableau_text(c.integrator.tableau); }});
  // --- [output]
  k.push_back({"output",
               "dir",
               "path",
               {},
               kMayChange,
               "output directory, relative to the run file (vimd run --out overrides it)",
               [](const KeyInput& in, RunConfig& c) {
                 c.output.dir = in.string();
                 in.require(!c.output.dir.empty(), "dir must not be empty");
               },
               [](const RunConfig& c) { return c.output.dir.string(); }});
  k.push_back(integer_key<&RunConfig::output, &OutputConfig::trajectory_every>(
      "output", "trajectory_every", "integer, steps", kMustMatch, "frames of traj.trr (x, v, f, box); 0 disables",
      [](long v) { return v >= 0; }, "trajectory_every must not be negative (0 disables the trajectory)"));
  k.push_back(integer_key<&RunConfig::output, &OutputConfig::energy_every>(
      "output", "energy_every", "integer, steps", kMustMatch,
      "rows of energy.xvg/.csv; energies are computed only there (the trajectory is the same); 0 disables",
      [](long v) { return v >= 0; }, "energy_every must not be negative (0 disables the energy output)"));
  k.push_back(integer_key<&RunConfig::output, &OutputConfig::checkpoint_every>(
      "output", "checkpoint_every", "integer, steps", kMayChange,
      "state.cpt every this many steps; 0: every 15 minutes of wall time. Always at a stop and at the end",
      [](long v) { return v >= 0; },
      "checkpoint_every must not be negative (0: every 15 minutes of wall time and at the end)"));
  return k;
}

}  // namespace

// The closest choice, when it is close enough to be a plausible typo.
std::optional<std::string> nearest_word(const std::string& word, const std::vector<std::string>& choices) {
  const auto best = *std::min_element(choices.begin(), choices.end(), [&](const auto& x, const auto& y) {
    return levenshtein(word, x) < levenshtein(word, y);
  });
  if (levenshtein(word, best) > std::max<std::size_t>(2, word.size() / 3)) return std::nullopt;
  return best;
}

std::string KeyInput::choice() const {
  const std::string value = string();
  const auto& choices = key().choices;
  if (std::find(choices.begin(), choices.end(), value) == choices.end()) {
    std::string list;
    for (const auto& c : choices) list += (list.empty() ? "" : ", ") + c;
    const auto suggestion = nearest_word(value, choices);
    fail(key().name + " = \"" + value + "\" is not supported" +
         (suggestion ? "; did you mean \"" + *suggestion + "\"?" : "") + " (choices: " + list + ")");
  }
  return value;
}

const std::vector<ConfigKey>& config_keys() {
  static const std::vector<ConfigKey> keys = make_keys();
  return keys;
}

const std::vector<std::string>& config_sections() {
  static const std::vector<std::string> sections = {"system", "forcefield", "integrator", "output"};
  return sections;
}

const ConfigKey* find_config_key(const std::string& section, const std::string& name) {
  for (const ConfigKey& key : config_keys())
    if (key.section == section && key.name == name) return &key;
  return nullptr;
}

std::string exact_text(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.15g", x);
  if (std::strtod(buf, nullptr) != x) std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

RunIdentity run_identity(const System& s, const RunConfig& config, long summary_every) {
  Fingerprint topology;
  topology.add_all(s.mass);
  topology.add_all(s.charge);
  topology.add_all(s.c6);
  topology.add_all(s.c12);
  for (int t : s.type) topology.add(t);
  for (const Constraint& x : s.constraints) topology.add(x.i), topology.add(x.j), topology.add(x.length);
  for (const Bond& x : s.bonds) topology.add(x.i), topology.add(x.j), topology.add(x.length), topology.add(x.k);
  for (const Angle& x : s.angles)
    topology.add(x.i), topology.add(x.j), topology.add(x.k), topology.add(x.theta0), topology.add(x.force_constant);
  const auto add_atoms = [&](const auto& x) { topology.add(x.i), topology.add(x.j), topology.add(x.k), topology.add(x.l); };
  for (const auto* list : {&s.proper_dihedrals, &s.periodic_impropers})
    for (const PeriodicDihedral& x : *list)
      add_atoms(x), topology.add(x.phi_s), topology.add(x.force_constant), topology.add(x.multiplicity);
  for (const RyckaertBellemansDihedral& x : s.rb_dihedrals) add_atoms(x), topology.add(x.c);
  for (const HarmonicImproper& x : s.harmonic_impropers) add_atoms(x), topology.add(x.xi0), topology.add(x.force_constant);
  for (const Pair14& x : s.pairs14) topology.add(x.i), topology.add(x.j), topology.add(x.c6), topology.add(x.c12), topology.add(x.qq);
  for (const VirtualSite& x : s.virtual_sites)
    topology.add(x.kind), topology.add(x.site), topology.add(x.i), topology.add(x.j), topology.add(x.k),
        topology.add(x.a), topology.add(x.b), topology.add(x.c);
  RunIdentity identity = {
      {"atoms", std::to_string(s.n_atoms())},
      {"topology (fingerprint of masses, charges, types, LJ, bonds, angles, constraints; dihedrals, 1-4 pairs)",
       topology.text()},
      {"box", exact_text(s.box.length[0]) + " " + exact_text(s.box.length[1]) + " " + exact_text(s.box.length[2])}};
  for (const ConfigKey& key : config_keys())
    if (key.on_continue == OnContinue::must_match)
      identity.emplace_back("[" + key.section + "] " + key.name, key.value(config));
  identity.emplace_back("summary sampling (steps)", std::to_string(summary_every));
  return identity;
}

std::vector<std::string> non_default_settings(const RunConfig& config) {
  RunConfig defaults;
  defaults.structure = config.structure;
  defaults.topology = config.topology;
  defaults.output.dir = config.output.dir;
  std::vector<std::string> lines;
  for (const std::string& section : config_sections()) {
    std::string line;
    for (const ConfigKey& key : config_keys()) {
      if (key.section != section) continue;
      const std::string value = key.value(config);
      if (value != key.value(defaults)) line += (line.empty() ? "" : ", ") + key.name + " = " + value;
    }
    if (!line.empty()) lines.push_back("[" + section + "] " + line);
  }
  return lines;
}

std::string shown_default(const ConfigKey& key) {
  static const RunConfig defaults;
  if (key.name == "tableau") return "(none)";
  std::string value = key.value(defaults);
  if (key.section == "system" && value.empty()) value = "(required)";
  return value;
}

std::string config_reference_markdown() {
  std::string out =
      "# Run-file keys\n\n"
      "<!-- Generated by `vimd keys --markdown` from engine/config_schema.cpp; tests/test_config.cpp checks it is "
      "current. -->\n\n"
      "A run file is TOML with the tables below; relative paths are relative to the run file. Units are "
      "GROMACS's: nm, ps, amu, kJ/mol, e, K. An unknown or misspelt key is an error naming the file, the line "
      "and the nearest valid key. *Continue* says whether `vimd run CONFIG --continue DIR` accepts a checkpoint "
      "written under another value (\"must match\": it is refused, naming the key).\n";
  for (const std::string& section : config_sections()) {
    out += "\n## [" + section + "]\n\n| key | type | default | continue | meaning |\n|---|---|---|---|---|\n";
    for (const ConfigKey& key : config_keys()) {
      if (key.section != section) continue;
      std::string type = key.type;
      if (!key.choices.empty()) {
        type += ": ";
        for (std::size_t c = 0; c < key.choices.size(); ++c) type += (c ? " \\| " : "") + ("`" + key.choices[c] + "`");
      }
      const std::string value = shown_default(key);
      out += "| `" + key.name + "` | " + type + " | `" + value + "` | " +
             (key.on_continue == OnContinue::must_match ? "must match" : "may change") + " | " + key.help + " |\n";
    }
  }
  return out;
}

}  // namespace vimd
