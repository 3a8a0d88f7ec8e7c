#include "engine/config.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <optional>
#include <toml++/toml.h>

#include "engine/config_schema.hpp"
#include "engine/errors.hpp"

namespace vimd {
namespace fs = std::filesystem;

namespace {

// The accepted keys per table, from the schema; [integrator.tableau] has its own.
std::map<std::string, std::vector<std::string>> tables_of(const ConfigSchema& schema) {
  std::map<std::string, std::vector<std::string>> tables;
  for (const ConfigKey& key : schema.keys) tables[key.section].push_back(key.name);
  tables["integrator.tableau"] = {"a", "b", "c", "order"};
  return tables;
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
  static constexpr const char* kOverrides = "settings given with the config file";

  ConfigReader(const fs::path& file, const ConfigSchema& schema)
      : file_(file), dir_(file.parent_path()), schema_(schema), tables_(tables_of(schema)) {}

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
      if (!tables_.count(name) || name.find('.') != std::string::npos) unknown_top_level(name, key, node);
      if (!node.is_table()) fail(key, "[" + name + "] must be a table, found " + type_name(node));
    }
    if (!root["system"].as_table()) throw InputError(file_.string(), 0, "missing [system] table with structure and topology");
    for (const std::string& section : schema_.sections())
      if (const auto* t = root[section].as_table()) read_section(*t, section, config);
    check_rules(root, config);
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


  static toml::array to_array(const std::vector<double>& values) {
    toml::array array;
    for (double x : values) array.push_back(x);
    return array;
  }

  // Puts `key = value` into the table whose schema has `key`, replacing what the file says.
  void apply_override(toml::table& root, const std::string& key, const ConfigValue& value) const {
    std::string table_name;
    std::vector<std::string> all;
    for (const auto& [table, keys] : tables_) {
      if (table.find('.') != std::string::npos) continue;
      all.insert(all.end(), keys.begin(), keys.end());
      if (std::find(keys.begin(), keys.end(), key) != keys.end()) table_name = table;
    }
    if (table_name.empty()) {
      const auto suggestion = nearest_word(key, all);
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
    for (const auto& [table, keys] : tables_)
      if (std::find(keys.begin(), keys.end(), name) != keys.end())
        fail(key, "'" + name + "' must be inside [" + table + "]");
    std::vector<std::string> tables;
    for (const auto& [table, keys] : tables_)
      if (table.find('.') == std::string::npos) tables.push_back(table);
    const auto suggestion = nearest_word(name, tables);
    fail(key, std::string(node.is_table() ? "unknown table [" : "unknown key '") + name +
                  (node.is_table() ? "]" : "'") + (suggestion ? "; did you mean [" + *suggestion + "]?" : "") +
                  " (tables: " + join(tables) + ")");
  }

  // Every key of `table` must be in the schema of `table_name`.
  void check_keys(const toml::table& table, const std::string& table_name) const {
    const auto& allowed = tables_.at(table_name);
    for (auto&& [key, node] : table) {
      const std::string name(key.str());
      if (std::find(allowed.begin(), allowed.end(), name) != allowed.end()) continue;
      std::string hint;
      for (const auto& [other, keys] : tables_)
        if (other != table_name && std::find(keys.begin(), keys.end(), name) != keys.end())
          hint = " ('" + name + "' belongs in [" + other + "])";
      const auto suggestion = nearest_word(name, allowed);
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

  // One key's value, through the reader's typed accessors (errors at the value's line).
  class NodeInput final : public KeyInput {
   public:
    NodeInput(const ConfigReader& reader, const ConfigKey& key, const toml::node& node)
        : reader_(reader), key_(key), node_(node) {}
    double number() const override { return reader_.number(node_, key_.name); }
    long integer() const override { return reader_.integer(node_, key_.name); }
    std::string string() const override { return reader_.string(node_, key_.name); }
    bool is_string() const override { return node_.is_string(); }
    std::vector<double> numbers() const override { return reader_.numbers(node_, key_.name); }
    fs::path existing_file() const override {
      return reader_.existing_file(node_, "[" + key_.section + "] " + key_.name);
    }
    fs::path path() const override { return reader_.resolve(reader_.string(node_, key_.name)); }
    TableauConfig tableau() const override {
      const auto* table = node_.as_table();
      if (!table) reader_.fail(node_, "[integrator.tableau] must be a table, found " + type_name(node_));
      return reader_.read_tableau(*table);
    }
    [[noreturn]] void fail(const std::string& problem) const override { reader_.fail(node_, problem); }
    const ConfigKey& key() const override { return key_; }

   private:
    const ConfigReader& reader_;
    const ConfigKey& key_;
    const toml::node& node_;
  };

  // The keys read, for the rules between them.
  class ReadKeys final : public GivenKeys {
   public:
    const KeyInput* find(const std::string& section, const std::string& name) const override {
      const auto it = inputs_.find({section, name});
      return it == inputs_.end() ? nullptr : &it->second;
    }
    const KeyInput& add(const ConfigReader& reader, const ConfigKey& key, const toml::node& node) {
      return inputs_.try_emplace({key.section, key.name}, reader, key, node).first->second;
    }

   private:
    std::map<std::pair<std::string, std::string>, NodeInput> inputs_;
  };

  // Every key the table has, read as the schema says, and where the file has it.
  void read_section(const toml::table& t, const std::string& section, RunConfig& config) {
    check_keys(t, section);
    config.sources.table_lines[section] = line_of(t);
    for (const ConfigKey& key : schema_.keys)
      if (key.section == section)
        if (const auto* node = t.get(key.name)) {
          config.sources.key_lines[{section, key.name}] = line_of(*node);
          key.read(read_.add(*this, key, *node), config);
        }
  }
  // 0 for what apply_override put there.
  static int line_of(const toml::node& node) {
    return node.source().path ? static_cast<int>(node.source().begin.line) : 0;
  }

  // The rules between keys, each reported at the line of the key that breaks it: [system]'s, then
  // the schema's.
  void check_rules(const toml::table& root, const RunConfig& config) const {
    const toml::table& system = *root["system"].as_table();
    const int system_line = static_cast<int>(system.source().begin.line);
    if (!system.get("structure")) throw InputError(file_.string(), system_line, "[system] needs structure = \"file.gro\"");
    if (!system.get("topology")) throw InputError(file_.string(), system_line, "[system] needs topology = \"file.top\"");
    for (const ConfigRule& rule : schema_.rules) rule(read_, config);
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

  fs::path file_, dir_;
  const ConfigSchema& schema_;
  const std::map<std::string, std::vector<std::string>> tables_;
  ReadKeys read_;
};

}  // namespace

InputError RunConfig::locate(const SettingError& e) const {
  const std::string what = "[" + e.section() + "] " + e.key() + ": " + e.problem();
  if (const auto key = sources.key_lines.find({e.section(), e.key()}); key != sources.key_lines.end())
    return key->second > 0 ? InputError(file.string(), key->second, e.problem())
                           : InputError(ConfigReader::kOverrides, 0, what);
  const auto table = sources.table_lines.find(e.section());
  return InputError(file.string(), table == sources.table_lines.end() ? 0 : table->second, what);
}

RunConfig read_config(const fs::path& file, const ConfigSchema& schema, const ConfigOverrides& overrides) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) throw InputError(file.string(), 0, "cannot open config file");
  return ConfigReader(file, schema).read(overrides);
}

}  // namespace vimd
