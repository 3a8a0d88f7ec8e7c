#include "engine/config.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <optional>
#include <sstream>
#include <toml++/toml.h>

#include "engine/errors.hpp"

namespace vimd {
namespace fs = std::filesystem;

namespace {

// The accepted keys per table; anything else is an error with a suggestion.
const std::map<std::string, std::vector<std::string>>& schema() {
  static const std::map<std::string, std::vector<std::string>> tables = {
      {"system", {"structure", "topology"}},
      {"forcefield",
       {"cutoff", "vdw_modifier", "vdw_switch", "coulomb", "coulomb_modifier", "coulomb_switch", "switch_smoothness",
        "epsilon_r", "epsilon_rf", "neighbor_skin", "neighbor_search_skin", "precision"}},
      {"integrator",
       {"type", "dt", "steps", "constraint_tolerance", "temperature", "seed", "thermostat", "tau_t", "emtol", "emstep", "method", "method_minus", "bias",
        "projection", "solver_tolerance", "max_iterations", "acceleration", "solver_precision", "tableau"}},
      {"integrator.tableau", {"a", "b", "c", "order"}},
      {"output", {"dir", "trajectory_every", "energy_every", "checkpoint_every"}},
  };
  return tables;
}

const std::vector<std::string> kIntegratorTypes = {"verlet", "shake", "rattle", "vi", "rk", "minimize"};
const std::vector<std::string> kThermostats = {"none", "v-rescale"};
const std::vector<std::string> kVdwModifiers = {"none", "potential-shift", "force-switch", "potential-switch"};
const std::vector<std::string> kCoulombTypes = {"reaction-field", "cutoff", "none"};
const std::vector<std::string> kCoulombModifiers = {"none", "potential-switch"};
const std::vector<std::string> kPrecisions = {"double", "mixed"};
const std::vector<std::string> kProjections = {"euclidean", "mass"};
const std::vector<std::string> kAccelerations = {"none", "anderson"};
const std::vector<std::string> kSolverPrecisions = {"mixed", "double"};

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

// The closest choice, when it is close enough to be a plausible typo.
std::optional<std::string> nearest(const std::string& word, const std::vector<std::string>& choices) {
  const auto best = *std::min_element(choices.begin(), choices.end(), [&](const auto& x, const auto& y) {
    return levenshtein(word, x) < levenshtein(word, y);
  });
  if (levenshtein(word, best) > std::max<std::size_t>(2, word.size() / 3)) return std::nullopt;
  return best;
}

std::string format_number(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

std::string join(const std::vector<std::string>& words) {
  std::string out;
  for (const auto& w : words) out += (out.empty() ? "" : ", ") + w;
  return out;
}

std::string type_name(const toml::node& node) {
  switch (node.type()) {
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a floating-point number";
    case toml::node_type::boolean: return "a boolean";
    case toml::node_type::table: return "a table";
    case toml::node_type::array: return "an array";
    default: return "a date/time";
  }
}

class ConfigReader {
 public:
  explicit ConfigReader(const fs::path& file) : file_(file), dir_(file.parent_path()) {}

  RunConfig read(const ConfigOverrides& overrides) {
    std::ifstream in(file_, std::ios::binary);
    const std::string text{std::istreambuf_iterator<char>(in), {}};
    if (!in) throw InputError(file_.string(), 0, "cannot read config file");
    check_characters(text);
    toml::table root;
    try {
      root = toml::parse(text, file_.string());
    } catch (const toml::parse_error& e) {
      throw InputError(file_.string(), static_cast<int>(e.source().begin.line),
                       "TOML syntax error: " + std::string(e.description()));
    }
    for (const auto& [key, value] : overrides) apply_override(root, key, value);
    RunConfig config;
    config.file = file_;
    for (auto&& [key, node] : root) {
      const std::string name(key.str());
      if (!schema().count(name) || name.find('.') != std::string::npos) unknown_top_level(name, key, node);
      if (!node.is_table()) fail(key, "[" + name + "] must be a table, found " + type_name(node));
    }
    const toml::table* system = root["system"].as_table();
    if (!system) throw InputError(file_.string(), 0, "missing [system] table with structure and topology");
    read_system(*system, config);
    if (const auto* t = root["forcefield"].as_table()) read_forcefield(*t, config.forcefield);
    if (const auto* t = root["integrator"].as_table()) read_integrator(*t, config.integrator);
    if (const auto* t = root["output"].as_table()) read_output(*t, config.output);
    if (config.forcefield.precision == "mixed" && (config.integrator.type == "vi" || config.integrator.type == "rk"))
      fail(*root["forcefield"]["precision"].node(),
           "precision = \"mixed\" is for verlet, shake, rattle and minimize: type = \"" + config.integrator.type +
               "\" solves its step equations to a tolerance that single-precision forces cannot meet");
    config.output.dir = resolve(config.output.dir);
    return config;
  }

 private:
  // Checks the raw text before the parser sees it: TOML allows no raw control characters but tab
  // and line breaks (a binary or corrupted file). Non-ASCII text is refused outside comments and
  // single-line string values: the TOML parser (toml++ 3.3 as Debian ships it) reaches
  // undefined behaviour on some non-ASCII characters where it tests for whitespace, i.e. between
  // tokens, in keys and in multi-line strings (upstream marzer/tomlplusplus#190, #295); a run file
  // needs them nowhere else, and TOML allows them nowhere else but in quoted keys.
  void check_characters(const std::string& text) const {
    int line = 1;
    bool value = false;               // after '=' of a key/value pair
    bool string_value = false;        // the open string starts a value (else it is a key or garbage)
    char last = '\n';                 // the last character outside strings, comments and blanks
    std::vector<char> open;           // enclosing '[' arrays and '{' inline tables of a value
    char quote = 0;                   // the open string's delimiter, 0 outside strings
    bool multi_line = false, comment = false;
    const auto refuse = [&](const std::string& problem) { throw InputError(file_.string(), line, problem); };
    for (std::size_t k = 0; k < text.size(); ++k) {
      const char c = text[k];
      const auto byte = static_cast<unsigned char>(c);
      if ((byte < 0x20 && c != '\t' && c != '\n' && c != '\r') || byte == 0x7f) {
        char code[8];
        std::snprintf(code, sizeof code, "0x%02X", byte);
        refuse(std::string("control character ") + code +
               " in the file (TOML allows none but tab and line breaks; binary or corrupted file?)");
      }
      if (c == '\n') {
        ++line;
        comment = false;
        if (quote && !multi_line) quote = 0;  // an unterminated string: the parser reports it
        if (!quote && open.empty()) value = false, last = '\n';
        continue;
      }
      if (comment) continue;
      if (quote) {
        if (byte >= 0x80 && (multi_line || !string_value))
          refuse(std::string("non-ASCII character in a ") +
                 (string_value ? "multi-line string" : "quoted key or misplaced string") +
                 ": a run file takes non-ASCII text only in comments and single-line string values");
        if (quote == '"' && c == '\\') {
          if (k + 1 < text.size() && text[k + 1] != '\n') ++k;  // the escaped character
        } else if (c == quote && (!multi_line || text.compare(k, 3, std::string(3, quote)) == 0)) {
          k += multi_line ? 2 : 0;
          last = quote;
          quote = 0;
        }
        continue;
      }
      if (byte >= 0x80)
        refuse("non-ASCII character outside a string or comment (TOML keys, numbers and booleans are ASCII)");
      if (c != ' ' && c != '\t' && c != '\r' && c != '#' && c != '"' && c != '\'') last = c;
      switch (c) {
        case '#': comment = true; break;
        case '"':
        case '\'':
          // As the parser sees it: a value string only right after '=', or '[' / ',' in an array.
          string_value = value && (last == '=' || last == '[' || last == ',');
          quote = c;
          multi_line = text.compare(k, 3, std::string(3, c)) == 0;
          k += multi_line ? 2 : 0;
          break;
        case '=': value = true; break;
        case '[': if (value) open.push_back('['); break;
        case '{':
          open.push_back('{');
          value = false;
          break;
        case ',': value = open.empty() || open.back() == '['; break;
        case ']':
        case '}':
          if (!open.empty()) open.pop_back();
          value = true;
          break;
        default: break;
      }
    }
  }

  // Nodes without a source were put there by apply_override.
  [[noreturn]] void fail(const toml::key& key, const std::string& problem) const {
    if (!key.source().path) throw InputError(kOverrides, 0, problem);
    throw InputError(file_.string(), static_cast<int>(key.source().begin.line), problem);
  }
  [[noreturn]] void fail(const toml::node& node, const std::string& problem) const {
    if (!node.source().path) throw InputError(kOverrides, 0, problem);
    throw InputError(file_.string(), static_cast<int>(node.source().begin.line), problem);
  }

  static constexpr const char* kOverrides = "settings given with the config file";

  static toml::array to_array(const std::vector<double>& values) {
    toml::array array;
    for (double x : values) array.push_back(x);
    return array;
  }

  // Puts `key = value` into the table whose schema has `key`, replacing what the file says.
  void apply_override(toml::table& root, const std::string& key, const ConfigValue& value) const {
    std::string table_name;
    std::vector<std::string> all;
    for (const auto& [table, keys] : schema()) {
      if (table.find('.') != std::string::npos) continue;
      all.insert(all.end(), keys.begin(), keys.end());
      if (std::find(keys.begin(), keys.end(), key) != keys.end()) table_name = table;
    }
    if (table_name.empty()) {
      const auto suggestion = nearest(key, all);
      throw InputError(kOverrides, 0,
                       "unknown setting '" + key + "'" + (suggestion ? "; did you mean '" + *suggestion + "'?" : "") +
                           " (settings: " + join(all) + ")");
    }
    if (!root.contains(table_name)) root.insert(table_name, toml::table{});
    toml::table* table = root[table_name].as_table();
    if (!table) throw InputError(file_.string(), 0, "[" + table_name + "] must be a table");
    std::visit(
        [&](const auto& v) {
          using T = std::decay_t<decltype(v)>;
          if constexpr (std::is_same_v<T, std::vector<double>>) {
            table->insert_or_assign(key, to_array(v));
          } else if constexpr (std::is_same_v<T, TableauConfig>) {
            toml::table tableau;
            toml::array a;
            for (const auto& row : v.a) a.push_back(to_array(row));
            tableau.insert("a", std::move(a));
            tableau.insert("b", to_array(v.b));
            if (!v.c.empty()) tableau.insert("c", to_array(v.c));
            tableau.insert("order", static_cast<std::int64_t>(v.order));
            table->insert_or_assign(key, std::move(tableau));
            table->insert_or_assign("method", "user");
          } else if constexpr (std::is_same_v<T, long>) {
            table->insert_or_assign(key, static_cast<std::int64_t>(v));
          } else {
            table->insert_or_assign(key, v);
          }
        },
        value);
  }

  [[noreturn]] void unknown_top_level(const std::string& name, const toml::key& key, const toml::node& node) const {
    for (const auto& [table, keys] : schema())
      if (std::find(keys.begin(), keys.end(), name) != keys.end())
        fail(key, "'" + name + "' must be inside [" + table + "]");
    std::vector<std::string> tables;
    for (const auto& [table, keys] : schema())
      if (table.find('.') == std::string::npos) tables.push_back(table);
    const auto suggestion = nearest(name, tables);
    fail(key, std::string(node.is_table() ? "unknown table [" : "unknown key '") + name +
                  (node.is_table() ? "]" : "'") + (suggestion ? "; did you mean [" + *suggestion + "]?" : "") +
                  " (tables: " + join(tables) + ")");
  }

  // Every key of `table` must be in the schema of `table_name`.
  void check_keys(const toml::table& table, const std::string& table_name) const {
    const auto& allowed = schema().at(table_name);
    for (auto&& [key, node] : table) {
      const std::string name(key.str());
      if (std::find(allowed.begin(), allowed.end(), name) != allowed.end()) continue;
      std::string hint;
      for (const auto& [other, keys] : schema())
        if (other != table_name && std::find(keys.begin(), keys.end(), name) != keys.end())
          hint = " ('" + name + "' belongs in [" + other + "])";
      const auto suggestion = nearest(name, allowed);
      fail(key, "unknown key '" + name + "' in [" + table_name + "]" +
                    (suggestion ? "; did you mean '" + *suggestion + "'?" : "") + hint + " (valid keys: " +
                    join(allowed) + ")");
    }
  }

  double number(const toml::node& node, const std::string& what) const {
    if (const auto* v = node.as_floating_point()) {
      if (!std::isfinite(v->get())) fail(node, what + " must be a finite number");
      return v->get();
    }
    if (const auto* v = node.as_integer()) return static_cast<double>(v->get());
    fail(node, what + " must be a number, found " + type_name(node));
  }
  long integer(const toml::node& node, const std::string& what) const {
    if (const auto* v = node.as_integer()) return static_cast<long>(v->get());
    // 1e5 is a float in TOML; accept it when it is a whole number.
    if (const auto* v = node.as_floating_point())
      if (std::floor(v->get()) == v->get() && std::abs(v->get()) < 9e18) return static_cast<long>(v->get());
    fail(node, what + " must be an integer, found " + type_name(node));
  }
  std::string string(const toml::node& node, const std::string& what) const {
    if (const auto* v = node.as_string()) return v->get();
    fail(node, what + " must be a string, found " + type_name(node));
  }
  std::string choice(const toml::node& node, const std::string& what, const std::vector<std::string>& choices) const {
    const std::string value = string(node, what);
    if (std::find(choices.begin(), choices.end(), value) == choices.end()) {
      const auto suggestion = nearest(value, choices);
      fail(node, what + " = \"" + value + "\" is not supported" +
                     (suggestion ? "; did you mean \"" + *suggestion + "\"?" : "") + " (choices: " + join(choices) + ")");
    }
    return value;
  }
  void require(bool ok, const toml::node& node, const std::string& problem) const {
    if (!ok) fail(node, problem);
  }
  std::vector<double> numbers(const toml::node& node, const std::string& what) const {
    const auto* array = node.as_array();
    if (!array) fail(node, what + " must be an array of numbers, found " + type_name(node));
    std::vector<double> values;
    for (const auto& element : *array) values.push_back(number(element, what + " element"));
    return values;
  }

  fs::path resolve(const fs::path& p) const { return p.is_relative() ? (dir_ / p).lexically_normal() : p; }

  fs::path existing_file(const toml::node& node, const std::string& what) const {
    const fs::path path = resolve(string(node, what));
    std::error_code ec;
    require(fs::is_regular_file(path, ec), node, what + " file " + path.string() + " does not exist");
    return path;
  }

  void read_system(const toml::table& t, RunConfig& config) const {
    check_keys(t, "system");
    const auto* structure = t.get("structure");
    const auto* topology = t.get("topology");
    const int line = static_cast<int>(t.source().begin.line);
    if (!structure) throw InputError(file_.string(), line, "[system] needs structure = \"file.gro\"");
    if (!topology) throw InputError(file_.string(), line, "[system] needs topology = \"file.top\"");
    config.structure = existing_file(*structure, "[system] structure");
    config.topology = existing_file(*topology, "[system] topology");
  }

  void read_forcefield(const toml::table& t, ForceFieldConfig& ff) const {
    check_keys(t, "forcefield");
    if (const auto* n = t.get("cutoff")) {
      ff.cutoff = number(*n, "cutoff");
      require(ff.cutoff > 0, *n, "cutoff must be positive (nm)");
    }
    if (const auto* n = t.get("vdw_modifier")) ff.vdw_modifier = choice(*n, "vdw_modifier", kVdwModifiers);
    if (const auto* n = t.get("vdw_switch")) {
      ff.vdw_switch = number(*n, "vdw_switch");
      require(ff.vdw_switch >= 0, *n, "vdw_switch must not be negative (nm)");
    }
    if (ff.vdw_modifier == "force-switch" || ff.vdw_modifier == "potential-switch") {
      const toml::node* where = t.get("vdw_switch") ? t.get("vdw_switch") : t.get("vdw_modifier");
      require(ff.vdw_switch < ff.cutoff, *where,
              "vdw_switch (" + format_number(ff.vdw_switch) + " nm) must be smaller than cutoff (" +
                  format_number(ff.cutoff) + " nm) for " + ff.vdw_modifier);
    }
    if (const auto* n = t.get("coulomb")) ff.coulomb = choice(*n, "coulomb", kCoulombTypes);
    if (const auto* n = t.get("epsilon_r")) {
      ff.epsilon_r = number(*n, "epsilon_r");
      require(ff.epsilon_r > 0, *n, "epsilon_r must be positive");
    }
    if (const auto* n = t.get("epsilon_rf")) {
      ff.epsilon_rf = number(*n, "epsilon_rf");
      require(ff.epsilon_rf >= 0, *n, "epsilon_rf must not be negative (0 means infinity)");
    }
    if (const auto* n = t.get("coulomb_modifier"))
      ff.coulomb_modifier = choice(*n, "coulomb_modifier", kCoulombModifiers);
    if (const auto* n = t.get("coulomb_switch")) {
      ff.coulomb_switch = number(*n, "coulomb_switch");
      require(ff.coulomb_switch >= 0, *n, "coulomb_switch must not be negative (nm)");
    }
    if (ff.coulomb_modifier == "potential-switch") {
      const toml::node& modifier = *t.get("coulomb_modifier");
      require(ff.coulomb != "none", modifier, "coulomb_modifier = \"potential-switch\" needs coulomb = \"reaction-field\" or \"cutoff\"");
      require(t.get("coulomb_switch") != nullptr, modifier,
              "coulomb_modifier = \"potential-switch\" needs coulomb_switch (nm, where the switch starts)");
      require(ff.coulomb_switch < ff.cutoff, *t.get("coulomb_switch"),
              "coulomb_switch (" + format_number(ff.coulomb_switch) + " nm) must be smaller than cutoff (" +
                  format_number(ff.cutoff) + " nm)");
    }
    if (const auto* n = t.get("switch_smoothness")) {
      const long k = integer(*n, "switch_smoothness");
      require(k >= 2 && k <= 6, *n,
              "switch_smoothness must be between 2 and 6 (continuous derivatives of a potential-switch pair "
              "potential; 2 is GROMACS's), got " + std::to_string(k));
      ff.switch_smoothness = static_cast<int>(k);
    }
    if (const auto* n = t.get("neighbor_skin")) {
      ff.neighbor_skin = number(*n, "neighbor_skin");
      require(ff.neighbor_skin >= 0, *n, "neighbor_skin must not be negative (nm)");
    }
    if (const auto* n = t.get("precision")) ff.precision = choice(*n, "precision", kPrecisions);
    if (const auto* n = t.get("neighbor_search_skin")) {
      ff.neighbor_search_skin = number(*n, "neighbor_search_skin");
      require(*ff.neighbor_search_skin >= ff.neighbor_skin, *n,
              "neighbor_search_skin (" + format_number(*ff.neighbor_search_skin) +
                  " nm) must not be smaller than neighbor_skin (" + format_number(ff.neighbor_skin) + " nm)");
    }
  }

  void read_integrator(const toml::table& t, IntegratorConfig& in) const {
    check_keys(t, "integrator");
    if (const auto* n = t.get("type")) in.type = choice(*n, "type", kIntegratorTypes);
    if (const auto* n = t.get("dt")) {
      in.dt = number(*n, "dt");
      require(in.dt > 0, *n, "dt must be positive (ps)");
    }
    if (const auto* n = t.get("steps")) {
      in.steps = integer(*n, "steps");
      require(in.steps >= 0, *n, "steps must not be negative");
    }
    if (const auto* n = t.get("constraint_tolerance")) {
      in.constraint_tolerance = number(*n, "constraint_tolerance");
      require(in.constraint_tolerance > 0 && in.constraint_tolerance < 1, *n,
              "constraint_tolerance is relative and must be in (0, 1)");
    }
    if (const auto* n = t.get("temperature")) {
      in.temperature = number(*n, "temperature");
      require(*in.temperature >= 0, *n, "temperature must not be negative (K)");
    }
    if (const auto* n = t.get("seed")) {
      const long seed = integer(*n, "seed");
      require(seed >= 0, *n, "seed must not be negative");
      in.seed = static_cast<std::uint64_t>(seed);
    }
    if (const auto* n = t.get("thermostat")) {
      in.thermostat = choice(*n, "thermostat", kThermostats);
      require(in.thermostat == "none" || in.temperature, *n,
              "thermostat = \"" + in.thermostat + "\" needs temperature = <K> in [integrator] (the reference)");
    }
    if (const auto* n = t.get("tau_t")) {
      in.tau_t = number(*n, "tau_t");
      require(in.tau_t >= 0, *n, "tau_t must not be negative (ps)");
    }
    if (const auto* n = t.get("emtol")) {
      in.emtol = number(*n, "emtol");
      require(in.emtol > 0, *n, "emtol must be positive (kJ/mol/nm)");
    }
    if (const auto* n = t.get("emstep")) {
      in.emstep = number(*n, "emstep");
      require(in.emstep > 0, *n, "emstep must be positive (nm)");
    }
    if (const auto* n = t.get("method")) {
      in.method = string(*n, "method");
      require(!in.method.empty(), *n, "method must not be empty");
    }
    if (const auto* n = t.get("method_minus")) {
      in.method_minus = string(*n, "method_minus");
      require(!in.method_minus->empty(), *n, "method_minus must not be empty");
    }
    if (const auto* n = t.get("bias")) {
      const auto bias = numbers(*n, "bias");
      require(bias.size() == 2, *n, "bias must have two numbers [alpha_minus, alpha_plus]");
      in.bias = {bias[0], bias[1]};
    }
    if (const auto* n = t.get("projection")) in.projection = choice(*n, "projection", kProjections);
    if (const auto* n = t.get("solver_tolerance")) {
      in.solver_tolerance = number(*n, "solver_tolerance");
      require(*in.solver_tolerance > 0, *n, "solver_tolerance must be positive");
    }
    if (const auto* n = t.get("max_iterations")) {
      const long iterations = integer(*n, "max_iterations");
      require(iterations >= 1 && iterations <= 1000000, *n, "max_iterations must be between 1 and 1000000");
      in.max_iterations = static_cast<int>(iterations);
    }
    if (const auto* n = t.get("acceleration")) in.acceleration = choice(*n, "acceleration", kAccelerations);
    if (const auto* n = t.get("solver_precision"))
      in.solver_precision = choice(*n, "solver_precision", kSolverPrecisions);
    const auto* tableau = t.get("tableau");
    if (tableau) {
      const auto* table = tableau->as_table();
      if (!table) fail(*tableau, "[integrator.tableau] must be a table, found " + type_name(*tableau));
      in.tableau = read_tableau(*table);
      const auto* method = t.get("method");
      require(in.method == "user", method ? *method : *tableau,
              "[integrator.tableau] is given, so method must be \"user\" (it is \"" + in.method + "\")");
    } else if (in.method == "user") {
      fail(*t.get("method"), "method = \"user\" needs an [integrator.tableau] table with a, b and order");
    }
  }

  TableauConfig read_tableau(const toml::table& t) const {
    check_keys(t, "integrator.tableau");
    TableauConfig tableau;
    tableau.line = static_cast<int>(t.source().begin.line);
    const auto missing = [&](const char* key) {
      throw InputError(file_.string(), tableau.line, std::string("[integrator.tableau] needs '") + key + "'");
    };
    const auto* a = t.get("a");
    const auto* b = t.get("b");
    const auto* order = t.get("order");
    if (!a) missing("a");
    if (!b) missing("b");
    if (!order) missing("order");
    const auto* rows = a->as_array();
    if (!rows || rows->empty()) fail(*a, "tableau a must be a non-empty array of rows (arrays of numbers)");
    for (const auto& row : *rows) tableau.a.push_back(numbers(row, "tableau a row"));
    const std::size_t stages = tableau.a.size();
    for (const auto& row : tableau.a)
      require(row.size() == stages, *a, "tableau a must be square: " + std::to_string(stages) + " rows but a row has " +
                                            std::to_string(row.size()) + " entries");
    tableau.b = numbers(*b, "tableau b");
    require(tableau.b.size() == stages, *b, "tableau b must have " + std::to_string(stages) + " entries (one per stage)");
    if (const auto* c = t.get("c")) {
      tableau.c = numbers(*c, "tableau c");
      require(tableau.c.size() == stages, *c, "tableau c must have " + std::to_string(stages) + " entries");
    } else {
      // The usual convention c_i = Σ_j a_ij.
      for (const auto& row : tableau.a) {
        double sum = 0;
        for (double x : row) sum += x;
        tableau.c.push_back(sum);
      }
    }
    const long stated = integer(*order, "tableau order");
    require(stated >= 1 && stated <= 20, *order, "tableau order must be between 1 and 20");
    tableau.order = static_cast<int>(stated);
    return tableau;
  }

  void read_output(const toml::table& t, OutputConfig& out) const {
    check_keys(t, "output");
    if (const auto* n = t.get("dir")) {
      out.dir = string(*n, "dir");
      require(!out.dir.empty(), *n, "dir must not be empty");
    }
    if (const auto* n = t.get("trajectory_every")) {
      out.trajectory_every = integer(*n, "trajectory_every");
      require(out.trajectory_every >= 0, *n, "trajectory_every must not be negative (0 disables the trajectory)");
    }
    if (const auto* n = t.get("checkpoint_every")) {
      out.checkpoint_every = integer(*n, "checkpoint_every");
      require(out.checkpoint_every >= 0, *n,
              "checkpoint_every must not be negative (0: every 15 minutes of wall time and at the end)");
    }
    if (const auto* n = t.get("energy_every")) {
      out.energy_every = integer(*n, "energy_every");
      require(out.energy_every >= 0, *n, "energy_every must not be negative (0 disables the energy output)");
    }
  }

  fs::path file_, dir_;
};

}  // namespace

RunConfig read_config(const fs::path& file, const ConfigOverrides& overrides) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) throw InputError(file.string(), 0, "cannot open config file");
  return ConfigReader(file).read(overrides);
}

}  // namespace vimd
