#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <set>

#include "app/run_schema.hpp"
#include "engine/checkpoint.hpp"
#include "engine/config.hpp"
#include "engine/config_schema.hpp"
#include "engine/errors.hpp"
#include "forcefields/settings.hpp"
#include "integrators/registry.hpp"
#include "integrators/settings.hpp"
#include "marked_line.hpp"

namespace fs = std::filesystem;
using namespace vimd;

namespace {
const fs::path kConfig = fs::path(VIMD_SOURCE_DIR) / "tests/data/config";
const fs::path kData = fs::path(VIMD_SOURCE_DIR) / "tests/data";
}  // namespace

TEST(Config, ReadsEveryKey) {
  const RunConfig c = read_config(kConfig / "full.toml", run_schema());
  EXPECT_EQ(c.file, kConfig / "full.toml");
  EXPECT_EQ(c.constraints, "h-bonds");
  // Relative paths are relative to the config file's directory.
  EXPECT_EQ(c.structure, (kData / "gro/water2.gro").lexically_normal());
  EXPECT_EQ(c.topology, (kData / "top/spce_opls.top").lexically_normal());
  EXPECT_EQ(c.output.dir, kConfig / "results/run1");
  EXPECT_EQ(c.output.trajectory_every, 50);
  EXPECT_EQ(c.output.energy_every, 5);
  EXPECT_EQ(c.output.checkpoint_every, 2000);

  EXPECT_DOUBLE_EQ(forcefield_config(c).cutoff, 1.0);
  EXPECT_EQ(forcefield_config(c).vdw_modifier, "potential-switch");
  EXPECT_DOUBLE_EQ(forcefield_config(c).vdw_switch, 0.8);
  EXPECT_EQ(forcefield_config(c).coulomb, "reaction-field");
  EXPECT_DOUBLE_EQ(forcefield_config(c).epsilon_r, 1.0);  // an integer where a number is expected is fine
  EXPECT_DOUBLE_EQ(forcefield_config(c).epsilon_rf, 78.0);
  EXPECT_DOUBLE_EQ(forcefield_config(c).neighbor_skin, 0.12);
  EXPECT_EQ(forcefield_config(c).coulomb_modifier, "potential-switch");
  EXPECT_DOUBLE_EQ(forcefield_config(c).coulomb_switch, 0.75);
  EXPECT_EQ(forcefield_config(c).switch_smoothness, 4);

  const IntegratorConfig in = integrator_config(c);
  EXPECT_EQ(in.type, "vi");
  EXPECT_DOUBLE_EQ(in.dt, 0.001);
  EXPECT_EQ(in.steps, 500);
  EXPECT_DOUBLE_EQ(in.constraint_tolerance, 1e-12);
  ASSERT_TRUE(in.temperature.has_value());
  EXPECT_DOUBLE_EQ(*in.temperature, 300.0);
  EXPECT_EQ(in.seed, 42u);
  EXPECT_EQ(in.method, "user");
  EXPECT_EQ(in.method_minus, std::optional<std::string>("rk4"));
  EXPECT_EQ(in.bias, (std::array<double, 2>{0.25, 0.75}));
  EXPECT_EQ(in.projection, "mass");
  EXPECT_EQ(in.solver_tolerance, std::optional<double>(1e-11));
  EXPECT_EQ(in.max_iterations, 30);
  EXPECT_EQ(in.acceleration, "anderson");
  EXPECT_EQ(in.solver_precision, "double");
  ASSERT_TRUE(in.tableau.has_value());
  EXPECT_EQ(in.tableau->a, (std::vector<std::vector<double>>{{0.0, 0.0}, {0.5, 0.0}}));
  EXPECT_EQ(in.tableau->b, (std::vector<double>{0.0, 1.0}));
  EXPECT_EQ(in.tableau->c, (std::vector<double>{0.0, 0.5}));  // not given: row sums of a
  EXPECT_EQ(in.tableau->order, 2);
  EXPECT_EQ(in.tableau->line, marked_line(kConfig / "full.toml", "[integrator.tableau]"));
}

