#pragma once
// The run file's keys, in one table: each key's section, type, help, how it is read and checked,
// its value's exact text, and whether a continued run must keep it. The reader, the defaults'
// listing, a checkpoint's identity, `vimd check`, `vimd keys` and docs/run-file.md all come from it.
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "engine/checkpoint.hpp"
#include "engine/config.hpp"
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

const std::vector<ConfigKey>& config_keys();
// The sections in the order the reference lists them: system, forcefield, integrator, output.
const std::vector<std::string>& config_sections();
// The key of `section` named `name`, or nullptr.
const ConfigKey* find_config_key(const std::string& section, const std::string& name);

// The closest of `choices` to `word` when it is close enough to be a plausible typo.
std::optional<std::string> nearest_word(const std::string& word, const std::vector<std::string>& choices);

// Exact decimal text of x: the shortest of %.15g and %.17g that reads back as x.
std::string exact_text(double x);

// What a continued run must share with the stopped one: the system's size, interactions and box,
// then every key marked must_match (as "[section] name"), then how often the summary samples.
RunIdentity run_identity(const System& system, const RunConfig& config, long summary_every);

// "[section] name = value" of every key whose value differs from the default, one section per line.
std::vector<std::string> non_default_settings(const RunConfig& config);

// A key's default as the references show it: "(required)" for the input files, which have none.
std::string shown_default(const ConfigKey& key);

// The run-file reference in Markdown (docs/run-file.md is this text).
std::string config_reference_markdown();

}  // namespace vimd
