#include "forcefields/registry.hpp"

#include "forcefields/ewald.hpp"
#include "forcefields/harmonic_angle.hpp"
#include "forcefields/harmonic_bond.hpp"
#include "forcefields/nonbonded_pair_term.hpp"

namespace vimd {

// Every term is always present (energies lj, coulomb, bonds, angles are always reported, 0 when
// a system has nothing for a term), so output columns do not depend on the system.
std::unique_ptr<ForceField> make_force_field(const System& system, const ForceFieldConfig& config) {
  auto field = std::make_unique<ForceField>();
  field->add(std::make_unique<NonbondedPairTerm>(system, config));
  field->add(std::make_unique<HarmonicBondTerm>(system.bonds, system.box));
  field->add(std::make_unique<HarmonicAngleTerm>(system.angles, system.box));
  if (config.coulomb == "pme") pme_grid_size(config, system.box);  // checks the grid; the mesh term is next
  return field;
}

}  // namespace vimd