TEST(Config, DefaultsFromTheContract) {
  const RunConfig c = read_config(kConfig / "minimal.toml", run_schema());
  const ForceFieldConfig ff;
  const IntegratorConfig in;
  const OutputConfig out;
  EXPECT_EQ(forcefield_config(c).cutoff, ff.cutoff);
  EXPECT_EQ(forcefield_config(c).vdw_modifier, ff.vdw_modifier);
  EXPECT_EQ(forcefield_config(c).coulomb, ff.coulomb);
  EXPECT_EQ(forcefield_config(c).epsilon_rf, ff.epsilon_rf);
  EXPECT_EQ(forcefield_config(c).coulomb_modifier, "potential-shift");  // GROMACS's default
  EXPECT_EQ(forcefield_config(c).switch_smoothness, 2);  // GROMACS's potential-switch
  EXPECT_EQ(forcefield_config(c).neighbor_skin, ff.neighbor_skin);
  EXPECT_EQ(integrator_settings(c).type, in.type);
  EXPECT_EQ(c.dynamics.dt, in.dt);
  EXPECT_EQ(c.dynamics.steps, in.steps);
  EXPECT_EQ(c.dynamics.constraint_tolerance, in.constraint_tolerance);
  EXPECT_FALSE(c.dynamics.temperature.has_value());
  EXPECT_FALSE(integrator_settings(c).tableau.has_value());
  EXPECT_EQ(integrator_settings(c).method, in.method);
  EXPECT_EQ(integrator_settings(c).solver_precision, "mixed");
  EXPECT_EQ(c.output.trajectory_every, out.trajectory_every);
  EXPECT_EQ(c.output.energy_every, out.energy_every);
  EXPECT_EQ(c.output.checkpoint_every, 0);  // 0: by wall time
  EXPECT_EQ(c.output.dir, kConfig / out.dir);  // the default dir is relative to the config too
}

TEST(Config, SolverToleranceTakesANumberOrAuto) {
  const RunConfig c = read_config(kConfig / "auto_tolerance.toml", run_schema());
  EXPECT_TRUE(integrator_settings(c).solver_tolerance_auto);
  EXPECT_FALSE(integrator_settings(c).solver_tolerance.has_value());
  EXPECT_FALSE(integrator_settings(read_config(kConfig / "minimal.toml", run_schema())).solver_tolerance_auto);
}

