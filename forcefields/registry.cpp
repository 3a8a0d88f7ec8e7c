#include "forcefields/registry.hpp"

#include "forcefields/dihedral_term.hpp"
#include "forcefields/nonbonded/ewald.hpp"
#include "forcefields/ewald_mesh.hpp"
#include "forcefields/harmonic_angle.hpp"
#include "forcefields/harmonic_bond.hpp"
#include "forcefields/nonbonded/nonbonded_pair_term.hpp"
#include "forcefields/pairs_14.hpp"
#include "forcefields/virtual_sites.hpp"

namespace vimd {

// Every term is always present (energies lj, coulomb, bonds, angles, dihedrals, impropers, lj14,
// coulomb14 are always reported, 0 when a system has nothing for a term), so output columns do not
// depend on the system; PME's mesh (coulomb_recip, a part of coulomb) comes with coulomb = "pme".
std::unique_ptr<ForceField> make_force_field(const System& system, const ForceFieldConfig& config) {
  auto field = std::make_unique<ForceField>();
  field->add(std::make_unique<NonbondedPairTerm>(system, config));
  field->add(std::make_unique<HarmonicBondTerm>(system.bonds, system.box));
  field->add(std::make_unique<HarmonicAngleTerm>(system.angles, system.box));
  field->add(std::make_unique<DihedralTerm>(system));
  field->add(std::make_unique<Pair14Term>(system.pairs14, system.box, config));
  if (config.coulomb == "pme") {
    const EwaldRealSpace real_space = EwaldRealSpace::from_config(config);
    field->add(std::make_unique<EwaldMeshTerm>(
        system, EwaldMeshParameters{pme_grid_size(config, system.box), config.pme_order, real_space.beta, real_space.prefactor},
        config.precision == "mixed"));
  }
  if (!system.virtual_sites.empty())
    field->set_sites(std::make_unique<VirtualSiteConstruction>(system.virtual_sites, system.box));
  return field;
}

}  // namespace vimd
