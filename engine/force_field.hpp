#pragma once
// The potential as a sum of terms. Forces are functions of positions only (RK stages are not
// States). Every term provides energy, forces and a Hessian–vector product.
//
// How to evaluate travels with each evaluation (Evaluation): the precision, the variational
// step's pair set, and the masks a force pass leaves for Hessian–vector products at the same
// positions. The field itself has no modes to switch.
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "engine/carried.hpp"
#include "engine/types.hpp"

namespace vimd {

// Work counters, for cost reports (force-evaluation equivalents). Adding a counter is one line in
// fields(): sums, differences, checkpoints and summary.json follow it.
struct WorkCounters {
  long force_evaluations = 0;
  long hessian_evaluations = 0;
  // Of those, the ones some term computed in single precision (Evaluation::single_precision).
  long single_precision_force_evaluations = 0;
  long single_precision_hessian_evaluations = 0;
  long neighbor_rebuilds = 0;  // pair searches
  long neighbor_prunes = 0;    // prunings of pair lists, step lists included
  double neighbor_build_seconds = 0;  // wall time of those searches and prunings
  double mesh_seconds = 0;            // wall time of PME's mesh (forces and Hessian–vector products)

  // f(name, pointer to member) for every counter, in report order.
  template <class F>
  static void fields(F&& f) {
    f("force_evaluations", &WorkCounters::force_evaluations);
    f("hessian_evaluations", &WorkCounters::hessian_evaluations);
    f("single_precision_force_evaluations", &WorkCounters::single_precision_force_evaluations);
    f("single_precision_hessian_evaluations", &WorkCounters::single_precision_hessian_evaluations);
    f("neighbor_rebuilds", &WorkCounters::neighbor_rebuilds);
    f("neighbor_prunes", &WorkCounters::neighbor_prunes);
    f("neighbor_build_seconds", &WorkCounters::neighbor_build_seconds);
    f("mesh_seconds", &WorkCounters::mesh_seconds);
  }
  WorkCounters& operator+=(const WorkCounters& b) {
    fields([&](const char*, auto m) { this->*m += b.*m; });
    return *this;
  }
  WorkCounters& operator-=(const WorkCounters& b) {
    fields([&](const char*, auto m) { this->*m -= b.*m; });
    return *this;
  }
  friend WorkCounters operator+(WorkCounters a, const WorkCounters& b) { return a += b; }
  friend WorkCounters operator-(WorkCounters a, const WorkCounters& b) { return a -= b; }
};

// A term's state for one variational step (its pair set), kept by StepPairSet.
struct TermStepState {
  virtual ~TermStepState() = default;
};

// What a term's force pass leaves for a Hessian–vector product at the same positions: its pair
// list's inside-cut-off masks, and which list and precision they belong to.
struct TermMasks {
  long list_id = -1;  // none
  bool single_precision = false;
  std::vector<std::uint32_t> bits;  // per list entry
};

// The masks of a whole force pass (ForceField::compute with Evaluation::keep_masks), per term.
// Opaque to callers: they hand it back to ForceField::hessian_vector at the same positions.
class ForceMasks {
 private:
  friend class ForceField;
  std::vector<TermMasks> terms_;
};

// One variational step's pair set: ForceField::start_step(q) sets it up at the step's start q̂,
// and every evaluation of the step passes it (Evaluation::step). The integrator owns it and reuses
// it from step to step (a term may learn from the last step how far evaluations reach).
class StepPairSet {
 private:
  friend class ForceField;
  std::vector<std::unique_ptr<TermStepState>> terms_;  // per term; null for terms without a pair set
};

struct Forces {
  Coords f;                   // kJ/mol/nm
  double potential = 0;       // kJ/mol
  std::vector<double> terms;  // kJ/mol, aligned with ForceField::energy_names()
  ForceMasks masks;           // with Evaluation::keep_masks
};

// How to evaluate, given with each evaluation.
struct Evaluation {
  // Single-precision pair arithmetic where a term has it (ForceTerm::has_single_precision): for
  // the parts of a solve whose rounding the solve absorbs (VariationalSettings::mixed_precision_solve).
  bool single_precision = false;
  // The variational step whose evaluation this is (ForceField::start_step), or none.
  StepPairSet* step = nullptr;
  // compute/compute_forces: leave the inside-cut-off masks in Forces::masks.
  bool keep_masks = false;
  // hessian_vector: the masks of a force pass at exactly these positions (saves finding them).
  const ForceMasks* masks = nullptr;
};

// The same, as one term sees it.
struct TermEvaluation {
  bool single_precision = false;
  TermStepState* step = nullptr;
  TermMasks* keep_masks = nullptr;
  const TermMasks* masks = nullptr;
  // f is sized but holds nothing yet: a term whose writes_forces() is true sets every atom's force
  // instead of adding to it, which spares the evaluation a pass that zeroes f.
  bool forces_unset = false;
};

class ForceTerm {
 public:
  virtual ~ForceTerm() = default;
  // Names of the energies this term reports, e.g. {"lj", "coulomb"} for the nonbonded pair term.
  virtual std::vector<std::string> energy_names() const = 0;
  // For each of energy_names(), the column of an earlier term that also counts it, or "" (most):
  // the PME mesh's "coulomb_recip" is a part of "coulomb", as GROMACS's Coul. recip. is of the
  // Coulomb energy. A part is reported on its own and enters the potential only through its total.
  virtual std::vector<std::string> energy_part_of() const { return {}; }
  // Adds −∇V to f and the energies to energies[0..energy_names().size()); an empty `energies`
  // asks for the forces only (a term may then skip the energy work). A term with neighbour lists
  // keeps them valid for q here.
  virtual void add_forces(const Coords& q, Coords& f, std::span<double> energies,
                          const TermEvaluation& how = {}) = 0;
  // Whether add_forces honours TermEvaluation::forces_unset.
  virtual bool writes_forces() const { return false; }
  // Adds ∇²V(q) u to out.
  virtual void add_hessian_vector(const Coords& q, const Coords& u, Coords& out, const TermEvaluation& how = {}) = 0;
  // add_forces as a fresh term would compute them at q, changing nothing of this term: an
  // observation, which must not alter what later evaluations compute.
  virtual void add_single_point(const Coords& q, Coords& f, std::span<double> energies) const = 0;
  // Where the force jumps at the cut-off: the pairs inside it at q, from here on fixed for every
  // evaluation that passes the state (each pair potential continued smoothly past the cut-off), and
  // no others, so a crossing cannot make the force jump between them. Where the force is
  // continuous there, the potential stays the truncated one, smooth enough and exact (see
  // ForceField::start_step). Either way the evaluations are one step's, near q: a term may visit a
  // list cut to them (NonbondedPairTerm's step list), with the same results. `state` holds the
  // last step's (null at first) and is replaced; terms without pairs leave it null.
  virtual void start_step(const Coords& /*q*/, std::unique_ptr<TermStepState>& /*state*/) {}
  // Whether the term has single-precision kernels (Evaluation::single_precision).
  virtual bool has_single_precision() const { return false; }
  // Adds this term's searches, prunings and their wall time.
  virtual void add_work(WorkCounters& /*counters*/) const {}
  // Checkpoints: what changes results at round-off besides q (the neighbour list's build
  // positions: the list's order is the summation order), and rebuilding from it.
  virtual void save(Carried& /*out*/) const {}
  virtual void restore(const Carried& /*in*/) {}
};

// Atoms whose positions are functions of the others' (virtual sites, System::virtual_sites). The
// field evaluates its terms with the sites placed, then moves the sites' forces onto the atoms they
// are built from: to integrators, V is a function of the real atoms alone, with zero force and
// Hessian rows on the sites. All functions take q with the sites placed (place).
class SiteConstruction {
 public:
  virtual ~SiteConstruction() = default;
  // q's site columns from the other columns.
  virtual void place(Coords& q) const = 0;
  // u's site columns ← J u, the sites' motion when the atoms move along u.
  virtual void tangent(const Coords& q, Coords& u) const = 0;
  // Adds the forces on the sites to the atoms they are built from (f ← Jᵀ f) and zeroes them.
  virtual void spread(const Coords& q, Coords& f) const = 0;
  // hv ← Jᵀ hv + Σ_sites (∂²x_site/∂x² u) · (−F_site), for the Hessian of V(x(q)) from the terms'
  // Hessian–vector product hv at the sites' tangent u (see tangent). F_site: the sites' forces as the
  // terms give them (site_forces, unspread); only where the construction is not linear (linear()).
  virtual void spread_hessian(const Coords& q, const Coords& u, const Coords* site_forces, Coords& hv) const = 0;
  // Whether every construction is linear in the atoms (no second-derivative term).
  virtual bool linear() const = 0;
};

// The first atom (column) of q with a NaN or infinite coordinate, or -1. There is no energy at such
// a q, and the pair search would leave the atom out unnoticed: the sum would look plausible.
int first_non_finite(const Coords& q);
// "(nan, 1.378, 0.114)": atom i's position as an error message shows it.
std::string position_text(const Coords& q, int i);

class ForceField {
 public:
  void add(std::unique_ptr<ForceTerm> term);
  const std::vector<std::string>& energy_names() const { return names_; }

