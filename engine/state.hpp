#pragma once
// The dynamical state: plain copyable data. Forces and energies are those at q, kept so that
// output and the next step need not recompute them.
#include <vector>

#include "engine/types.hpp"

namespace vimd {

struct State {
  Coords q;  // nm
  Coords v;  // nm/ps
  Coords f;  // kJ/mol/nm, at q
  double potential = 0;              // kJ/mol, at q
  std::vector<double> energy_terms;  // kJ/mol, one per ForceField::energy_names()
  double time = 0;                   // ps
  long step = 0;
};

}  // namespace vimd
