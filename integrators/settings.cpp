#include "integrators/settings.hpp"

#include "integrators/registry.hpp"

namespace vimd {

namespace {

constexpr OnContinue kMustMatch = OnContinue::must_match;

// A user tableau's value text: a fingerprint of its coefficients and claimed order.
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

// The v-rescale thermostat (verlet, rattle).
void add_thermostat_keys(std::vector<ConfigKey>& k) {
  k.push_back(choice_key<&IntegratorSettings::thermostat>(
      "integrator", "thermostat", {"none", "v-rescale"}, kMustMatch,
      "v-rescale (Bussi) with verlet and rattle; needs temperature"));
  k.push_back(number_key<&IntegratorSettings::tau_t>(
      "integrator", "tau_t", "number, ps", kMustMatch, "the thermostat's time constant",
      [](double v) { return v >= 0; }, "tau_t must not be negative (ps)"));
}

// RATTLE as a symmetric composition of its own steps.
void add_composition_keys(std::vector<ConfigKey>& k) {
  k.push_back(choice_key<&IntegratorSettings::composition>(
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
                 std::vector<double>& weights = integrator_settings(c).composition_weights;
                 weights = in.numbers();
                 in.require(!weights.empty(), "composition_weights must not be empty");
               },
               [](const RunConfig& c) {
                 const std::vector<double>& weights = integrator_settings(c).composition_weights;
                 if (weights.empty()) return std::string("(none)");
                 std::string text;
                 for (double w : weights) text += (text.empty() ? "[" : ", ") + exact_text(w);
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
                 integrator_settings(c).composition_order = static_cast<int>(order);
               },
               [](const RunConfig& c) {
                 const int order = integrator_settings(c).composition_order;
                 return order ? std::to_string(order) : std::string("(none)");
               }});
}

// The steepest-descent minimiser.
void add_minimize_keys(std::vector<ConfigKey>& k) {
  k.push_back(number_key<&IntegratorSettings::emtol>(
      "integrator", "emtol", "number, kJ/mol/nm", kMustMatch,
      "minimize: stop when the largest constrained force is below this", [](double v) { return v > 0; },
      "emtol must be positive (kJ/mol/nm)"));
  k.push_back(number_key<&IntegratorSettings::emstep>(
      "integrator", "emstep", "number, nm", kMustMatch, "minimize: the first step's largest displacement",
      [](double v) { return v > 0; }, "emstep must be positive (nm)"));
}

// The Runge-Kutta methods: vi (variational) and rk (projected).
void add_runge_kutta_keys(std::vector<ConfigKey>& k) {
  k.push_back({"integrator",
               "method",
               "string",
               {},
               kMustMatch,
               "vi, rk: the tableau: euler heun2 midpoint rk3 rk4 rk38 rk6 rk8, or user ([integrator.tableau])",
               [](const KeyInput& in, RunConfig& c) {
                 integrator_settings(c).method = in.string();
                 in.require(!integrator_settings(c).method.empty(), "method must not be empty");
               },
               [](const RunConfig& c) { return integrator_settings(c).method; }});
  k.push_back({"integrator",
               "method_minus",
               "string",
               {},
               kMustMatch,
               "vi: the method of the left discrete Lagrangian (unset: the same as method)",
               [](const KeyInput& in, RunConfig& c) {
                 integrator_settings(c).method_minus = in.string();
                 in.require(!integrator_settings(c).method_minus->empty(), "method_minus must not be empty");
               },
               [](const RunConfig& c) { return integrator_settings(c).method_minus.value_or("(same)"); }});
  k.push_back({"integrator",
               "bias",
               "array of two numbers",
               {},
               kMustMatch,
               "vi: [alpha_minus, alpha_plus], where the discrete Lagrangians sit in the step",
               [](const KeyInput& in, RunConfig& c) {
                 const auto bias = in.numbers();
                 in.require(bias.size() == 2, "bias must have two numbers [alpha_minus, alpha_plus]");
                 integrator_settings(c).bias = {bias[0], bias[1]};
               },
               [](const RunConfig& c) {
                 const auto& bias = integrator_settings(c).bias;
                 std::string text = "[";  // appended, not "[" + ...: g++ 12 warns falsely there (-Wrestrict)
                 return text.append(exact_text(bias[0])).append(", ").append(exact_text(bias[1])).append("]");
               }});
  k.push_back(choice_key<&IntegratorSettings::projection>(
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
                   integrator_settings(c).solver_tolerance_auto = true;
                   return;
                 }
                 integrator_settings(c).solver_tolerance = in.number();
                 in.require(*integrator_settings(c).solver_tolerance > 0, "solver_tolerance must be positive");
               },
               [](const RunConfig& c) {
                 if (integrator_settings(c).solver_tolerance_auto) return std::string("auto");
                 return integrator_settings(c).solver_tolerance ? exact_text(*integrator_settings(c).solver_tolerance)
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
                 integrator_settings(c).max_iterations = static_cast<int>(iterations);
               },
               [](const RunConfig& c) { return std::to_string(integrator_settings(c).max_iterations); }});
  k.push_back(choice_key<&IntegratorSettings::acceleration>(
      "integrator", "acceleration", {"none", "anderson"}, kMustMatch,
      "vi: Anderson mixing of the step's fixed-point iteration"));
  k.push_back(choice_key<&IntegratorSettings::solver_precision>(
      "integrator", "solver_precision", {"mixed", "double"}, kMustMatch,
      "vi: mixed runs the pair kernels in single precision where the solve absorbs the rounding"));
  k.push_back({"integrator",
               "tableau",
               "table: a, b, c, order",
               {},
               kMustMatch,
               "[integrator.tableau]: a user's explicit tableau (a square, b, c = row sums of a if left out, "
               "the order it claims, checked); method = \"user\"",
               [](const KeyInput& in, RunConfig& c) { integrator_settings(c).tableau = in.tableau(); },
               [](const RunConfig& c) { return tableau_text(integrator_settings(c).tableau); }});
}

}  // namespace