  void compute(const Coords& q, Forces& out, const Evaluation& how = {});
  // The forces alone (the pair kernels skip the energy sums): out.potential and out.terms are NaN,
  // so that a use of energies nobody computed shows.
  void compute_forces(const Coords& q, Forces& out, const Evaluation& how = {});
  // out = ∇²V(q) u
  void hessian_vector(const Coords& q, const Coords& u, Coords& out, const Evaluation& how = {});
  // Energies and forces at q as a freshly made field would compute them (pair lists built at q):
  // an observation. Const: nothing the field keeps for later evaluations changes, so observing a
  // state cannot change a trajectory. Not counted as work. std::invalid_argument naming the first
  // atom whose position is not finite (first_non_finite): checked here, once per observation,
  // rather than in the runs' evaluations, whose steps check_sane checks.
  void single_point(const Coords& q, Forces& out) const;

  // Sets `pairs` up for a variational step starting at q. The evaluations that pass it (Evaluation::step)
  // see, from every term whose force jumps at the cut-off, V_q(x) = Σ over the pairs inside the
  // cut-off at q of the pair potentials, each continued analytically beyond the cut-off: a smooth
  // function of x, which the variational integrator uses as one step's potential so that its step
  // equations are smooth. A term whose force is continuous at the cut-off keeps its true truncated
  // potential: the solve converges on it, and the continuation would cost energy conservation.
  void start_step(StepPairSet& pairs, const Coords& q);
  bool has_single_precision() const;