TEST(Config, MalformedConfigsNameFileAndLine) {
  struct Case {
    const char* file;
    const char* problem;
  };
  const Case cases[] = {
      {"unknown_key.toml", "unknown key 'cutof' in [forcefield]; did you mean 'cutoff'?"},
      {"unknown_table.toml", "unknown table [integrater]; did you mean [integrator]?"},
      {"key_in_wrong_table.toml", "'dt' belongs in [integrator]"},
      {"top_level_key.toml", "'steps' must be inside [integrator]"},
      {"syntax_error.toml", "TOML syntax error"},
      {"negative_dt.toml", "dt must be positive"},
      {"negative_steps.toml", "steps must not be negative"},
      {"zero_cutoff.toml", "cutoff must be positive"},
      {"bad_modifier.toml", "did you mean \"potential-shift\"? (choices: none, potential-shift, force-switch, potential-switch)"},
      {"bad_coulomb.toml", "coulomb = \"multipole\" is not supported (choices: reaction-field, cutoff, pme, none)"},
      {"bad_integrator_type.toml", "(choices: verlet, shake, rattle, vi, rk, minimize)"},
      {"bad_projection.toml", "(choices: euclidean, mass)"},
      {"bad_solver_precision.toml", "(choices: mixed, double)"},
      {"bad_solver_tolerance_word.toml", "solver_tolerance must be a positive number (nm/ps) or \"auto\", not \"fast\""},
      {"wrong_type.toml", "steps must be an integer, found a string"},
      {"fractional_steps.toml", "steps must be an integer, found a floating-point number"},
      {"string_cutoff.toml", "cutoff must be a number, found a string"},
      {"switch_beyond_cutoff.toml", "must be smaller than cutoff"},
      {"bad_bias.toml", "bias must have two numbers"},
      {"ragged_tableau.toml", "tableau a must be square"},
      {"tableau_without_user.toml", "method must be \"user\""},
      {"missing_structure.toml", "[system] needs structure"},
      {"structure_not_found.toml", "nowhere.gro does not exist"},
      {"negative_energy_every.toml", "energy_every must not be negative"},
      {"negative_checkpoint_every.toml", "checkpoint_every must not be negative"},
      {"infinite_dt.toml", "dt must be a finite number"},
      {"control_character.toml", "control character 0x01"},
      {"non_ascii_after_value.toml", "non-ASCII character outside a string or comment"},
      {"non_ascii_key.toml", "non-ASCII character in a quoted key"},
      {"non_ascii_multi_line_string.toml", "non-ASCII character in a multi-line string"},
      {"bad_switch_smoothness.toml", "switch_smoothness must be between 2 and 6"},
      {"fractional_switch_smoothness.toml", "switch_smoothness must be an integer, found a floating-point number"},
      {"coulomb_switch_beyond_cutoff.toml", "coulomb_switch (0.95 nm) must be smaller than cutoff (0.9 nm)"},
      {"coulomb_switch_missing.toml", "needs coulomb_switch"},
      {"coulomb_modifier_without_coulomb.toml", "needs coulomb = \"reaction-field\", \"cutoff\" or \"pme\""},
      {"bad_coulomb_modifier.toml", "(choices: none, potential-shift, potential-switch)"},
      {"composition_with_shake.toml", "SHAKE's leap-frog state holds half-step velocities"},
      {"composition_with_vi.toml", "composition is for type = \"rattle\" (type is \"vi\")"},
      {"composition_weights_without_user.toml", "composition_weights is given, so composition must be \"user\""},
      {"user_composition_without_order.toml", "composition = \"user\" needs composition_order"},
      {"odd_composition_order.toml", "composition_order must be 2, 4, 6, 8 or 10"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.file);
    const fs::path file = kConfig / "bad" / c.file;
    const int line = marked_line(file, "# ERROR");
    try {
      read_config(file, run_schema());
      ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_EQ(e.line(), line) << what;
      EXPECT_NE(what.find(std::string(c.file) + ":" + std::to_string(line) + ": "), std::string::npos) << what;
      EXPECT_NE(what.find(c.problem), std::string::npos) << what;
    }
  }
}