ConfigKey integrator_type_key() {
  return choice_key<&IntegratorSettings::type>(
      "integrator", "type", integrator_names(), kMustMatch,
      "the integrator (vi: variational from a Runge-Kutta method; rk: projected Runge-Kutta)");
}

std::vector<ConfigKey> integrator_keys() {
  std::vector<ConfigKey> k;
  add_thermostat_keys(k);
  add_composition_keys(k);
  add_minimize_keys(k);
  add_runge_kutta_keys(k);
  return k;
}

std::vector<ConfigRule> integrator_rules() {
  const auto thermostat_needs_temperature = [](const GivenKeys& given, const RunConfig& c) {
    const IntegratorSettings& in = integrator_settings(c);
    if (const KeyInput* thermostat = given.find("integrator", "thermostat"))
      thermostat->require(in.thermostat == "none" || c.dynamics.temperature,
                          "thermostat = \"" + in.thermostat +
                              "\" needs temperature = <K> in [integrator] (the reference)");
  };
  const auto user_tableau_is_the_method = [](const GivenKeys& given, const RunConfig& c) {
    const IntegratorSettings& in = integrator_settings(c);
    const KeyInput* method = given.find("integrator", "method");
    if (const KeyInput* tableau = given.find("integrator", "tableau"))
      (method ? *method : *tableau)
          .require(in.method == "user",
                   "[integrator.tableau] is given, so method must be \"user\" (it is \"" + in.method + "\")");
    else if (in.method == "user")
      method->fail("method = \"user\" needs an [integrator.tableau] table with a, b and order");
  };
  const auto composition_is_rattles = [](const GivenKeys& given, const RunConfig& c) {
    const IntegratorSettings& in = integrator_settings(c);
    if (const KeyInput* composition = given.find("integrator", "composition")) {
      if (in.type == "shake")
        composition->require(
            in.composition == "none",
            "composition is for type = \"rattle\": SHAKE's leap-frog state holds half-step velocities, which "
            "sub-steps of other lengths cannot share; type = \"rattle\" takes the same positions with on-step "
            "velocities");
      composition->require(in.composition == "none" || in.type == "rattle",
                           "composition is for type = \"rattle\" (type is \"" + in.type + "\")");
    }
    for (const char* user_key : {"composition_weights", "composition_order"})
      if (const KeyInput* user_given = given.find("integrator", user_key))
        user_given->require(in.composition == "user", std::string(user_key) +
                                                          " is given, so composition must be \"user\" (it is \"" +
                                                          in.composition + "\")");
    if (in.composition == "user") {
      const KeyInput& composition = *given.find("integrator", "composition");
      composition.require(
          given.find("integrator", "composition_weights") != nullptr,
          "composition = \"user\" needs composition_weights = [...] (the sub-steps as fractions of dt)");
      composition.require(given.find("integrator", "composition_order") != nullptr,
                          "composition = \"user\" needs composition_order (the order the weights claim, checked)");
    }
  };
  // The force field's precision key, by name: the integrators do not depend on the force field.
  const auto runge_kutta_needs_double_forces = [](const GivenKeys& given, const RunConfig& c) {
    const IntegratorSettings& in = integrator_settings(c);
    const KeyInput* precision = given.find("forcefield", "precision");
    if (precision && precision->string() == "mixed" && (in.type == "vi" || in.type == "rk"))
      precision->fail("precision = \"mixed\" is for verlet, shake, rattle and minimize: type = \"" + in.type +
                      "\" solves its step equations to a tolerance that single-precision forces cannot meet");
  };
  return {thermostat_needs_temperature, user_tableau_is_the_method, composition_is_rattles,
          runge_kutta_needs_double_forces};
}

}  // namespace vimd
