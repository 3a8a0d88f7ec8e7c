#include "engine/config_schema.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "engine/system_identity.hpp"

namespace vimd {

namespace {

constexpr OnContinue kMustMatch = OnContinue::must_match;
constexpr OnContinue kMayChange = OnContinue::may_change;

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

}  // namespace

std::vector<ConfigKey> system_keys() {
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
  return k;
}

std::vector<ConfigKey> dynamics_keys() {
  std::vector<ConfigKey> k;
  k.push_back(number_key<&DynamicsConfig::dt>("integrator", "dt", "number, ps", kMustMatch, "time step",
                                              [](double v) { return v > 0; }, "dt must be positive (ps)"));
  k.push_back(integer_key<&DynamicsConfig::steps>(
      "integrator", "steps", "integer", kMayChange, "steps to run (a continued run goes on up to it)",
      [](long v) { return v >= 0; }, "steps must not be negative"));
  k.push_back(number_key<&DynamicsConfig::constraint_tolerance>(
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
                 c.dynamics.temperature = in.number();
                 in.require(*c.dynamics.temperature >= 0, "temperature must not be negative (K)");
               },
               [](const RunConfig& c) {
                 return c.dynamics.temperature ? exact_text(*c.dynamics.temperature) : std::string("(none)");
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
                 c.dynamics.seed = static_cast<std::uint64_t>(seed);
               },
               [](const RunConfig& c) { return std::to_string(c.dynamics.seed); }});
  return k;
}

std::vector<ConfigKey> output_keys() {
  std::vector<ConfigKey> k;
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
  k.push_back(integer_key<&OutputConfig::trajectory_every>(
      "output", "trajectory_every", "integer, steps", kMustMatch, "frames of traj.trr (x, v, f, box); 0 disables",
      [](long v) { return v >= 0; }, "trajectory_every must not be negative (0 disables the trajectory)"));
  k.push_back(integer_key<&OutputConfig::energy_every>(
      "output", "energy_every", "integer, steps", kMustMatch,
      "rows of energy.xvg/.csv; energies are computed only there (the trajectory is the same); 0 disables",
      [](long v) { return v >= 0; }, "energy_every must not be negative (0 disables the energy output)"));
  k.push_back(integer_key<&OutputConfig::checkpoint_every>(
      "output", "checkpoint_every", "integer, steps", kMayChange,
      "state.cpt every this many steps; 0: every 15 minutes of wall time. Always at a stop and at the end",
      [](long v) { return v >= 0; },
      "checkpoint_every must not be negative (0: every 15 minutes of wall time and at the end)"));
  return k;
}

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

std::vector<std::string> ConfigSchema::sections() const {
  std::vector<std::string> sections;
  for (const ConfigKey& key : keys)
    if (std::find(sections.begin(), sections.end(), key.section) == sections.end()) sections.push_back(key.section);
  return sections;
}

const ConfigKey* ConfigSchema::find(const std::string& section, const std::string& name) const {
  for (const ConfigKey& key : keys)
    if (key.section == section && key.name == name) return &key;
  return nullptr;
}

std::string exact_text(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.15g", x);
  if (std::strtod(buf, nullptr) != x) std::snprintf(buf, sizeof buf, "%.17g", x);
  return buf;
}

std::string format_number(double x) {
  std::ostringstream out;
  out << x;
  return out.str();
}

RunIdentity run_identity(const System& s, const RunConfig& config, const ConfigSchema& schema, long summary_every) {
  RunIdentity identity = system_identity(s);
  for (const ConfigKey& key : schema.keys)
    if (key.on_continue == OnContinue::must_match)
      identity.emplace_back("[" + key.section + "] " + key.name, key.value(config));
  identity.emplace_back("summary sampling (steps)", std::to_string(summary_every));
  return identity;
}

std::vector<std::string> non_default_settings(const RunConfig& config, const ConfigSchema& schema) {
  RunConfig defaults;
  defaults.structure = config.structure;
  defaults.topology = config.topology;
  defaults.output.dir = config.output.dir;
  std::vector<std::string> lines;
  for (const std::string& section : schema.sections()) {
    std::string line;
    for (const ConfigKey& key : schema.keys) {
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
  std::string value = key.value(defaults);
  if (key.section == "system" && value.empty()) value = "(required)";
  return value;
}

std::string config_reference_markdown(const ConfigSchema& schema) {
  std::string out =
      "# Run-file keys\n\n"
      "<!-- Generated by `vimd keys --markdown` from the schema app/run_schema.cpp assembles (the engine's keys, "
      "forcefields/settings.cpp, integrators/settings.cpp); tests/test_config.cpp checks it is current. -->\n\n"
      "A run file is TOML with the tables below; relative paths are relative to the run file. Units are "
      "GROMACS's: nm, ps, amu, kJ/mol, e, K. An unknown or misspelt key is an error naming the file, the line "
      "and the nearest valid key. *Continue* says whether `vimd run CONFIG --continue DIR` accepts a checkpoint "
      "written under another value (\"must match\": it is refused, naming the key).\n";
  for (const std::string& section : schema.sections()) {
    out += "\n## [" + section + "]\n\n| key | type | default | continue | meaning |\n|---|---|---|---|---|\n";
    for (const ConfigKey& key : schema.keys) {
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
