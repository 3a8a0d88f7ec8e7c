#pragma once
// The nonbonded pair term: one OpenMP pair loop over the pair lists (pair_lists.hpp), evaluating
// the pair forms registered in pair_forms.hpp with the SIMD kernels of the CPU's best target
// (nonbonded_kernels.hpp) for every listed pair inside the cut-off; reports energies
// {"lj", "coulomb"} (each form's PairEnergy).
//   V = Σ_{i<j, not excluded, r<rc} Σ_forms φ(r) + Σ_{excluded, r<rc} Σ_forms φ_excl(r) + Σ_forms V_self
//   (the forms with excluded-pair and self terms say so: pair_form.hpp)
//   Units: nm, kJ/mol, e. Forces kJ/mol/nm. Hessian–vector products kJ/mol/nm² × (units of u).
//
// Threads: each thread takes its home segment of chunks of i-halves, then tail segments as they
// come free (pair_loop_segments), each segment accumulating into its own force buffer; the buffers
// are summed per atom in segment order. No atomic sums, no races.
// Energies are summed from per-half partials in a fixed order, so they do not depend on the thread
// count at all; forces and HVPs differ by round-off only.
//
// A force pass evaluated with TermEvaluation::keep_masks records, per list entry, which pairs were
// inside the cut-off; a Hessian–vector product handed them (TermEvaluation::masks) takes them
// instead of finding those pairs by a mask pass of its own, with the same results (a
// single-precision product also takes a double-precision pass's masks).
#include <array>
#include <stdexcept>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include "forcefields/settings.hpp"
#include "engine/force_field.hpp"
#include "engine/system.hpp"
#include "forcefields/nonbonded/nonbonded_kernels.hpp"
#include "forcefields/nonbonded/pair_lists.hpp"

namespace vimd {

class NonbondedPairTerm : public ForceTerm {
 public:
  NonbondedPairTerm(const System& system, const ForceFieldConfig& config);

  std::vector<std::string> energy_names() const override { return {"lj", "coulomb"}; }
  void add_forces(const Coords& q, Coords& f, std::span<double> energies, const TermEvaluation& how = {}) override;
  bool writes_forces() const override { return true; }
  void add_hessian_vector(const Coords& q, const Coords& u, Coords& out, const TermEvaluation& how = {}) override;
  void add_single_point(const Coords& q, Coords& f, std::span<double> energies) const override;
  void start_step(const Coords& q, std::unique_ptr<TermStepState>& state) override;
  // Forces (mixed precision already has them) and Hessian–vector products from the single-precision kernels.
  bool has_single_precision() const override { return true; }
  void add_work(WorkCounters& counters) const override { run_.lists.add_work(counters); }
  void save(Carried& out) const override { run_.lists.save(out); }
  void restore(const Carried& in) override;

  const PairLists& lists() const { return run_.lists; }
  const NeighborList& neighbor_list() const { return run_.lists.searched(); }
  double skin() const { return run_.lists.skin(); }
  double search_skin() const { return run_.lists.search_skin(); }
  // Whether the pair list the kernels visit (`step`'s list, else the regular one) holds atoms a
  // and b, in any image. A linear scan, for tests.
  bool lists_pair(int a, int b, const TermStepState* step = nullptr) const;
  // Entries of the list the kernels visit (`step`'s list, else the regular one), for tests and reports.
  std::size_t visited_entries(const TermStepState* step = nullptr) const;
  // Hessian–vector products that took a force pass's masks.
  long reused_masks() const { return run_.reused_masks; }
  // The constants of a pair form (e.g. form<LjConstants>()).
  template <class Form>
  const Form& form() const {
    return std::get<Form>(forms_);
  }

