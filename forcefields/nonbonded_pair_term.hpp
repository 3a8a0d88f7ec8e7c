#pragma once
// The nonbonded pair term: one OpenMP pair loop over the cluster-pair Verlet list, evaluating the
// Lennard-Jones kernel (lennard_jones.hpp) and the reaction-field Coulomb kernel (reaction_field.hpp)
// with the SIMD kernels of the CPU's best target (nonbonded_kernels.hpp) for every listed pair inside the cut-off; reports energies {"lj", "coulomb"}.
//   V = Σ_{i<j, not excluded, r<rc} [V_LJ(r) + V_RF(r)] + Σ_{excluded, r<rc} V_RF,excl(r) + Σ_i V_RF,self
//   (V_RF and V_RF,excl times the switch S(r − coulomb_switch) with coulomb_modifier = potential-switch)
//   Units: nm, kJ/mol, e. Forces kJ/mol/nm. Hessian–vector products kJ/mol/nm² × (units of u).
//
// Two lists, as GROMACS's dynamic pruning: the searched list holds every cluster pair within
// cut-off + search skin; the kernels run over a pruned copy, its pairs within cut-off + skin,
// redone by one cheap SIMD pass whenever an atom has moved skin/2 since the last pruning. The
// search is redone only when an atom has moved (search skin − skin)/2 since it ran, so the pruned
// range, hence every pair inside the cut-off, is always covered: exact, like a single list.
//
// A third, for one variational step (fix_pair_set): its dozen evaluations stay within ~h·|v|max
// of the step's start q̂, so a list pruned at q̂ to cut-off + step skin, a few hundredths of a nm,
// serves them all. With skin 0.1 nm only ~43 % of the single-precision kernels' lanes were pairs
// inside the cut-off (water900). The step skin is twice the largest displacement from q̂ of the
// last step's evaluations, with a margin; an evaluation beyond half of it prunes again there, so
// the list stays exact. Where the force jumps at the cut-off, the step list is the fixed pair set.
// The dropped pairs would have added exact zeros: results are bitwise those of the wider list.
//
// Threads: each thread takes every nt-th chunk of i-half-clusters and accumulates into its own
// force buffer; the buffers are summed per atom in thread order.
// No atomics, no races. Energies are summed from per-half partials in a fixed order, so they do
// not depend on the thread count at all; forces and HVPs differ by round-off only.
#include <string>
#include <type_traits>
#include <vector>

#include "engine/config.hpp"
#include "engine/force_field.hpp"
#include "engine/neighbor_list.hpp"
#include "engine/system.hpp"
#include "forcefields/nonbonded_kernels.hpp"

namespace vimd {

class NonbondedPairTerm : public ForceTerm {
 public:
  NonbondedPairTerm(const System& system, const ForceFieldConfig& config);

  std::vector<std::string> energy_names() const override { return {"lj", "coulomb"}; }
  void add_forces(const Coords& q, Coords& f, std::span<double> energies) override;
  void add_hessian_vector(const Coords& q, const Coords& u, Coords& out) override;
  void prepare(const Coords& q) override;
  void fix_pair_set(const Coords* q) override;
  // Forces (mixed precision already has them) and Hessian–vector products from the single-precision kernels.
  bool has_single_precision() const override { return true; }
  void set_single_precision(bool on) override;
  long rebuilds() const override { return list_.builds(); }
  // Prunings of the regular list and of step lists.
  long prunes() const override { return prunes_ + step_prunes_; }
  // Searches and prunings.
  double rebuild_seconds() const override { return list_.build_seconds() + prune_seconds_; }
  void save(Carried& out) const override;
  void restore(const Carried& in) override;

