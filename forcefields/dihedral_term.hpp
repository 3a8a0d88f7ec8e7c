#pragma once
// Dihedrals, energies "dihedrals" and "impropers":
//   dihedrals: the proper kinds, GROMACS's Proper Dih. (types 1, 9: periodic_dihedral.hpp) plus
//              Ryckaert-Bell. (type 3) and Fourier Dih. (type 5) (ryckaert_bellemans.hpp);
//   impropers: GROMACS's Improper Dih. (type 2: harmonic_improper.hpp) plus Per. Imp. Dih.
//              (type 4: periodic_dihedral.hpp).
// The angle and its derivatives: dihedral_angle.hpp. Where the torsion is undefined (three atoms on
// a line) the energy is V(φ) at the φ atan2 gives and the force is zero, as in GROMACS.
#include <vector>

#include "engine/box.hpp"
#include "engine/system.hpp"
#include "forcefields/bonded_term.hpp"

namespace vimd {

class DihedralTerm : public BondedTerm {
 public:
  explicit DihedralTerm(const System& system);

  std::vector<std::string> energy_names() const override { return {"dihedrals", "impropers"}; }

 private:
  std::vector<PeriodicDihedral> proper_, periodic_impropers_;
  std::vector<RyckaertBellemansDihedral> ryckaert_bellemans_;
  std::vector<HarmonicImproper> harmonic_impropers_;
  Box box_;

  void add_forces_with(BondedLoop& loop, const Coords& q, Coords& f, std::span<double> energies) const override;
  void add_hessian_vector_with(BondedLoop& loop, const Coords& q, const Coords& u, Coords& out) const override;
};

}  // namespace vimd
