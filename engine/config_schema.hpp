#pragma once
// The run file's keys, in one table: each key's section, type, help, how it is read and checked,
// its value's exact text, and whether a continued run must keep it; with the rules between keys.
// The engine has its own keys ([system], [output], the run's length, dt and seed); each component
// (the force field, the integrators) brings its keys and rules, and the app assembles the schema.
// The reader, the defaults' listing, a checkpoint's identity, `vimd check`, `vimd keys` and
// docs/run-file.md all come from it.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include <Eigen/Core>

#include "engine/checkpoint.hpp"
#include "engine/config.hpp"
#include "engine/fingerprint.hpp"
#include "engine/system.hpp"

namespace vimd {

struct ConfigKey;

// One key's value as the run file (or a setting given next to it) has it. Every accessor checks
// the type; errors name the file and the line of the value.
class KeyInput {
 public:
  virtual ~KeyInput() = default;
  virtual double number() const = 0;  // finite; an integer is accepted
  virtual long integer() const = 0;   // a float with a whole value (1e5) is accepted
  virtual std::string string() const = 0;
  virtual bool is_string() const = 0;  // for keys that take a number or a word
  std::string choice() const;  // one of the key's choices, else an error suggesting the nearest
  virtual std::vector<double> numbers() const = 0;
  virtual std::filesystem::path existing_file() const = 0;  // relative to the run file
  virtual std::filesystem::path path() const = 0;           // relative to the run file
  virtual TableauConfig tableau() const = 0;                // an [integrator.tableau] table
  [[noreturn]] virtual void fail(const std::string& problem) const = 0;
  void require(bool ok, const std::string& problem) const {
    if (!ok) fail(problem);
  }
  virtual const ConfigKey& key() const = 0;
};

// Whether `vimd run --continue` accepts a checkpoint written under another value of the key.
enum class OnContinue {
  must_match,  // the outputs would not be the uninterrupted run's
  may_change,  // e.g. steps: how far to go on
};

struct ConfigKey {
  std::string section;  // "forcefield", or "integrator" for the [integrator.tableau] table
  std::string name;
  std::string type;                  // for the reference, e.g. "number, nm"
  std::vector<std::string> choices;  // the values a string key accepts
  OnContinue on_continue;
  std::string help;  // one line
  std::function<void(const KeyInput&, RunConfig&)> read;
  // The value's exact text ("0.9", "potential-shift", "(unset)"): a run's identity, `vimd check`,
  // and, of a default RunConfig, the reference's default.
  std::function<std::string(const RunConfig&)> value;
};

// The keys a run file (with the settings given next to it) has, for the rules between keys: a rule
// reports at the line of the key that breaks it.
class GivenKeys {
 public:
  virtual ~GivenKeys() = default;
  // The key's value as given, or nullptr when it was left at its default.
  virtual const KeyInput* find(const std::string& section, const std::string& name) const = 0;
};

// A rule between keys, checked after every key is read; it fails through the KeyInput of a given key.
using ConfigRule = std::function<void(const GivenKeys&, const RunConfig&)>;

struct ConfigSchema {
  std::vector<ConfigKey> keys;    // in the reference's order; a section's keys together
  std::vector<ConfigRule> rules;  // in the order they are checked
  // The sections in the order of their keys (system, forcefield, integrator, output).
  std::vector<std::string> sections() const;
  // The key of `section` named `name`, or nullptr.
  const ConfigKey* find(const std::string& section, const std::string& name) const;
};

// The engine's own keys: [system], the [integrator] keys of DynamicsConfig, and [output].
std::vector<ConfigKey> system_keys();
std::vector<ConfigKey> dynamics_keys();
std::vector<ConfigKey> output_keys();

// The closest of `choices` to `word` when it is close enough to be a plausible typo.
std::optional<std::string> nearest_word(const std::string& word, const std::vector<std::string>& choices);

// Exact decimal text of x: the shortest of %.15g and %.17g that reads back as x.
std::string exact_text(double x);
// The text of x as an error message quotes a setting (as an ostream prints it: 0.9, 1e-05).
std::string format_number(double x);

// What a continued run must share with the stopped one: the resolved system (system_identity),
// then every key marked must_match (as "[section] name"), then how often the summary samples.
RunIdentity run_identity(const System& system, const RunConfig& config, const ConfigSchema& schema,
                         long summary_every);

// "[section] name = value" of every key whose value differs from the default, one section per line.
std::vector<std::string> non_default_settings(const RunConfig& config, const ConfigSchema& schema);

// A key's default as the references show it: "(required)" for the input files, which have none.
std::string shown_default(const ConfigKey& key);

// The run-file reference in Markdown (docs/run-file.md is this text).
std::string config_reference_markdown(const ConfigSchema& schema);

// --- Building keys whose value is one field of a settings struct: the engine's own (DynamicsConfig,
// OutputConfig) or a component's, held in RunConfig::components.

// The struct S of a RunConfig (or a const RunConfig).
template <class S, class Config>
auto& settings_of(Config& c) {
  if constexpr (std::is_same_v<S, DynamicsConfig>) return c.dynamics;
  else if constexpr (std::is_same_v<S, OutputConfig>) return c.output;
  else return c.components.template get<S>();
}

namespace detail {
template <class M>
struct MemberOf;
template <class S, class F>
struct MemberOf<F S::*> {
  using type = S;
};
template <auto Field>
using Owner = typename MemberOf<decltype(Field)>::type;
}  // namespace detail

// A number (T = double) or integer (T = long) field checked on its own.
template <auto Field, class T>
ConfigKey checked_key(std::string section, std::string name, std::string type, OnContinue on_continue,
                      std::string help, bool (*valid)(T), std::string problem) {
  using S = detail::Owner<Field>;
  return {std::move(section),
          std::move(name),
          std::move(type),
          {},
          on_continue,
          std::move(help),
          [valid, problem](const KeyInput& in, RunConfig& c) {
            T value;
            if constexpr (std::is_same_v<T, double>) value = in.number();
            else value = in.integer();
            in.require(valid(value), problem);
            settings_of<S>(c).*Field = value;
          },
          [](const RunConfig& c) {
            if constexpr (std::is_same_v<T, double>) return exact_text(settings_of<S>(c).*Field);
            else return std::to_string(settings_of<S>(c).*Field);
          }};
}
template <auto Field>
ConfigKey number_key(std::string section, std::string name, std::string type, OnContinue on_continue, std::string help,
                     bool (*valid)(double), std::string problem) {
  return checked_key<Field, double>(std::move(section), std::move(name), std::move(type), on_continue,
                                    std::move(help), valid, std::move(problem));
}
template <auto Field>
ConfigKey integer_key(std::string section, std::string name, std::string type, OnContinue on_continue, std::string help,
                      bool (*valid)(long), std::string problem) {
  return checked_key<Field, long>(std::move(section), std::move(name), std::move(type), on_continue,
                                  std::move(help), valid, std::move(problem));
}

// A string field with a fixed set of choices.
template <auto Field>
ConfigKey choice_key(std::string section, std::string name, std::vector<std::string> choices, OnContinue on_continue,
                     std::string help) {
  using S = detail::Owner<Field>;
  return {std::move(section),
          std::move(name),
          "string",
          std::move(choices),
          on_continue,
          std::move(help),
          [](const KeyInput& in, RunConfig& c) { settings_of<S>(c).*Field = in.choice(); },
          [](const RunConfig& c) { return settings_of<S>(c).*Field; }};
}

}  // namespace vimd
