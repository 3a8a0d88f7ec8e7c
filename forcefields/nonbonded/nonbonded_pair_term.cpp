#include "forcefields/nonbonded/nonbonded_pair_term.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "forcefields/nonbonded/pair_forms-inl.h"

namespace vimd {

namespace {

// The scalar excluded-pair Hessian terms, from the build's static SIMD target.
using HWY_NAMESPACE::excluded_hessian;

template <class Form>
constexpr bool kHasSelfEnergy = requires(const Form& form) { form.self_energy(1.0); };

// f(constants) for every form present whose excluded pairs interact.
template <class F>
void for_each_excluded_pair_form(const PairFormConstants& forms, F&& f) {
  for_each_present_form(forms, [&](const auto& form) {
    if constexpr (kHasExcludedPairs<std::remove_cvref_t<decltype(form)>>) f(form);
  });
}

// A form's terms of the excluded pairs [p0, p1) for Hessian–vector products (reaction field: GROMACS
// keeps k_rf r² − c_rf for them), in double precision from the view's positions, added to buffers
// of the view's precision.
template <class Form, class Real>
void excluded_pair_hessian(const Form& form, const PairViewOf<Real>& d, const NeighborList::ExcludedPair* excluded,
                           double cutoff2, const Real* ux, const Real* uy, const Real* uz, int p0, int p1, Real* ox,
                           Real* oy, Real* oz) {
  for (int p = p0; p < p1; ++p) {
    const NeighborList::ExcludedPair& pair = excluded[p];
    const Vec3& shift = d.shifts[pair.shift];
    const int i = pair.i_slot, j = pair.j_slot;
    const double dx = double(d.x[i]) - d.x[j] - shift[0], dy = double(d.y[i]) - d.y[j] - shift[1],
                 dz = double(d.z[i]) - d.z[j] - shift[2];
    const double r2 = dx * dx + dy * dy + dz * dz;
    if (r2 >= cutoff2) continue;
    double a, b;  // b ≠ 0 only where a switch acts
    excluded_hessian(form, double(d.charge[i]) * d.charge[j], r2, a, b);
    const double dux = double(ux[i]) - ux[j], duy = double(uy[i]) - uy[j], duz = double(uz[i]) - uz[j];
    const double bp = b * (dx * dux + dy * duy + dz * duz);
    const double hx = a * dux + bp * dx, hy = a * duy + bp * dy, hz = a * duz + bp * dz;
    ox[i] += hx;
    oy[i] += hy;
    oz[i] += hz;
    ox[j] -= hx;
    oy[j] -= hy;
    oz[j] -= hz;
  }
}

// Extra buffer of the searched list over the pruned one when the configuration leaves it open.
constexpr double kAutoSearchSkinExtra = 0.6;  // nm

// Lists are pruned on single-precision distances whatever the precision of the forces: twice the
// lanes a vector, and the list stays exact (the range is widened by their rounding). The extra
// pairs add exact zeros; only the threads' split of the entries, hence the order of their force
// sums, can differ from a list pruned on doubles.
constexpr bool kPruneOnSinglePrecision = true;

// The pair list's buffer: as configured, cut to what the box allows (pair_list_warnings says so).
double skin_for(const System& system, const ForceFieldConfig& config) {
  return skin_fitting_box(system.box, config.cutoff, config.neighbor_skin);
}

// The searched list's buffer: as configured, or the pruned one's plus kAutoSearchSkinExtra, in
// either case cut to what the box allows. Pruning pays only if the search can then wait longer than
// a pruning does, i.e. if the extra buffer is at least the pruned one.
double search_skin_for(const System& system, const ForceFieldConfig& config) {
  const double skin = skin_for(system, config);
  if (config.neighbor_search_skin)
    return std::max(skin, skin_fitting_box(system.box, config.cutoff, *config.neighbor_search_skin));
  const double search_skin = skin_fitting_box(system.box, config.cutoff, skin + kAutoSearchSkinExtra);
  return search_skin - skin >= skin ? search_skin : skin;
}

// Some c6 or c12 of type t's row is not zero.
bool type_has_lj(const System& system, int t) {
  return (system.c6.row(t).array() != 0).any() || (system.c12.row(t).array() != 0).any();
}

// Per atom: 1 where its type has Lennard-Jones; empty where the type tables do not fit (the
// constructor reports that).
std::vector<char> atoms_with_lj(const System& system) {
  const Eigen::Index n_types = system.c6.rows();
  if (system.c6.cols() != n_types || system.c12.rows() != n_types || system.c12.cols() != n_types) return {};
  std::vector<char> lj(system.type.size());
  for (std::size_t a = 0; a < lj.size(); ++a) {
    const int t = system.type[a];
    if (t < 0 || t >= n_types) return {};
    lj[a] = type_has_lj(system, t);
  }
  return lj;
}

// Small lists run on one thread: starting a team would cost more than the pairs.
constexpr std::size_t kParallelEntries = 2048;

// Excluded pairs go in fixed blocks (independent of the thread count, like the per-half energies),
// each thread a contiguous run of them: small blocks, so that the runs are near equal.
constexpr int kExcludedBlock = 256;

template <class F>
void for_thread_blocks(int n_blocks, int t, int nt, F&& f) {
  for (int b = n_blocks * t / nt; b < n_blocks * (t + 1) / nt; ++b) f(b);
}

}  // namespace

NonbondedPairTerm::NonbondedPairTerm(const System& system, const ForceFieldConfig& config)
    : n_atoms_(system.n_atoms()),
      mixed_(config.precision == "mixed"),
      forms_(make_pair_form_constants(config)),
      cutoff2_(config.cutoff * config.cutoff),
      n_types_(static_cast<int>(system.c6.rows())),
      charge_(system.charge),
      type_(system.type),
      fresh_lists_(system.box, config.cutoff, search_skin_for(system, config), skin_for(system, config),
                   system.exclusions, atoms_with_lj(system)),
      run_(fresh_workspace()) {
  if (system.c6.rows() != system.c6.cols() || system.c12.rows() != n_types_ || system.c12.cols() != n_types_)
    throw std::invalid_argument("NonbondedPairTerm: c6/c12 must be square matrices of the same size");
  if (static_cast<int>(type_.size()) != n_atoms_ || charge_.size() != n_atoms_)
    throw std::invalid_argument("NonbondedPairTerm: type and charge need one entry per atom");
  for (int t : type_)
    if (t < 0 || t >= n_types_) throw std::invalid_argument("NonbondedPairTerm: atom type index out of range");
  force_continuous_at_cutoff_ = true;
  for_each_present_form(forms_, [&](const auto& form) {
    if (form.continuity(config.cutoff) < 1) force_continuous_at_cutoff_ = false;
  });
  for_each_excluded_pair_form(forms_, [&](const auto&) { excluded_pairs_ = true; });
  c6_.resize(static_cast<std::size_t>(n_types_) * n_types_);
  c12_.resize(c6_.size());
  for (int a = 0; a < n_types_; ++a)
    for (int b = 0; b < n_types_; ++b) {
      c6_[a * n_types_ + b] = system.c6(a, b);
      c12_[a * n_types_ + b] = system.c12(a, b);
    }
  type_has_lj_.resize(n_types_);
  for (int t = 0; t < n_types_; ++t) type_has_lj_[t] = type_has_lj(system, t);
  double sum_q2 = 0;  // a plain loop: Eigen's AVX-512 reduction trips a GCC 12 false-positive warning
  for (double qi : charge_) sum_q2 += qi * qi;
  for_each_present_form(forms_, [&](const auto& form) {
    if constexpr (kHasSelfEnergy<std::remove_cvref_t<decltype(form)>>)
      self_energy_[static_cast<int>(form.kEnergy)] += form.self_energy(sum_q2);
  });
}

void NonbondedPairTerm::check_atoms(const Coords& q) const {
  if (q.cols() != n_atoms_)
    throw std::invalid_argument("NonbondedPairTerm: " + std::to_string(q.cols()) + " positions for " +
                                std::to_string(n_atoms_) + " atoms");
}

void NonbondedPairTerm::keep_lists(Workspace& w, const Coords& q, Step* step) const {
  check_atoms(q);
  if (step)
    w.lists.keep_step(step->list, q, kPruneOnSinglePrecision);
  else
    w.lists.keep_regular(q, kPruneOnSinglePrecision);
  refresh_layout(w);
}

NonbondedPairTerm::Visit NonbondedPairTerm::visit(const Workspace& w, const Step* step) {
  if (step) return {step->list.list.view(), step->fixed};
  return {w.lists.regular(), false};
}

void NonbondedPairTerm::start_step(const Coords& q, std::unique_ptr<TermStepState>& state) {
  check_atoms(q);
  if (!state) state = std::make_unique<Step>();
  Step* step = step_of(state.get());
  step->fixed = !force_continuous_at_cutoff_;
  run_.lists.start_step(step->list, q, step->fixed, kPruneOnSinglePrecision);
  refresh_layout(run_);
}

void NonbondedPairTerm::keep_single_precision(Workspace& w) const {
  if (w.single_kept) return;
  w.single_kept = true;
  if (w.layout_build >= 0) refresh_single_precision_layout(w);  // later searches refresh them too
}

template <class Real>
PairViewOf<Real> NonbondedPairTerm::pair_view(Workspace& w, const Visit& visit) const {
  // With a fixed pair set the masks alone decide; its pairs interact wherever they go.
  const double cutoff2 = visit.fixed ? std::numeric_limits<double>::infinity() : cutoff2_;
  const SlotArrays<Real>& a = w.template slot_arrays<Real>();
  const NeighborList& list = w.lists.searched();
  const NeighborList::Entry* const* half_entries =
      visit.list.half_entries.empty() ? nullptr : visit.list.half_entries.data();
  return {{a.x.data(), a.y.data(), a.z.data(), visit.list.entries.data(), visit.list.half_start.data(),
           list.shift_vectors().data(), cutoff2, half_entries},
          a.charge.data(),
          w.slot_type.data(),
          a.lj.data(),
          type_has_lj_.data(),
          static_cast<std::size_t>(list.n_slots()),
          forms_};
}

bool NonbondedPairTerm::lists_pair(int a, int b, const TermStepState* step) const {
  constexpr int kC = NeighborList::kClusterSize, kH = NeighborList::kHalfSize;
  const PairListView listed = visit(run_, step_of(step)).list;
  auto holds = [&](int i_slot, int j_slot) {
    const int h = i_slot / kH;
    const std::uint32_t bit = 1u << ((i_slot % kH) * kC + j_slot % kC);
    const NeighborList::Entry* entries = listed.entries_of(h);
    for (int k = 0; k < listed.half_start[h + 1] - listed.half_start[h]; ++k)
      if (entries[k].j_cluster() == j_slot / kC && (entries[k].mask & bit)) return true;
    return false;
  };
  const auto& atom_slot = run_.lists.searched().atom_slot();
  const int sa = atom_slot[a], sb = atom_slot[b];
  return holds(sa, sb) || holds(sb, sa);
}

std::size_t NonbondedPairTerm::visited_entries(const TermStepState* step) const {
  return visit(run_, step_of(step)).list.size();
}

void NonbondedPairTerm::restore(const Carried& in) {
  if (in.has("neighbor_list_built_at") && in.coords("neighbor_list_built_at").cols() != n_atoms_)
    throw std::invalid_argument("NonbondedPairTerm::restore: wrong number of atoms");
  run_.lists.restore(in, kPruneOnSinglePrecision);
  refresh_layout(run_);
}

void NonbondedPairTerm::refresh_layout(Workspace& w) const {
  const NeighborList& list = w.lists.searched();
  if (w.layout_build == list.builds()) return;
  const int n = list.n_slots();
  const auto& slot_atom = list.slot_atom();
  SlotArrays<double>& slots = w.slots;
  w.slot_type.assign(n, 0);
  slots.charge.assign(n, 0.0);
  for (int s = 0; s < n; ++s) {
    const int a = slot_atom[s];
    if (a < 0) continue;
    slots.charge[s] = charge_[a];
    w.slot_type[s] = type_[a];
  }
  for (auto* v : {&slots.x, &slots.y, &slots.z}) v->resize(n);
  constexpr int kC = NeighborList::kClusterSize;
  slots.lj.assign(2 * static_cast<std::size_t>(n_types_) * n, 0.0);
  for (int t = 0; t < n_types_; ++t)
    for (int s = 0; s < n; ++s) {
      if (slot_atom[s] < 0) continue;
      double* at = slots.lj.data() + lj_index(t, s / kC, n) + s % kC;
      at[0] = c6_[t * n_types_ + w.slot_type[s]];
      at[kC] = c12_[t * n_types_ + w.slot_type[s]];
    }
  if (w.single_kept) refresh_single_precision_layout(w);
  w.layout_build = list.builds();
}

void NonbondedPairTerm::refresh_single_precision_layout(Workspace& w) const {
  SlotArrays<float>& single = w.single_slots;
  single.charge.assign(w.slots.charge.begin(), w.slots.charge.end());
  single.lj.assign(w.slots.lj.begin(), w.slots.lj.end());
  for (auto* v : {&single.x, &single.y, &single.z}) v->resize(w.lists.searched().n_slots());
}

// One parallel region per evaluation; pack() is worksharing loops that fill the slot arrays.
template <class Real, class Pack, class Halves, class Blocks>
void NonbondedPairTerm::run_parallel(Workspace& w, std::span<const int> visited_half_start,
                                     std::vector<std::vector<Real>>& buffers, Pack&& pack, Halves&& halves,
                                     Blocks&& blocks, Coords& out, bool write) const {
  const NeighborList& list = w.lists.searched();
  const int n = list.n_slots();
  const std::size_t n_entries = visited_half_start.empty() ? 0 : visited_half_start.back();
  // Segments by the regular list's entries, where it is there: a step list visited instead is then
  // split as the regular list would be, and the pairs it lacks, exact zeros, leave its sums bit for
  // bit the regular list's.
  const std::span<const int> regular_half_start = w.lists.regular_half_start();
  const std::span<const int> half_start =
      regular_half_start.size() == visited_half_start.size() ? regular_half_start : visited_half_start;
  buffers.resize(pair_loop_segments(omp_get_max_threads()));
  for (auto& b : buffers) b.resize(3 * static_cast<std::size_t>(n));
  const auto& atom_slot = list.atom_slot();
  std::atomic<int> next_tail{0};
#pragma omp parallel if (n_entries >= kParallelEntries)
  {
    pack();
    const int t = omp_get_thread_num(), nt = omp_get_num_threads();
    const int segments = pair_loop_segments(nt);
    const auto run_segment = [&](int s, std::size_t first_slot) {
      Real* b = buffers[s].data();
      for (int k = 0; k < 3; ++k) std::fill(b + k * n + first_slot, b + (k + 1) * n, Real(0));
      for_segment_chunks(half_start, s, nt, [&](int h0, int h1) { halves(h0, h1, b, b + n, b + 2 * n); });
    };
    // A tail's entries pair its halves' clusters with the same or later ones (NeighborList), so
    // its sums start at its first cluster's slots. A home segment's buffer is whole: its thread's
    // excluded pairs may be anywhere.
    std::size_t tail_first_slot[kTailSegments] = {};
    for (int s = nt; s < segments; ++s)
      tail_first_slot[s - nt] = static_cast<std::size_t>(segment_first_half(half_start, s, nt) / 2) *
                                NeighborList::kClusterSize;
    take_segments(t, nt, next_tail, [&](int s) {
      if (s >= nt) return run_segment(s, tail_first_slot[s - nt]);
      run_segment(s, 0);
      blocks(t, nt, buffers[s].data(), buffers[s].data() + n, buffers[s].data() + 2 * n);
    });
#pragma omp barrier
    // By atom shares, as the per-atom passes that read out next split the atoms, each share in
    // the order of its slots.
    const int* order = list.share_atoms_by_slot(nt);
    for (int i = share_begin(n_atoms_, t, nt), end = share_begin(n_atoms_, t + 1, nt); i < end; ++i) {
      const int a = order ? order[i] : i;
      const std::size_t s = atom_slot[a];
      double sx = 0, sy = 0, sz = 0;
      for (int k = 0; k < segments && (k < nt || s >= tail_first_slot[k - nt]); ++k) {
        const Real* b = buffers[k].data();
        sx += b[s];
        sy += b[n + s];
        sz += b[2 * n + s];
      }
      if (write) {
        out(0, a) = sx;
        out(1, a) = sy;
        out(2, a) = sz;
      } else {
        out(0, a) += sx;
        out(1, a) += sy;
        out(2, a) += sz;
      }
    }
  }
}

void NonbondedPairTerm::add_forces(const Coords& q, Coords& f, std::span<double> energies,
                                   const TermEvaluation& how) {
  if (how.single_precision) keep_single_precision(run_);
  Step* step = step_of(how.step);
  keep_lists(run_, q, step);
  const Visit v = visit(run_, step);
  forces(run_, v, q, f, energies, mixed_ || how.single_precision, v.fixed ? nullptr : how.keep_masks,
         how.forces_unset);
}

void NonbondedPairTerm::add_single_point(const Coords& q, Coords& f, std::span<double> energies) const {
  Workspace w = fresh_workspace();
  keep_lists(w, q, nullptr);
  forces(w, visit(w, nullptr), q, f, energies, mixed_, nullptr, false);
}

void NonbondedPairTerm::forces(Workspace& w, const Visit& visit, const Coords& q, Coords& f,
                               std::span<double> energies, bool single, TermMasks* keep, bool write) const {
  const bool with_energies = !energies.empty();
  if (single)
    add_pair_forces<float>(w, visit, simd::single_force_kernel(forms_, with_energies, keep != nullptr), q, f, energies,
                           keep, write);
  else
    add_pair_forces<double>(w, visit, simd::force_kernel(forms_, with_energies, keep != nullptr), q, f, energies,
                            keep, write);
}

template <class Real, class Kernel>
void NonbondedPairTerm::add_pair_forces(Workspace& w, const Visit& visit, Kernel pair_kernel, const Coords& q,
                                        Coords& f, std::span<double> energies, TermMasks* keep, bool write) const {
  SlotArrays<Real>& slots = w.template slot_arrays<Real>();
  const PairViewOf<Real> view = pair_view<Real>(w, visit);
  const NeighborList& list = w.lists.searched();
  const NeighborList::ExcludedPair* excluded = list.excluded_pairs().data();
  const int n_excluded = excluded_pairs_ ? static_cast<int>(list.excluded_pairs().size()) : 0;
  const int n_halves = list.n_halves();
  const int n_blocks = (n_excluded + kExcludedBlock - 1) / kExcludedBlock;
  // Per PairEnergy k: the energies of the i-halves at half[k], of the excluded-pair blocks at block[k].
  w.partial_energies.assign(kPairEnergies * (n_halves + n_blocks), 0.0);
  std::array<double*, kPairEnergies> half, block;
  for (int k = 0; k < kPairEnergies; ++k) {
    half[k] = w.partial_energies.data() + k * n_halves;
    block[k] = w.partial_energies.data() + kPairEnergies * n_halves + k * n_blocks;
  }
  const auto excluded_kernel = [] {
    if constexpr (std::is_same_v<Real, float>)
      return simd::single_excluded_kernel();
    else
      return simd::excluded_kernel();
  }();
  double* half_lj = half[static_cast<int>(PairEnergy::vdw)];
  double* half_coulomb = half[static_cast<int>(PairEnergy::coulomb)];
  std::uint32_t* inside_masks = nullptr;
  if (keep) {
    keep->list_id = visit.list.id;
    keep->single_precision = std::is_same_v<Real, float>;
    keep->bits.resize(visit.list.size());
    inside_masks = keep->bits.data();
  }
  run_parallel(
      w, visit.list.half_start, slots.thread_buffers,
      [&] { list.pack_positions(q, slots.x.data(), slots.y.data(), slots.z.data()); },
      [&](int h0, int h1, Real* fx, Real* fy, Real* fz) {
        pair_kernel(view, h0, h1, fx, fy, fz, half_lj, half_coulomb, inside_masks);
      },
      [&](int t, int nt, Real* fx, Real* fy, Real* fz) {
        for_thread_blocks(n_blocks, t, nt, [&](int b) {
          double energies_of_block[kPairEnergies] = {};
          excluded_kernel(view, excluded, cutoff2_, b * kExcludedBlock, std::min(n_excluded, (b + 1) * kExcludedBlock),
                          fx, fy, fz, energies_of_block);
          for (int k = 0; k < kPairEnergies; ++k) block[k][b] += energies_of_block[k];
        });
      },
      f, write);
  if (energies.empty()) return;
  for (int k = 0; k < kPairEnergies; ++k) {
    double sum = self_energy_[k];
    for (int h = 0; h < n_halves; ++h) sum += half[k][h];
    for (int b = 0; b < n_blocks; ++b) sum += block[k][b];
    energies[k] += sum;
  }
}

void NonbondedPairTerm::add_hessian_vector(const Coords& q, const Coords& u, Coords& out, const TermEvaluation& how) {
  if (how.single_precision) keep_single_precision(run_);
  Step* step = step_of(how.step);
  keep_lists(run_, q, step);
  const Visit v = visit(run_, step);
  if (how.single_precision)
    add_pair_hessian_vector<float>(run_, v, simd::single_hessian_kernel(forms_), q, u, out, how.masks);
  else
    add_pair_hessian_vector<double>(run_, v, simd::hessian_kernel(forms_), q, u, out, how.masks);
}

template <class Real, class Kernel>
void NonbondedPairTerm::add_pair_hessian_vector(Workspace& w, const Visit& visit, Kernel pair_kernel,
                                                const Coords& q, const Coords& u, Coords& out,
                                                const TermMasks* masks_at_q) const {
  constexpr bool single = std::is_same_v<Real, float>;
  SlotArrays<Real>& slots = w.template slot_arrays<Real>();
  const PairViewOf<Real> view = pair_view<Real>(w, visit);
  const NeighborList& list = w.lists.searched();
  // Sized here, not with the layout: runs without products (RATTLE, Verlet) never hold them.
  for (auto* v : {&slots.ux, &slots.uy, &slots.uz}) v->resize(list.n_slots());
  const NeighborList::ExcludedPair* excluded = list.excluded_pairs().data();
  const int n_excluded = excluded_pairs_ ? static_cast<int>(list.excluded_pairs().size()) : 0;
  const int n_blocks = (n_excluded + kExcludedBlock - 1) / kExcludedBlock;
  // The kernel takes the masks as the interacting pairs (it has no cut-off test of its own): a
  // force pass's at these positions on this list (a single-precision product also takes a
  // double-precision pass's: exact decisions, where its own could differ only for pairs within
  // float rounding of the cut-off); with a fixed pair set, the step list's own (its pairs); or
  // else each chunk's from the mask kernel just before it.
  const bool reuse = !visit.fixed && masks_at_q && masks_at_q->list_id == visit.list.id && visit.list.id >= 0 &&
                     (single || !masks_at_q->single_precision);
  const bool find_masks = !reuse && !visit.fixed;
  if (reuse) {
    ++w.reused_masks;
  } else {
    w.list_masks.resize(visit.list.size());
    if (visit.fixed)
      for (std::size_t h = 0; h + 1 < visit.list.half_start.size(); ++h) {
        const NeighborList::Entry* entries = visit.list.entries_of(static_cast<int>(h));
        for (int e = visit.list.half_start[h]; e < visit.list.half_start[h + 1]; ++e)
          w.list_masks[e] = entries[e - visit.list.half_start[h]].mask;
      }
  }
  const std::uint32_t* masks = reuse ? masks_at_q->bits.data() : w.list_masks.data();
  const auto mask_kernel = [] {
    if constexpr (single)
      return simd::single_mask_kernel();
    else
      return simd::mask_kernel();
  }();
  run_parallel(
      w, visit.list.half_start, slots.thread_buffers,
      [&] {
        list.pack_positions(q, slots.x.data(), slots.y.data(), slots.z.data());
        list.pack_vectors(u, slots.ux.data(), slots.uy.data(), slots.uz.data());
      },
      [&](int h0, int h1, Real* ox, Real* oy, Real* oz) {
        if (find_masks) mask_kernel(view, h0, h1, w.list_masks.data());
        pair_kernel(view, slots.ux.data(), slots.uy.data(), slots.uz.data(), masks, h0, h1, ox, oy, oz);
      },
      [&](int t, int nt, Real* ox, Real* oy, Real* oz) {
        for_thread_blocks(n_blocks, t, nt, [&](int b) {
          for_each_excluded_pair_form(view.forms, [&](const auto& form) {
            excluded_pair_hessian(form, view, excluded, cutoff2_, slots.ux.data(), slots.uy.data(), slots.uz.data(),
                                  b * kExcludedBlock, std::min(n_excluded, (b + 1) * kExcludedBlock), ox, oy, oz);
          });
        });
      },
      out);
}

std::vector<std::string> pair_list_warnings(const RunConfig& config, const Box& box) {
  const ForceFieldConfig& ff = forcefield_config(config);
  double shortest = INFINITY;
  for (int k = 0; k < 3; ++k)
    if (box.length[k] > 0) shortest = std::min(shortest, box.length[k]);
  std::vector<std::string> warnings;
  const auto fit = [&](const char* key, double skin) {
    const double fitting = skin_fitting_box(box, ff.cutoff, skin);
    if (fitting >= skin) return;
    char numbers[3][32];
    std::snprintf(numbers[0], sizeof numbers[0], "%g", shortest);
    std::snprintf(numbers[1], sizeof numbers[1], "%g", skin);
    std::snprintf(numbers[2], sizeof numbers[2], "%g", fitting);
    warnings.push_back(config.structure.string() + ": the box (" + numbers[0] + " nm at its shortest) leaves room for " +
                       "cutoff + " + key + " up to half its length, so the " + key + " of " + numbers[1] +
                       " nm set in " + config.file.string() + " is cut to " + numbers[2] +
                       " nm (as GROMACS shrinks its pair-list buffer to what the box allows); a run searches for "
                       "pairs more often");
  };
  fit("neighbor_skin", ff.neighbor_skin);
  if (ff.neighbor_search_skin) fit("neighbor_search_skin", *ff.neighbor_search_skin);
  return warnings;
}

}  // namespace vimd
