#pragma once
// Reaction-field Coulomb as in the GROMACS Verlet scheme, V = 0 for r ≥ rc:
//   V(r) = f qi qj/eps_r (1/r + k_rf r² − c_rf); excluded pairs (r < rc): f qi qj/eps_r (k_rf r² − c_rf); self: −½ f
//   qi² c_rf/eps_r Units: q e, r nm, f = 138.935458 kJ/mol nm e⁻², V kJ/mol; k_rf = (eps_rf − eps_r)/((2 eps_rf +
//   eps_r) rc³), c_rf = 1/rc + k_rf rc².
//
// GROMACS's "plain cut-off" Coulomb in the Verlet scheme is this same kernel with k_rf = 0 and
// c_rf = 1/rc (forcerec.cpp init_interaction_const: "For plain cut-off we might use the
// reaction-field kernels", eps_rf = eps_r; the nbnxm kernels then apply the excluded-pair and
// self terms as for reaction field). epsilon_rf = 0 means eps_rf = ∞: k_rf = 1/(2 rc³).
// The excluded-pair and self terms are what GROMACS's nbnxm kernels add (kernel_ref_inner.h:
// excluded pairs inside the cut-off keep qq (k_rf r² − c_rf); kernel_ref_outer.h: −½ qi² c_rf per atom).
//
// The pair kernels (reaction_field-inl.h) use the same convention as lennard_jones.hpp:
// g = −φ'/r, a = φ'/r, b = (φ'' − φ'/r)/r²; qq already includes f/eps_r.
#include <string>


namespace vimd {

enum class CoulombKind { none, reaction_field };

struct ReactionField {
  CoulombKind kind = CoulombKind::none;
  double prefactor = 0;  // f / eps_r, kJ/mol nm e⁻²
  double k_rf = 0;       // nm⁻³
  double c_rf = 0;       // nm⁻¹
};

// coulomb: "reaction-field" | "cutoff" | "none"; throws InputError for anything else or bad epsilons.
ReactionField make_reaction_field(const std::string& coulomb, double epsilon_r, double epsilon_rf, double cutoff);

// Excluded pair inside the cut-off: φ = qq (k_rf r² − c_rf), a pure quadratic (b = 0).
inline void rf_excluded_energy_force(const ReactionField& rf, double qq, double r2, double& v, double& g) {
  v = qq * (rf.k_rf * r2 - rf.c_rf);
  g = -2 * qq * rf.k_rf;
}

inline double rf_excluded_hessian(const ReactionField& rf, double qq) { return 2 * qq * rf.k_rf; }

// −½ (f/eps_r) c_rf Σ qi²: a constant energy, no force.
inline double rf_self_energy(const ReactionField& rf, double sum_q2) { return -0.5 * rf.prefactor * rf.c_rf * sum_q2; }

}  // namespace vimd