 private:
  // A variational step's pair set.
  struct Step : TermStepState {
    StepList list;
    bool fixed = false;  // the fixed pair set: its pairs interact wherever they go
  };
  // The list one evaluation visits.
  struct Visit {
    PairListView list;
    bool fixed = false;
  };
  // Slot-ordered arrays in one precision: double always, float as well for mixed precision or
  // once single precision was asked for.
  template <class Real>
  struct SlotArrays {
    std::vector<Real> charge;
    std::vector<Real> lj;  // PairViewOf::lj
    std::vector<Real> x, y, z;  // positions, packed per evaluation
    std::vector<Real> ux, uy, uz;  // the direction of a Hessian–vector product, packed per product (empty until one)
    std::vector<std::vector<Real>> thread_buffers;  // per pair-loop segment: x, y, z blocks of n_slots
  };
  // Everything an evaluation changes: the run's (run_), or a single point's own.
  struct Workspace {
    Workspace(PairLists fresh, bool single) : lists(std::move(fresh)), single_kept(single) {}
    PairLists lists;
    bool single_kept;  // the single-precision slot arrays are kept up to date
    long layout_build = -1;  // list search the slot arrays below belong to
    std::vector<int> slot_type;
    SlotArrays<double> slots;
    SlotArrays<float> single_slots;
    std::vector<double> partial_energies;  // per i-half and per excluded-pair block
    std::vector<std::uint32_t> list_masks;
    long reused_masks = 0;
    template <class Real>
    SlotArrays<Real>& slot_arrays() {
      if constexpr (std::is_same_v<Real, float>)
        return single_slots;
      else
        return slots;
    }
  };

  Workspace fresh_workspace() const { return Workspace{fresh_lists_, mixed_}; }
  // The step state as this term's (null for none); State: TermStepState, const or not.
  template <class State>
  static auto* step_of(State* state) {
    using Own = std::conditional_t<std::is_const_v<State>, const Step, Step>;
    if (!state) return static_cast<Own*>(nullptr);
    auto* step = dynamic_cast<Own*>(state);
    if (!step) throw std::logic_error("NonbondedPairTerm: a step state of another term");
    return step;
  }
  // Keeps w's lists (`step`'s, else the regular one) valid at q and the slot arrays in their layout.
  void keep_lists(Workspace& w, const Coords& q, Step* step) const;
  static Visit visit(const Workspace& w, const Step* step);
  void keep_single_precision(Workspace& w) const;
  void refresh_layout(Workspace& w) const;  // slot-ordered charges and types after a search
  void refresh_single_precision_layout(Workspace& w) const;  // their single-precision copies
  // write: set f to the forces (else add them).
  void forces(Workspace& w, const Visit& visit, const Coords& q, Coords& f, std::span<double> energies, bool single,
              TermMasks* keep, bool write) const;
  template <class Real>
  PairViewOf<Real> pair_view(Workspace& w, const Visit& visit) const;
  template <class Real, class Kernel>
  void add_pair_forces(Workspace& w, const Visit& visit, Kernel pair_kernel, const Coords& q, Coords& f,
                       std::span<double> energies, TermMasks* keep, bool write) const;
  template <class Real, class Kernel>
  void add_pair_hessian_vector(Workspace& w, const Visit& visit, Kernel pair_kernel, const Coords& q, const Coords& u,
                               Coords& out, const TermMasks* masks) const;
  // pack(), then halves(h0, h1, x, y, z) for the list's segments (pair_loop_segments), each into a
  // buffer of its own, and blocks(t, nt, x, y, z) for thread t's excluded-pair blocks into its
  // home segment's; then out += the buffers' sums in segment order (out = them: write).
  template <class Real, class Pack, class Halves, class Blocks>
  void run_parallel(Workspace& w, std::span<const int> visited_half_start, std::vector<std::vector<Real>>& buffers,
                    Pack&& pack, Halves&& halves, Blocks&& blocks, Coords& out, bool write = false) const;
  void check_atoms(const Coords& q) const;

  int n_atoms_;
  bool mixed_;  // precision = "mixed": forces from the single-precision kernel
  PairFormConstants forms_;
  bool excluded_pairs_ = false;  // some form has an excluded-pair term
  double cutoff2_;
  std::array<double, kPairEnergies> self_energy_{};  // per PairEnergy
  int n_types_;
  std::vector<double> c6_, c12_;  // [ti * n_types + tj]
  std::vector<unsigned char> type_has_lj_;  // per type: some c6 or c12 of its row is not zero
  Eigen::VectorXd charge_;
  std::vector<int> type_;
  // The force is continuous at the cut-off (C^1 or smoother): the step equations are smooth
  // enough for the solve without fixing the pair set, which then stays the true truncated one.
  bool force_continuous_at_cutoff_ = false;
  PairLists fresh_lists_;  // never searched: a single point's lists start as a copy
  Workspace run_;
};

// Where the box leaves no room for a buffer the run file sets (cutoff + skin up to half the box),
// the pair lists use what it allows, as GROMACS shrinks its pair-list buffer; one warning per buffer
// so cut, naming the structure and the run file, for the caller to show with the input's warnings.
std::vector<std::string> pair_list_warnings(const RunConfig& config, const Box& box);

}  // namespace vimd
