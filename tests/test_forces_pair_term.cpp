// The nonbonded pair term over the pair-form registry: forces and Hessian–vector products against
// finite differences for every vdw modifier and Coulomb kind the run file offers, every switch
// combination, every variant of every registered form reached; and the reuse of a force pass's
// cut-off masks.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>
#include <type_traits>
#include <typeindex>
#include <utility>
#include <vector>

#include "engine/config_schema.hpp"
#include "forcefields/settings.hpp"
#include "forcefields/nonbonded/nonbonded_pair_term.hpp"
#include "forcefields/nonbonded/pair_forms.hpp"
#include "test_forces_common.hpp"

namespace vimd {
namespace {

using testing::evaluate;
using testing::expect_derivatives_match;
using testing::hessian_vector;
using testing::random_direction;

struct PairCase {
  std::string modifier, coulomb;
  double epsilon_rf;
};

void PrintTo(const PairCase& c, std::ostream* os) {
  *os << c.modifier << "/" << c.coulomb << "/eps_rf=" << c.epsilon_rf;
}

// Every vdw modifier with every Coulomb kind, as the run file offers them (the schema's choices, so
// that a pair form added to the registry with its `coulomb` value is checked from then on), and
// reaction field with eps_rf = 78, whose unswitched force jumps at rc.
const std::vector<std::string>& forcefield_choices(const std::string& key) {
  static const std::vector<ConfigKey> keys = forcefield_keys();
  for (const ConfigKey& k : keys)
    if (k.section == "forcefield" && k.name == key) return k.choices;
  throw std::logic_error("no [forcefield] key " + key);
}

std::vector<PairCase> pair_cases() {
  std::vector<PairCase> cases;
  for (const std::string& coulomb : forcefield_choices("coulomb"))
    for (const std::string& modifier : forcefield_choices("vdw_modifier")) cases.push_back({modifier, coulomb, 0.0});
  for (const char* modifier : {"potential-shift", "potential-switch"}) cases.push_back({modifier, "reaction-field", 78.0});
  return cases;
}

// 12 water-like molecules with no pair within 2e-4 nm of the cut-off, where the energy (LJ none)
// or the force (potential-shift) jumps and finite differences (steps up to 2e-5 nm) would mislead.
testing::TestSystem system_away_from_cutoff(const Vec3& box, const Vec3& extent, double cutoff) {
  for (std::uint64_t seed = 1;; ++seed) {
    auto t = testing::water_like_system(12, box, seed, extent);
    double gap = INFINITY;
    testing::for_each_pair_distance(t.system, t.q,
                                    [&](int, int, double r) { gap = std::min(gap, std::abs(r - cutoff)); });
    if (gap > 2e-4) return t;
  }
}

class PairTermDerivatives : public ::testing::TestWithParam<PairCase> {};

TEST_P(PairTermDerivatives, ForcesAndHessianVectorMatchFiniteDifferences) {
  const PairCase c = GetParam();
  const auto config = testing::pair_config(c.modifier, c.coulomb, c.epsilon_rf);
  auto [system, q] = system_away_from_cutoff(Vec3(2.0, 2.0, 2.0), Vec3::Zero(), config.cutoff);
  int in_switch_region = 0;
  testing::for_each_pair_distance(system, q, [&](int, int, double r) {
    if (r >= 0.7 && r < config.cutoff) ++in_switch_region;
  });
  ASSERT_GT(in_switch_region, 50);
  NonbondedPairTerm term(system, config);
  expect_derivatives_match(term, q, c.modifier + "/" + c.coulomb);
}

TEST_P(PairTermDerivatives, NonPeriodicSystem) {
  const PairCase c = GetParam();
  const auto config = testing::pair_config(c.modifier, c.coulomb, c.epsilon_rf);
  auto [system, q] = system_away_from_cutoff(Vec3::Zero(), Vec3(1.6, 1.4, 1.5), config.cutoff);
  NonbondedPairTerm term(system, config);
  expect_derivatives_match(term, q, c.modifier + "/" + c.coulomb + " non-periodic");
}

INSTANTIATE_TEST_SUITE_P(AllModifiersAndCoulombKinds, PairTermDerivatives, ::testing::ValuesIn(pair_cases()),
                         [](const auto& info) {
                           std::string name = info.param.modifier + "_" + info.param.coulomb + "_eps" +
                                              std::to_string(int(info.param.epsilon_rf));
                           for (char& ch : name)
                             if (ch == '-') ch = '_';
                           return name;
                         });

// Every vdw modifier × {unswitched, switched} Coulomb × switch smoothness 2..6, for reaction field
// (eps_rf = 78: the unswitched force jumps at rc) and plain cut-off Coulomb. The Coulomb switch
// starts at 0.6 nm, or at 0.05 nm so that the excluded intramolecular pairs are switched too.
struct SwitchCase {
  std::string vdw, coulomb, coulomb_modifier;
  int smoothness;
  double coulomb_switch;
};

void PrintTo(const SwitchCase& c, std::ostream* os) {
  *os << c.vdw << "/" << c.coulomb << "/" << c.coulomb_modifier << "/k=" << c.smoothness << "/from " << c.coulomb_switch;
}

ForceFieldConfig switch_config(const SwitchCase& c) {
  auto config = testing::pair_config(c.vdw, c.coulomb, 78.0);
  config.coulomb_modifier = c.coulomb_modifier;
  config.coulomb_switch = c.coulomb_switch;
  config.switch_smoothness = c.smoothness;
  return config;
}

class SwitchedPairTermDerivatives : public ::testing::TestWithParam<SwitchCase> {};

TEST_P(SwitchedPairTermDerivatives, ForcesAndHessianVectorMatchFiniteDifferences) {
  const SwitchCase c = GetParam();
  const auto config = switch_config(c);
  for (const Vec3& box : {Vec3(2.0, 2.0, 2.0), Vec3(0.0, 0.0, 0.0)}) {
    auto [system, q] = system_away_from_cutoff(box, Vec3(1.6, 1.4, 1.5), config.cutoff);
    NonbondedPairTerm term(system, config);
    std::ostringstream what;
    PrintTo(c, &what);
    expect_derivatives_match(term, q, what.str() + (box[0] > 0 ? "" : " non-periodic"));
  }
}

std::vector<SwitchCase> switch_cases() {
  std::vector<SwitchCase> cases;
  for (int k = 2; k <= 6; ++k)
    for (const char* vdw : {"none", "potential-shift", "force-switch", "potential-switch"})
      for (const char* modifier : {"none", "potential-switch"}) cases.push_back({vdw, "reaction-field", modifier, k, 0.6});
  for (int k : {2, 5}) {
    cases.push_back({"potential-switch", "reaction-field", "potential-switch", k, 0.7});  // LJ's switch: shared
    cases.push_back({"potential-switch", "cutoff", "potential-switch", k, 0.6});
    cases.push_back({"potential-switch", "reaction-field", "potential-switch", k, 0.05});
  }
  for (int k = 2; k <= 6; ++k) cases.push_back({"potential-switch", "pme", "potential-switch", k, 0.6});
  cases.push_back({"potential-shift", "pme", "none", 2, 0.6});  // PME unshifted: the energy jumps at rc
  return cases;
}

INSTANTIATE_TEST_SUITE_P(EveryCombination, SwitchedPairTermDerivatives, ::testing::ValuesIn(switch_cases()),
                         [](const auto& info) {
                           const SwitchCase& c = info.param;
                           std::string name = c.vdw + "_" + c.coulomb + "_" + c.coulomb_modifier + "_k" +
                                              std::to_string(c.smoothness) +
                                              (c.coulomb_switch < 0.1   ? "_from_0_05"
                                               : c.coulomb_switch == 0.7 ? "_shared_switch"
                                                                         : "");
                           for (char& ch : name)
                             if (ch == '-') ch = '_';
                           return name;
                         });

// The forms' variants the cases above reach: (form, index in its kVariants).
using FormVariant = std::pair<std::type_index, std::size_t>;

void record_variants(const ForceFieldConfig& config, std::set<FormVariant>& reached) {
  for_each_present_form(make_pair_form_constants(config), [&](const auto& form) {
    const auto& variants = std::remove_cvref_t<decltype(form)>::kVariants;
    const auto k = std::find(variants.begin(), variants.end(), form.variant()) - variants.begin();
    reached.insert({typeid(form), static_cast<std::size_t>(k)});
  });
}

template <class... Form>
void expect_every_variant_reached(const std::set<FormVariant>& reached, std::tuple<Form...>*) {
  const auto expect_reached = [&]<class F>(std::type_identity<F>) {
    for (std::size_t k = 0; k < F::kVariants.size(); ++k)
      EXPECT_TRUE(reached.count({typeid(F), k})) << typeid(F).name() << ": variant " << k << " has no derivative check";
  };
  (expect_reached(std::type_identity<Form>{}), ...);
}

// Every variant of every form in the registry (pair_forms.hpp) is among the derivative checks above:
// a form or variant added there fails here until it is checked.
TEST(PairFormRegistry, EveryVariantOfEveryFormHasDerivativeChecks) {
  std::set<FormVariant> reached;
  for (const PairCase& c : pair_cases()) record_variants(testing::pair_config(c.modifier, c.coulomb, c.epsilon_rf), reached);
  for (const SwitchCase& c : switch_cases()) record_variants(switch_config(c), reached);
  expect_every_variant_reached(reached, static_cast<PairFormConstants*>(nullptr));
}

// A Hessian–vector product handed the cut-off masks of a force pass at the same positions takes
// them; it must give exactly what the full pass gives, and take them only for the list they belong to.
TEST(NonbondedPairTerm, HessianReuseOfForcePassIsExact) {
  auto [system, q] = testing::water_like_system(200, Vec3(2.5, 2.5, 2.5), 9);
  const auto config = testing::pair_config("potential-switch", "reaction-field", 78.0);
  const Coords u = random_direction(system.n_atoms(), 4);
  NonbondedPairTerm fresh(system, config), reused(system, config);
  const Coords reference = hessian_vector(fresh, q, u);  // no force evaluation: full pass
  EXPECT_EQ(fresh.reused_masks(), 0);
  TermMasks masks;
  TermEvaluation keep;
  keep.keep_masks = &masks;
  evaluate(reused, q, keep);
  TermEvaluation with_masks;
  with_masks.masks = &masks;
  const Coords again = hessian_vector(reused, q, u, with_masks);
  EXPECT_EQ(reused.reused_masks(), 1);
  EXPECT_EQ((again - reference).cwiseAbs().maxCoeff(), 0.0);
  // Several stage positions in a row, then their products in reverse order (as an RK reverse pass).
  std::vector<Coords> stages;
  std::vector<TermMasks> stage_masks(5);
  for (int k = 0; k < 5; ++k) {
    stages.push_back(q + 1e-3 * k * u);
    keep.keep_masks = &stage_masks[k];
    evaluate(reused, stages.back(), keep);
  }
  for (int k = 4; k >= 0; --k) {
    with_masks.masks = &stage_masks[k];
    EXPECT_EQ((hessian_vector(reused, stages[k], u, with_masks) - hessian_vector(fresh, stages[k], u))
                  .cwiseAbs()
                  .maxCoeff(),
              0.0);
  }
  EXPECT_EQ(reused.reused_masks(), 6);
  // After the list has changed (moved far enough to prune again), masks of the old list are not taken.
  const Coords far = q + 0.2 * u / u.cwiseAbs().maxCoeff();
  with_masks.masks = &masks;
  const Coords at_far = hessian_vector(reused, far, u, with_masks);
  EXPECT_EQ(reused.reused_masks(), 6);
  EXPECT_EQ((at_far - hessian_vector(fresh, far, u)).cwiseAbs().maxCoeff(), 0.0);
}

}  // namespace
}  // namespace vimd