  const NeighborList& neighbor_list() const { return list_; }
  // Buffers of the pruned and the searched list (equal: no pruning), nm.
  double skin() const { return skin_; }
  double search_skin() const { return list_.skin(); }
  // Whether the pair list the kernels visit (the step list inside a step, else the pruned list, if
  // pruning) holds atoms a and b, in any image. A linear scan, for tests.
  bool lists_pair(int a, int b) const;
  // Entries of the list the kernels visit now (the step list inside a step), for tests and reports.
  std::size_t visited_entries() const { return entries().size(); }
  // Hessian–vector products that reused the cut-off masks of an earlier force evaluation.
  long hessian_cache_hits() const { return hessian_cache_hits_; }

  // Reuse between the force and the Hessian–vector pass (no API needed): once a Hessian–vector
  // product has been asked for, every add_forces keeps, per list entry, which pairs were inside
  // the cut-off, for the last kHessianCacheSlots distinct positions (before that, force-only runs
  // pay nothing). add_hessian_vector at bitwise the same positions (and the same list) takes them
  // instead of finding the pairs inside the cut-off by a mask pass of its own first; the results
  // are the same (a single-precision product also takes a double-precision pass's masks). An
  // integrator's reverse pass gets this by evaluating forces at its stage positions first, as the
  // Runge–Kutta forward pass does. Costs ~1 MB per slot for 12k atoms.
  static constexpr std::size_t kHessianCacheSlots = 16;
  VdwModifier vdw_modifier() const { return modifier_; }
  const LjConstants& lj_constants() const { return lj_; }
  const ReactionField& reaction_field() const { return rf_; }

 private:
  struct InsideMasks {
    long list_version = -1;
    bool single = false;  // recorded by a single-precision force pass (valid for those HVPs only)
    Coords q;
    std::vector<std::uint32_t> masks;  // per list entry
    long last_used = 0;
  };
  std::vector<std::uint32_t>& record_inside_masks(const Coords& q, bool single);
  const std::uint32_t* find_inside_masks(const Coords& q, bool single);
  static bool same_positions(const Coords& a, const Coords& b);
  void refresh_layout();  // slot-ordered charges and types after a list rebuild
  void refresh_single_precision_layout();  // their single-precision copies
  bool pruning() const { return list_.skin() > skin_; }
  // moved_since_search: the largest displacement from the search's positions to q.
  void prune(const Coords& q, double moved_since_search);
  // The list evaluations outside a step use: the pruned one, or the searched one without pruning.
  // Its buffer is skin_ either way.
  const std::vector<NeighborList::Entry>& regular_entries() const {
    return pruning() ? pruned_entries_ : list_.entries();
  }
  const std::vector<int>& regular_half_start() const { return pruning() ? pruned_half_start_ : list_.half_start(); }
  // The list the kernels run over: the step list inside a step, else the regular one.
  const std::vector<NeighborList::Entry>& entries() const { return step_list_ ? step_entries_ : regular_entries(); }
  const std::vector<int>& half_start() const { return step_list_ ? step_half_start_ : regular_half_start(); }
  // Searches or prunes the regular list unless every atom is within `allowed` of where it was
  // pruned (searched, without pruning), so that it holds every pair within
  // cut-off + skin − 2·allowed at q.
  void keep_regular_list(const Coords& q, double allowed);
  // The entries of `from` with a listed pair closer than `range` at q, their masks narrowed to
  // those pairs, into `to` in half order. Entries whose `nearest` is at least skip_from are dropped
  // unseen. single: compare single-precision distances (the range is widened by their rounding).
  void narrow(const std::vector<NeighborList::Entry>& from, const std::vector<int>& from_start, const Coords& q,
              double range, double skip_from, bool single, std::vector<NeighborList::Entry>& to,
              std::vector<int>& to_start);
  // The step list at q with buffer `skin` (0: the pairs inside the cut-off).
  void prune_step_list(const Coords& q, double skin);
  double step_skin_after(double reach) const;
  // Changes whenever entries() does (masks and caches refer to its entry numbers).
  long list_version() const { return list_.builds() + prunes_ + step_prunes_ + step_scopes_; }
  // Slot-ordered arrays in one precision: double always, float as well for mixed precision or
  // once single precision was asked for.
  template <class Real>
  struct SlotArrays {
    std::vector<Real> charge;
    std::vector<Real> c6, c12;  // [type_i * n_slots + slot_j]
    std::vector<Real> x, y, z;  // positions, packed per evaluation
    std::vector<Real> ux, uy, uz;  // the direction of a Hessian–vector product, packed per product
    std::vector<std::vector<Real>> thread_buffers;  // per thread: x, y, z blocks of n_slots
  };
  template <class Real>
  const SlotArrays<Real>& slot_arrays() const {
    if constexpr (std::is_same_v<Real, float>)
      return mixed_slots_;
    else
      return slots_;
  }
  template <class Real>
  PairViewOf<Real> pair_view() const;
  template <class Real, class Kernel>
  void add_pair_forces(SlotArrays<Real>& slots, Kernel pair_kernel, const Coords& q, Coords& f,
                       std::span<double> energies);
  template <class Real, class Kernel>
  void add_pair_hessian_vector(SlotArrays<Real>& slots, Kernel pair_kernel, const Coords& q, const Coords& u,
                               Coords& out);
  template <class Real, class Pack, class Kernel>
  void run_parallel(std::vector<std::vector<Real>>& buffers, Pack&& pack, Kernel&& kernel, Coords& out);

