// The force field as a whole and its registry: energy columns and their parts, forces as the sum
// of the terms', observations that change nothing, and the configurations it refuses.
#include <gtest/gtest.h>

#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "engine/errors.hpp"
#include "forcefields/registry.hpp"
#include "test_forces_common.hpp"

namespace vimd {
namespace {

using testing::hessian_vector;
using testing::random_direction;
using testing::relative_difference;

// A term of constant energies, for the field's bookkeeping of energy columns.
class ConstantEnergyTerm : public ForceTerm {
 public:
  ConstantEnergyTerm(std::vector<std::string> names, std::vector<std::string> part_of, std::vector<double> values)
      : names_(std::move(names)), part_of_(std::move(part_of)), values_(std::move(values)) {}
  std::vector<std::string> energy_names() const override { return names_; }
  std::vector<std::string> energy_part_of() const override { return part_of_; }
  void add_forces(const Coords&, Coords&, std::span<double> energies, const TermEvaluation&) override {
    for (std::size_t k = 0; k < energies.size(); ++k) energies[k] += values_[k];
  }
  void add_hessian_vector(const Coords&, const Coords&, Coords&, const TermEvaluation&) override {}
  void add_single_point(const Coords&, Coords&, std::span<double> energies) const override {
    for (std::size_t k = 0; k < energies.size(); ++k) energies[k] += values_[k];
  }