// Non-ASCII text is refused only where the TOML parser cannot take it (see config.cpp).
// A setting found wrong after reading (a component built from it, or checked against the system)
// names the run file's line of the key, else of its table, else the settings given next to it.
TEST(Config, SettingErrorsFoundLaterNameTheKeysLine) {
  const fs::path file = kConfig / "full.toml";
  const RunConfig c = read_config(file, run_schema());
  const auto message = [&](const SettingError& e) {
    try {
      c.located([&] { throw e; });
    } catch (const SettingError&) {
      return std::string("not located");
    } catch (const InputError& located) {
      return std::string(located.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message(SettingError("integrator", "bias", "bad bias")),
            file.string() + ":" + std::to_string(marked_line(file, "bias = ")) + ": bad bias");
  // emtol is left at its default: the table's line, naming the key.
  EXPECT_EQ(message(SettingError("integrator", "emtol", "bad emtol")),
            file.string() + ":" + std::to_string(marked_line(file, "[integrator]")) +
                ": [integrator] emtol: bad emtol");
  const RunConfig given = read_config(file, run_schema(), {{"bias", std::vector<double>{0.0, 1.0}}});
  try {
    given.located([] { throw SettingError("integrator", "bias", "bad bias"); });
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "settings given with the config file: [integrator] bias: bad bias");
  }
  // A component's own check, through the integrator registry.
  const fs::path weights = kData.parent_path() / "bad_inputs/composition_user_false_order/run.toml";
  const RunConfig user = read_config(weights, run_schema());
  try {
    user.located([&] { make_integrator(integrator_config(user)); });
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    const std::string where = weights.string() + ":" + std::to_string(marked_line(weights, "composition_weights =")) +
                              ": composition_weights: the weights claim order 6";
    EXPECT_EQ(std::string(e.what()).rfind(where, 0), 0u) << e.what();
  }
}

TEST(Config, NonAsciiTextInCommentsAndStringValuesIsRead) {
  const RunConfig c = read_config(kConfig / "non_ascii.toml", run_schema());
  EXPECT_EQ(c.output.dir, kConfig / "r\xc3\xa9sultats/\xe6\xb0\xb4");
  EXPECT_EQ(integrator_settings(c).bias[0], 0.25);
  EXPECT_EQ(integrator_settings(c).bias[1], 0.75);
}

TEST(Config, MissingFileIsAnInputError) {
  try {
    read_config(kConfig / "no_such.toml", run_schema());
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no_such.toml"), std::string::npos);
  }
}

// A value handed to a key's reader as if a run file had it.
class GivenValue final : public KeyInput {
 public:
  GivenValue(const ConfigKey& key, ConfigValue value) : key_(key), value_(std::move(value)) {}
  double number() const override {
    return std::holds_alternative<long>(value_) ? static_cast<double>(std::get<long>(value_)) : std::get<double>(value_);
  }
  long integer() const override { return std::get<long>(value_); }
  std::string string() const override { return std::get<std::string>(value_); }
  bool is_string() const override { return std::holds_alternative<std::string>(value_); }
  std::vector<double> numbers() const override { return std::get<std::vector<double>>(value_); }
  fs::path existing_file() const override { return string(); }
  fs::path path() const override { return string(); }
  TableauConfig tableau() const override { return std::get<TableauConfig>(value_); }
  [[noreturn]] void fail(const std::string& problem) const override { throw InputError("given", 0, problem); }
  const ConfigKey& key() const override { return key_; }

 private:
  const ConfigKey& key_;
  ConfigValue value_;
};

// Every key of the schema is decided for a continued run: a key that must match changes the
// identity (and check_identity names it), one that may change leaves it alone. A new key fails
// here until it has an alternative value below, and so a decision.
TEST(ConfigSchema, EveryKeyIsPartOfTheIdentityOrAllowedToChange) {
  const std::map<std::string, ConfigValue> alternative = {
      {"structure", std::string("other.gro")},
      {"topology", std::string("other.top")},
      {"constraints", std::string("all-bonds")},
      {"cutoff", 1.1},
      {"vdw_modifier", std::string("force-switch")},
      {"vdw_switch", 0.7},
      {"coulomb", std::string("cutoff")},
      {"coulomb_modifier", std::string("none")},
      {"coulomb_switch", 0.7},
      {"switch_smoothness", 3L},
      {"epsilon_r", 2.0},
      {"epsilon_rf", 0.0},
      {"ewald_rtol", 1e-6},
      {"pme_order", 8L},
      {"fourier_spacing", 0.1},
      {"fourier_nx", 32L},
      {"fourier_ny", 32L},
      {"fourier_nz", 32L},
      {"neighbor_skin", 0.1},
      {"neighbor_search_skin", 0.5},
      {"precision", std::string("mixed")},
      {"type", std::string("rattle")},
      {"dt", 0.002},
      {"steps", 100L},
      {"constraint_tolerance", 1e-10},
      {"temperature", 310.0},
      {"seed", 7L},
      {"thermostat", std::string("v-rescale")},
      {"tau_t", 0.5},
      {"emtol", 1.0},
      {"emstep", 0.02},
      {"method", std::string("rk4")},
      {"method_minus", std::string("rk6")},
      {"bias", std::vector<double>{0.0, 1.0}},
      {"projection", std::string("euclidean")},
      {"solver_tolerance", 1e-9},
      {"max_iterations", 40L},
      {"acceleration", std::string("none")},
      {"solver_precision", std::string("mixed")},
      {"composition", std::string("yoshida4")},
      {"composition_weights", std::vector<double>{0.5, 0.5}},
      {"composition_order", 4L},
      {"tableau", TableauConfig{{{0.0, 0.0}, {1.0, 0.0}}, {0.5, 0.5}, {0.0, 1.0}, 2, 0}},
      {"dir", std::string("results/run2")},
      {"trajectory_every", 10L},
      {"energy_every", 1L},
      {"checkpoint_every", 0L},
  };
  const System system;
  const RunConfig base = read_config(kConfig / "full.toml", run_schema());
  const RunIdentity base_identity = run_identity(system, base, run_schema(), 5);
  for (const ConfigKey& key : run_schema().keys) {
    SCOPED_TRACE("[" + key.section + "] " + key.name);
    const auto it = alternative.find(key.name);
    ASSERT_NE(it, alternative.end()) << "a new key: give it an alternative value here and decide (OnContinue) "
                                        "whether a continued run may change it";
    RunConfig changed = base;
    key.read(GivenValue(key, it->second), changed);
    ASSERT_NE(key.value(changed), key.value(base)) << "the alternative value is full.toml's own";
    const RunIdentity identity = run_identity(system, changed, run_schema(), 5);
    // Which settings a continued run may change is a decision: changing it changes this list.
    const std::set<std::string> may_change = {"structure", "topology", "steps", "dir", "checkpoint_every"};
    EXPECT_EQ(key.on_continue == OnContinue::may_change, may_change.count(key.name) == 1);
    if (key.on_continue == OnContinue::may_change) {
      EXPECT_EQ(identity, base_identity);
    } else {
      try {
        check_identity("state.cpt", base_identity, identity);
        ADD_FAILURE() << "a continued run accepts another value of this key";
      } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("[" + key.section + "] " + key.name + ": "), std::string::npos)
            << e.what();
      }
    }
  }
}