  int n_atoms_;
  bool mixed_;  // precision = "mixed": forces from the single-precision kernel
  bool single_precision_ = false;       // set_single_precision: forces and HVPs in single precision now
  bool single_precision_asked_ = false;  // ever: the single-precision slot arrays are kept up to date
  VdwModifier modifier_;
  LjConstants lj_;
  ReactionField rf_;
  bool shared_switch_;  // LJ and Coulomb switched by the same S: the kernels switch their sum once
  double cutoff2_;
  double self_energy_ = 0;
  int n_types_;
  std::vector<double> c6_, c12_;  // [ti * n_types + tj]
  std::vector<unsigned char> type_has_lj_;  // per type: some c6 or c12 of its row is not zero
  Eigen::VectorXd charge_;
  std::vector<int> type_;

  double skin_;
  NeighborList list_;
  std::vector<NeighborList::Entry> pruned_entries_;
  std::vector<int> pruned_half_start_;
  std::vector<std::uint32_t> prune_masks_;  // per entry of the list being narrowed
  Coords pruned_at_;
  long prunes_ = 0;
  double prune_seconds_ = 0;
  long layout_build_ = -1;  // list build the slot arrays below belong to
  std::vector<int> slot_type_;
  SlotArrays<double> slots_;
  SlotArrays<float> mixed_slots_;
  std::vector<double> partial_energies_;             // per i-half and per excluded-pair block
  std::vector<InsideMasks> inside_cache_;
  std::vector<std::uint32_t> list_masks_;
  long cache_clock_ = 0, hessian_cache_hits_ = 0;
  bool hessian_requested_ = false;
  // The force is continuous at the cut-off (C^1 or smoother): the step equations are smooth
  // enough for the solve without fixing the pair set, which then stays the true truncated one.
  bool force_continuous_at_cutoff_ = false;
  bool pair_set_fixed_ = false;
  // The step list (see the top of this file), in use from fix_pair_set(q) to fix_pair_set(nullptr).
  bool step_list_ = false;
  std::vector<NeighborList::Entry> step_entries_;
  std::vector<int> step_half_start_;
  Coords step_at_;
  double step_skin_ = 0;   // nm; 0 with a fixed pair set, whose masks alone decide
  double step_reach_ = 0;  // largest displacement from the step's start of its evaluations so far
  double last_reach_ = -1;  // the same for the last step (< 0: no step yet)
  long step_prunes_ = 0, step_scopes_ = 0;
};

}  // namespace vimd