 private:
  std::vector<std::string> names_, part_of_;
  std::vector<double> values_;
};

// A column that is a part of another (the PME mesh's coulomb_recip of coulomb) is reported on its
// own, added to its total, and counted in the potential once.
TEST(ForceField, EnergyPartsAreAddedToTheirTotalAndCountedOnce) {
  ForceField field;
  field.add(std::make_unique<ConstantEnergyTerm>(std::vector<std::string>{"lj", "coulomb"}, std::vector<std::string>{},
                                                 std::vector<double>{1.0, -10.0}));
  field.add(std::make_unique<ConstantEnergyTerm>(std::vector<std::string>{"bonds", "coulomb_recip"},
                                                 std::vector<std::string>{"", "coulomb"}, std::vector<double>{5.0, 2.5}));
  EXPECT_EQ(field.energy_names(), (std::vector<std::string>{"lj", "coulomb", "bonds", "coulomb_recip"}));
  const Coords q = Coords::Zero(3, 2);
  Forces forces, single;
  field.compute(q, forces);
  field.single_point(q, single);
  for (const Forces* f : {&forces, &single}) {
    EXPECT_EQ(f->terms, (std::vector<double>{1.0, -7.5, 5.0, 2.5}));
    EXPECT_EQ(f->potential, 1.0 - 7.5 + 5.0);
  }
  ForceField wrong;
  EXPECT_THROW(wrong.add(std::make_unique<ConstantEnergyTerm>(std::vector<std::string>{"coulomb_recip"},
                                                              std::vector<std::string>{"coulomb"},
                                                              std::vector<double>{1.0})),
               std::logic_error);
}

// A NaN position gave an energy, plausible where only pair terms see the atom (the pair search
// leaves it out: SPC/E water under reaction field), with NaN forces. Now refused, naming the atom.
TEST(ForceField, SinglePointRefusesNonFinitePositionsNamingTheAtom) {
  auto [system, q] = testing::water_like_system(12, Vec3(2.0, 2.0, 2.0), 11);
  auto field = make_force_field(system, testing::pair_config("potential-shift", "reaction-field", 0.0));
  q(0, 3) = std::numeric_limits<double>::quiet_NaN();
  Forces forces;
  try {
    field->single_point(q, forces);
    FAIL() << "no exception; potential " << forces.potential;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("atom 4 is at (nan, "), std::string::npos) << e.what();
  }
}

TEST(ForceFieldRegistry, BuildsAllTermsWithTheirEnergyNames) {
  auto [system, q] = testing::water_like_system(12, Vec3(2.0, 2.0, 2.0), 11);
  auto field = make_force_field(system, testing::pair_config("potential-switch", "reaction-field", 78.0));
  EXPECT_EQ(field->energy_names(), (std::vector<std::string>{"lj", "coulomb", "bonds", "angles", "dihedrals",
                                                              "impropers", "lj14", "coulomb14"}));
  Forces forces;
  field->compute(q, forces);
  double sum = 0;
  for (double e : forces.terms) sum += e;
  EXPECT_DOUBLE_EQ(forces.potential, sum);
  for (int k = 0; k < 4; ++k) EXPECT_NE(forces.terms[k], 0.0);
  for (int k = 4; k < 8; ++k) EXPECT_EQ(forces.terms[k], 0.0);  // water has no dihedrals or 1-4 pairs
  // The whole field obeys the same derivative checks as its terms.
  Coords hu;
  const Coords u = random_direction(system.n_atoms(), 3);
  field->hessian_vector(q, u, hu);
  Coords expected = Coords::Zero(3, q.cols());
  for (const auto& term : field->terms()) expected += hessian_vector(*term, q, u);
  EXPECT_LT(relative_difference(hu, expected), 1e-14);
  EXPECT_EQ(field->work().neighbor_rebuilds, 1);
}

// The first term (the pair term) sets the forces instead of adding to zeros, so whatever the output
// held before must not show; the later terms add theirs, as onto zeros.
TEST(ForceField, ForcesAreTheTermsSumWhateverTheOutputHeld) {
  auto [system, q] = testing::water_like_system(100, Vec3(2.2, 2.2, 2.2), 17);
  auto field = make_force_field(system, testing::pair_config("potential-shift", "reaction-field", 0.0));
  ASSERT_TRUE(field->terms().front()->writes_forces());
  for (bool energies : {true, false}) {
    Forces forces;
    forces.f.setConstant(3, q.cols(), std::numeric_limits<double>::quiet_NaN());
    if (energies)
      field->compute(q, forces);
    else
      field->compute_forces(q, forces);
    Coords expected = Coords::Zero(3, q.cols());
    for (const auto& term : field->terms()) term->add_forces(q, expected, {});
    EXPECT_EQ((forces.f - expected).cwiseAbs().maxCoeff(), 0.0) << "energies " << energies;
  }
}

// An observation (single_point) is what a fresh field computes, and leaves the field as it was:
// the run's evaluations after it are bitwise those of a run never observed, whatever positions
// were observed (here ones that would have forced a new search and pruning).
TEST(ForceField, SinglePointChangesNothingTheRunComputes) {
  auto [system, q] = testing::water_like_system(200, Vec3(2.5, 2.5, 2.5), 13);
  const auto config = testing::pair_config("potential-switch", "reaction-field", 78.0);
  auto observed = make_force_field(system, config), plain = make_force_field(system, config),
       fresh = make_force_field(system, config);
  const Coords u = random_direction(system.n_atoms(), 5);
  const Coords elsewhere = q + 0.3 * u / u.cwiseAbs().maxCoeff();
  Forces at_elsewhere, reference;
  fresh->compute(elsewhere, reference);
  const ForceField& as_observer = *observed;
  as_observer.single_point(elsewhere, at_elsewhere);
  EXPECT_EQ(at_elsewhere.terms, reference.terms);
  EXPECT_EQ((at_elsewhere.f - reference.f).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(observed->work().neighbor_rebuilds, 0);
  EXPECT_EQ(observed->work().force_evaluations, 0);
  for (const Coords& at : {q, Coords(q + 1e-3 * u)}) {
    Forces a, b;
    observed->compute(at, a);
    as_observer.single_point(elsewhere, at_elsewhere);
    plain->compute(at, b);
    EXPECT_EQ(a.terms, b.terms);
    EXPECT_EQ((a.f - b.f).cwiseAbs().maxCoeff(), 0.0);
  }
  EXPECT_EQ(observed->work().neighbor_rebuilds, plain->work().neighbor_rebuilds);
  EXPECT_EQ(observed->work().neighbor_prunes, plain->work().neighbor_prunes);
}

TEST(ForceFieldRegistry, RejectsBadConfiguration) {
  auto [system, q] = testing::water_like_system(4, Vec3(2.0, 2.0, 2.0), 1);
  EXPECT_THROW(make_force_field(system, testing::pair_config("switch", "reaction-field")), InputError);
  EXPECT_THROW(make_force_field(system, testing::pair_config("potential-shift", "p3m")), InputError);
  EXPECT_THROW(make_force_field(system, testing::pair_config("potential-switch", "reaction-field", 0, 0.9, 1.0)),
               InputError);
  // The box must hold twice the cut-off.
  EXPECT_THROW(make_force_field(system, testing::pair_config("potential-shift", "reaction-field", 0, 1.1)), InputError);
}

}  // namespace
}  // namespace vimd