// Every key the schema lists is one the reader accepts, and a settings override reaches it.
TEST(ConfigSchema, OverridesReachEveryNamedKey) {
  const RunConfig c = read_config(kConfig / "full.toml", run_schema(), {{"switch_smoothness", 5L}, {"coulomb_switch", 0.6}});
  EXPECT_EQ(forcefield_config(c).switch_smoothness, 5);
  EXPECT_DOUBLE_EQ(forcefield_config(c).coulomb_switch, 0.6);
}

// docs/run-file.md is the schema's reference as `vimd keys --markdown` prints it.
TEST(ConfigSchema, ReferenceInDocsIsCurrent) {
  std::ifstream in(fs::path(VIMD_SOURCE_DIR) / "docs/run-file.md");
  const std::string docs{std::istreambuf_iterator<char>(in), {}};
  EXPECT_EQ(docs, config_reference_markdown(run_schema())) << "regenerate it: build/vimd keys --markdown > docs/run-file.md";
}

// The assembled schema is the engine's keys and every component's, each once, with every
// component's rules: a component's key is readable, listed and part of the identity without the
// engine naming it.
TEST(ConfigSchema, AssemblesTheEngineAndEveryComponent) {
  std::vector<ConfigKey> parts = system_keys();
  for (auto more : {forcefield_keys(), std::vector<ConfigKey>{integrator_type_key()}, dynamics_keys(),
                    integrator_keys(), output_keys()})
    parts.insert(parts.end(), more.begin(), more.end());
  const ConfigSchema& schema = run_schema();
  ASSERT_EQ(schema.keys.size(), parts.size());
  std::set<std::pair<std::string, std::string>> names;
  for (std::size_t k = 0; k < parts.size(); ++k) {
    SCOPED_TRACE("[" + parts[k].section + "] " + parts[k].name);
    EXPECT_EQ(schema.keys[k].section, parts[k].section);  // in the reference's order
    EXPECT_EQ(schema.keys[k].name, parts[k].name);
    EXPECT_EQ(schema.find(parts[k].section, parts[k].name), &schema.keys[k]);
    EXPECT_TRUE(names.emplace(parts[k].section, parts[k].name).second) << "listed twice";
  }
  EXPECT_EQ(schema.sections(), (std::vector<std::string>{"system", "forcefield", "integrator", "output"}));
  EXPECT_EQ(schema.rules.size(), forcefield_rules().size() + integrator_rules().size());
}

// The run file offers exactly the integrators the registry builds.
TEST(ConfigSchema, IntegratorTypesAreTheRegistrys) {
  const ConfigKey* type = run_schema().find("integrator", "type");
  ASSERT_NE(type, nullptr);
  EXPECT_EQ(type->choices, integrator_names());
}