  WorkCounters work() const;
  // Every term's save()/restore(), entries prefixed with the term's index.
  Carried save() const;
  void restore(const Carried& in);

  const std::vector<std::unique_ptr<ForceTerm>>& terms() const { return terms_; }

  // The system's virtual sites, if it has any: every evaluation places them first.
  void set_sites(std::unique_ptr<SiteConstruction> sites) { sites_ = std::move(sites); }
  // Writes the sites' positions into q and their velocities J·v into v (when v has q's shape), as
  // GROMACS keeps them for output; nothing without sites.
  void place_sites(Coords& q, Coords& v) const;

 private:
  // q with the sites placed (q itself without sites).
  const Coords& with_sites(const Coords& q);
  void evaluate(const Coords& q, Forces& out, bool energies, const Evaluation& how);
  // Adds each part column to its total, then sums the potential over the other columns.
  void total_energies(Forces& out) const;
  TermEvaluation for_term(std::size_t k, const Evaluation& how, ForceMasks* keep) const;

  std::vector<std::unique_ptr<ForceTerm>> terms_;
  std::vector<std::string> names_;
  std::vector<std::size_t> name_counts_;  // per term
  struct EnergyPart {
    std::size_t part, total;  // columns
  };
  std::vector<EnergyPart> parts_;
  std::vector<bool> is_part_;  // per column
  std::unique_ptr<SiteConstruction> sites_;
  Coords placed_, tangent_, site_forces_;  // scratch for the sites
  WorkCounters evaluations_;  // the evaluation counts; the terms add theirs in work()
};

}  // namespace vimd
