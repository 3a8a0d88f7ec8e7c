#include "forcefields/nonbonded_pair_term.hpp"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "engine/errors.hpp"
#include "forcefields/reaction_field-inl.h"

namespace vimd {

namespace {

double max_abs_coordinate(const Coords& q) {
  double m = 0;  // a plain loop: Eigen's AVX-512 reduction trips a GCC 12 false-positive warning
  for (Eigen::Index k = 0; k < q.size(); ++k) m = std::max(m, std::abs(q.data()[k]));
  return m;
}

// The scalar excluded-pair terms, from the build's static SIMD target.
using HWY_NAMESPACE::rf_excluded_energy_force;
using HWY_NAMESPACE::rf_excluded_hessian;

// Reaction-field terms of the excluded pairs [p0, p1) (GROMACS keeps k_rf r² − c_rf for them), in
// double precision from the view's positions, added to force buffers of the view's precision.
template <class Real>
double excluded_forces(const PairViewOf<Real>& d, const NeighborList::ExcludedPair* excluded, double cutoff2, int p0,
                       int p1, Real* fx, Real* fy, Real* fz) {
  double e_coulomb = 0;
  for (int p = p0; p < p1; ++p) {
    const NeighborList::ExcludedPair& pair = excluded[p];
    const Vec3& shift = d.shifts[pair.shift];
    const int i = pair.i_slot, j = pair.j_slot;
    const double dx = double(d.x[i]) - d.x[j] - shift[0], dy = double(d.y[i]) - d.y[j] - shift[1],
                 dz = double(d.z[i]) - d.z[j] - shift[2];
    const double r2 = dx * dx + dy * dy + dz * dz;
    if (r2 >= cutoff2) continue;
    double v, g;
    rf_excluded_energy_force(d.rf, d.rf.prefactor * d.charge[i] * d.charge[j], r2, v, g);
    e_coulomb += v;
    fx[i] += g * dx;
    fy[i] += g * dy;
    fz[i] += g * dz;
    fx[j] -= g * dx;
    fy[j] -= g * dy;
    fz[j] -= g * dz;
  }
  return e_coulomb;
}

// The same for Hessian–vector products, in double precision, added to buffers of the view's precision.
template <class Real>
void excluded_hessian(const PairViewOf<Real>& d, const NeighborList::ExcludedPair* excluded, double cutoff2,
                      const Real* ux, const Real* uy, const Real* uz, int p0, int p1, Real* ox, Real* oy, Real* oz) {
  for (int p = p0; p < p1; ++p) {
    const NeighborList::ExcludedPair& pair = excluded[p];
    const Vec3& shift = d.shifts[pair.shift];
    const int i = pair.i_slot, j = pair.j_slot;
    const double dx = double(d.x[i]) - d.x[j] - shift[0], dy = double(d.y[i]) - d.y[j] - shift[1],
                 dz = double(d.z[i]) - d.z[j] - shift[2];
    const double r2 = dx * dx + dy * dy + dz * dz;
    if (r2 >= cutoff2) continue;
    double a, b;  // b ≠ 0 only where a switch acts
    rf_excluded_hessian(d.rf, d.rf.prefactor * d.charge[i] * d.charge[j], r2, a, b);
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

// The i-halves in chunks of kHalfChunk, dealt to the threads in rounds of nt chunks: early halves
// (a cluster paired with all later ones) cost more per entry than late ones (fewer cache hits on
// their j-clusters), so contiguous blocks of equal entry counts left one of two threads waiting
// 25 % of the kernel time. The deal runs back and forth (thread 0 first, then last, in alternate
// rounds): dealt always in the same direction, thread 0 took the costlier chunk of every round (perf
// of vi on water900, 2 threads: up to 9 % more kernel samples on thread 0). It depends only on the
// thread count, as the summation order must.
constexpr int kHalfChunk = 16;

int half_chunks(int n_halves) { return (n_halves + kHalfChunk - 1) / kHalfChunk; }

// f(h0, h1) for the chunks of thread t of nt.
template <class F>
void for_thread_chunks(int n_halves, int t, int nt, F&& f) {
  const int chunks = half_chunks(n_halves);
  for (int round_start = 0; round_start < chunks; round_start += nt) {
    const int c = round_start + ((round_start / nt) % 2 == 0 ? t : nt - 1 - t);
    if (c < chunks) f(c * kHalfChunk, std::min(n_halves, (c + 1) * kHalfChunk));
  }
}

// The step list's skin: twice the largest displacement from its start that the last step's
// evaluations reached, times a margin for this step reaching further (water900, rk4 at 2 fs: the
// reach, ~0.011 nm, changes by up to ~10 % from one step to the next; an evaluation beyond half the
// skin costs another pruning). Never below kMinStepSkin, far above the rounding of
// single-precision distances.
constexpr double kStepReachMargin = 1.3;
constexpr double kMinStepSkin = 0.005;  // nm

// Extra buffer of the searched list over the pruned one when the configuration leaves it open.
constexpr double kAutoSearchSkinExtra = 0.4;  // nm

// The pair list's buffer: as configured, cut to what the box allows (engine/input.cpp warns).
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

}  // namespace

NonbondedPairTerm::NonbondedPairTerm(const System& system, const ForceFieldConfig& config)
    : n_atoms_(system.n_atoms()),
      mixed_(config.precision == "mixed"),
      modifier_(parse_vdw_modifier(config.vdw_modifier)),
      lj_(make_lj_constants(modifier_, config.cutoff, config.vdw_switch, config.switch_smoothness)),
      rf_(make_reaction_field(config.coulomb, config.epsilon_r, config.epsilon_rf, config.cutoff,
                              config.coulomb_modifier, config.coulomb_switch, config.switch_smoothness)),
      shared_switch_(modifier_ == VdwModifier::potential_switch && rf_.kind == CoulombKind::reaction_field &&
                     rf_.modifier == CoulombModifier::potential_switch && rf_.sw.r_switch == lj_.sw.r_switch &&
                     rf_.sw.smoothness == lj_.sw.smoothness),
      cutoff2_(config.cutoff * config.cutoff),
      n_types_(static_cast<int>(system.c6.rows())),
      charge_(system.charge),
      type_(system.type),
      skin_(skin_for(system, config)),
      list_(system.box, config.cutoff, search_skin_for(system, config), system.exclusions) {
  if (system.c6.rows() != system.c6.cols() || system.c12.rows() != n_types_ || system.c12.cols() != n_types_)
    throw std::invalid_argument("NonbondedPairTerm: c6/c12 must be square matrices of the same size");
  if (static_cast<int>(type_.size()) != n_atoms_ || charge_.size() != n_atoms_)
    throw std::invalid_argument("NonbondedPairTerm: type and charge need one entry per atom");
  for (int t : type_)
    if (t < 0 || t >= n_types_) throw std::invalid_argument("NonbondedPairTerm: atom type index out of range");
  force_continuous_at_cutoff_ =
      lj_continuity(modifier_, config.switch_smoothness) >= 1 &&
      (rf_.kind == CoulombKind::none || coulomb_continuity(rf_, config.cutoff) >= 1);
  c6_.resize(static_cast<std::size_t>(n_types_) * n_types_);
  c12_.resize(c6_.size());
  for (int a = 0; a < n_types_; ++a)
    for (int b = 0; b < n_types_; ++b) {
      c6_[a * n_types_ + b] = system.c6(a, b);
      c12_[a * n_types_ + b] = system.c12(a, b);
    }
  type_has_lj_.assign(n_types_, 0);
  for (int a = 0; a < n_types_; ++a)
    for (int b = 0; b < n_types_; ++b)
      if (system.c6(a, b) != 0 || system.c12(a, b) != 0) type_has_lj_[a] = 1;
  double sum_q2 = 0;  // a plain loop: Eigen's AVX-512 reduction trips a GCC 12 false-positive warning
  for (double qi : charge_) sum_q2 += qi * qi;
  if (rf_.kind == CoulombKind::reaction_field) self_energy_ = rf_self_energy(rf_, sum_q2);
}

void NonbondedPairTerm::prepare(const Coords& q) {
  if (q.cols() != n_atoms_)
    throw std::invalid_argument("NonbondedPairTerm: " + std::to_string(q.cols()) + " positions for " +
                                std::to_string(n_atoms_) + " atoms");
  // A fixed pair set needs no new pairs, and a rebuild would renumber the entries it refers to.
  if (pair_set_fixed_) {
    refresh_layout();
  } else if (step_list_) {
    const double moved = max_displacement(q, step_at_);
    step_reach_ = std::max(step_reach_, moved);
    if (moved > 0.5 * step_skin_) prune_step_list(q, step_skin_after(moved));
  } else {
    keep_regular_list(q, 0.5 * skin_);
  }
}

void NonbondedPairTerm::keep_regular_list(const Coords& q, double allowed) {
  if (!pruning()) {
    list_.update(q, allowed);
    refresh_layout();
  } else if (prunes_ == 0 || max_displacement(q, pruned_at_) > allowed) {
    const double moved = list_.update(q, 0.5 * (list_.skin() - skin_));
    refresh_layout();
    prune(q, moved);
  }
}

void NonbondedPairTerm::prune(const Coords& q, double moved_since_search) {
  const auto start = std::chrono::steady_clock::now();
  const double range = list_.cutoff() + skin_;
  // Since the search no pair came closer by more than twice the largest displacement: an entry
  // whose atoms were all that much beyond the pruned range then cannot have a pair inside it now.
  // On single-precision positions where they are kept (cheaper; narrow covers their rounding).
  narrow(list_.entries(), list_.half_start(), q, range, range + 2 * moved_since_search,
         mixed_ || single_precision_asked_, pruned_entries_, pruned_half_start_);
  pruned_at_ = q;
  ++prunes_;
  prune_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void NonbondedPairTerm::narrow(const std::vector<NeighborList::Entry>& from, const std::vector<int>& from_start,
                               const Coords& q, double range, double skip_from, bool single,
                               std::vector<NeighborList::Entry>& to, std::vector<int>& to_start) {
  prune_masks_.resize(from.size());
  // Single-precision distances are compared with a range widened by a bound on their rounding
  // (coordinates and shifts below `magnitude`; a few roundings of each difference), so that every
  // pair truly within the range is kept.
  const double magnitude = max_abs_coordinate(q) + 2 * list_.box().length.maxCoeff() + range;
  const double float_range = range + 16 * std::numeric_limits<float>::epsilon() * magnitude;
  auto view_of = [&](auto view, double kept_range) {
    view.entries = from.data();
    view.half_start = from_start.data();
    view.cutoff2 = kept_range * kept_range;
    return view;
  };
  const PairView view = view_of(pair_view<double>(), range);
  const PairViewOf<float> float_view = view_of(pair_view<float>(), float_range);
  const MaskKernel kernel = simd::mask_kernel();
  const MixedMaskKernel float_kernel = simd::mixed_mask_kernel();
  const int n_halves = list_.n_halves();
  to_start.resize(n_halves + 1);
  to_start[0] = 0;
  std::vector<int> chunk_kept(half_chunks(n_halves) + 1, 0);
  constexpr std::size_t kParallelEntries = 2048;  // as in run_parallel
  // Each thread narrows its chunks of halves and counts what each keeps; the chunks are then
  // copied into place in half order (the result does not depend on the thread count).
#pragma omp parallel if (from.size() >= kParallelEntries)
  {
    if (single)
      list_.pack_positions(q, mixed_slots_.x.data(), mixed_slots_.y.data(), mixed_slots_.z.data());
    else
      list_.pack_positions(q, slots_.x.data(), slots_.y.data(), slots_.z.data());
    const int t = omp_get_thread_num(), nt = omp_get_num_threads();
    for_thread_chunks(n_halves, t, nt, [&](int h0, int h1) {
      if (single)
        float_kernel(float_view, h0, h1, skip_from, prune_masks_.data());
      else
        kernel(view, h0, h1, skip_from, prune_masks_.data());
      int kept = 0;
      for (int e = from_start[h0]; e < from_start[h1]; ++e) kept += prune_masks_[e] != 0;
      chunk_kept[h0 / kHalfChunk + 1] = kept;
    });
#pragma omp barrier
#pragma omp single
    {
      std::partial_sum(chunk_kept.begin(), chunk_kept.end(), chunk_kept.begin());
      to.resize(chunk_kept.back());
    }
    for_thread_chunks(n_halves, t, nt, [&](int h0, int h1) {
      int out = chunk_kept[h0 / kHalfChunk];
      for (int h = h0; h < h1; ++h) {
        for (int e = from_start[h]; e < from_start[h + 1]; ++e)
          if (prune_masks_[e] != 0) {
            to[out] = from[e];
            to[out++].mask = prune_masks_[e];
          }
        to_start[h + 1] = out;
      }
    });
  }
}

double NonbondedPairTerm::step_skin_after(double reach) const {
  if (reach < 0) return 0.5 * skin_;  // no step yet
  return std::clamp(2 * kStepReachMargin * reach, kMinStepSkin, skin_);
}

void NonbondedPairTerm::prune_step_list(const Coords& q, double skin) {
  step_list_ = false;
  // The regular list must then hold every pair within cut-off + skin at q.
  keep_regular_list(q, 0.5 * (skin_ - skin));
  const auto start = std::chrono::steady_clock::now();
  // The fixed pair set (skin 0) is exactly the pairs inside the cut-off at q: double-precision
  // distances. A buffered step list may be cut on the cheaper single-precision ones where those
  // positions are kept anyway (narrow widens the range by their rounding).
  const bool single = skin > 0 && (mixed_ || single_precision_asked_);
  narrow(regular_entries(), regular_half_start(), q, list_.cutoff() + skin, INFINITY, single, step_entries_,
         step_half_start_);
  step_list_ = true;
  step_at_ = q;
  step_skin_ = skin;
  ++step_prunes_;
  prune_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

template <class Real>
PairViewOf<Real> NonbondedPairTerm::pair_view() const {
  // With a fixed pair set the masks alone decide; its pairs interact wherever they go.
  const double cutoff2 = pair_set_fixed_ ? std::numeric_limits<double>::infinity() : cutoff2_;
  const SlotArrays<Real>& a = slot_arrays<Real>();
  return {a.x.data(),
          a.y.data(),
          a.z.data(),
          a.charge.data(),
          slot_type_.data(),
          a.c6.data(),
          a.c12.data(),
          type_has_lj_.data(),
          static_cast<std::size_t>(list_.n_slots()),
          entries().data(),
          half_start().data(),
          list_.shift_vectors().data(),
          cutoff2,
          lj_,
          rf_};
}

bool NonbondedPairTerm::lists_pair(int a, int b) const {
  constexpr int kC = NeighborList::kClusterSize, kH = NeighborList::kHalfSize;
  const auto& listed = entries();
  const auto& start = half_start();
  auto holds = [&](int i_slot, int j_slot) {
    const int h = i_slot / kH;
    const std::uint32_t bit = 1u << ((i_slot % kH) * kC + j_slot % kC);
    for (int e = start[h]; e < start[h + 1]; ++e)
      if (listed[e].j_cluster == j_slot / kC && (listed[e].mask & bit)) return true;
    return false;
  };
  const int sa = list_.atom_slot()[a], sb = list_.atom_slot()[b];
  return holds(sa, sb) || holds(sb, sa);
}

void NonbondedPairTerm::fix_pair_set(const Coords* q) {
  if (step_list_) {
    step_list_ = false;
    ++step_scopes_;
    last_reach_ = step_reach_;
  }
  pair_set_fixed_ = false;
  if (!q) return;
  step_reach_ = 0;
  if (force_continuous_at_cutoff_) {
    prune_step_list(*q, step_skin_after(last_reach_));
  } else {
    prune_step_list(*q, 0);
    pair_set_fixed_ = true;
  }
}

void NonbondedPairTerm::set_single_precision(bool on) {
  single_precision_ = on;
  if (on && !mixed_ && !single_precision_asked_) {
    single_precision_asked_ = true;
    if (layout_build_ >= 0) refresh_single_precision_layout();  // later list builds refresh them too
  }
}

void NonbondedPairTerm::save(Carried& out) const {
  if (list_.builds() > 0) out.put("neighbor_list_built_at", list_.built_at());
  if (prunes_ > 0) out.put("neighbor_list_pruned_at", pruned_at_);
}

void NonbondedPairTerm::restore(const Carried& in) {
  if (!in.has("neighbor_list_built_at")) return;
  const Coords built_at = in.coords("neighbor_list_built_at");
  if (built_at.cols() != n_atoms_) throw std::invalid_argument("NonbondedPairTerm::restore: wrong number of atoms");
  list_.build(built_at);  // the same positions give the same list, hence the same summation order
  refresh_layout();
  if (in.has("neighbor_list_pruned_at")) {
    const Coords pruned_at = in.coords("neighbor_list_pruned_at");
    if (pruned_at.cols() != n_atoms_) throw std::invalid_argument("NonbondedPairTerm::restore: wrong number of atoms");
    prune(pruned_at, max_displacement(pruned_at, built_at));
  }
}

void NonbondedPairTerm::refresh_layout() {
  if (layout_build_ == list_.builds()) return;
  const int n = list_.n_slots();
  const auto& slot_atom = list_.slot_atom();
  slot_type_.assign(n, 0);
  slots_.charge.assign(n, 0.0);
  for (int s = 0; s < n; ++s) {
    const int a = slot_atom[s];
    if (a < 0) continue;
    slots_.charge[s] = charge_[a];
    slot_type_[s] = type_[a];
  }
  for (auto* v : {&slots_.x, &slots_.y, &slots_.z, &slots_.ux, &slots_.uy, &slots_.uz}) v->resize(n);
  slots_.c6.assign(static_cast<std::size_t>(n_types_) * n, 0.0);
  slots_.c12.assign(slots_.c6.size(), 0.0);
  for (int t = 0; t < n_types_; ++t)
    for (int s = 0; s < n; ++s) {
      if (slot_atom[s] < 0) continue;
      slots_.c6[static_cast<std::size_t>(t) * n + s] = c6_[t * n_types_ + slot_type_[s]];
      slots_.c12[static_cast<std::size_t>(t) * n + s] = c12_[t * n_types_ + slot_type_[s]];
    }
  if (mixed_ || single_precision_asked_) refresh_single_precision_layout();
  layout_build_ = list_.builds();
}

void NonbondedPairTerm::refresh_single_precision_layout() {
  mixed_slots_.charge.assign(slots_.charge.begin(), slots_.charge.end());
  mixed_slots_.c6.assign(slots_.c6.begin(), slots_.c6.end());
  mixed_slots_.c12.assign(slots_.c12.begin(), slots_.c12.end());
  for (auto* v : {&mixed_slots_.x, &mixed_slots_.y, &mixed_slots_.z, &mixed_slots_.ux, &mixed_slots_.uy,
                  &mixed_slots_.uz})
    v->resize(list_.n_slots());
}

// Runs pack() (worksharing loops that fill the slot arrays), then kernel(thread, n_threads, fx, fy,
// fz) on every thread with a zeroed private buffer, then adds the buffers, in thread order, to out:
// one parallel region per evaluation.
template <class Real, class Pack, class Kernel>
void NonbondedPairTerm::run_parallel(std::vector<std::vector<Real>>& buffers, Pack&& pack, Kernel&& kernel,
                                     Coords& out) {
  const int n = list_.n_slots();
  buffers.resize(omp_get_max_threads());
  for (auto& b : buffers) b.resize(3 * static_cast<std::size_t>(n));
  const auto& atom_slot = list_.atom_slot();
  // Small lists run on one thread: starting a team would cost more than the pairs.
  constexpr std::size_t kParallelEntries = 2048;
#pragma omp parallel if (entries().size() >= kParallelEntries)
  {
    pack();
    const int t = omp_get_thread_num(), nt = omp_get_num_threads();
    Real* buffer = buffers[t].data();
    std::fill(buffer, buffer + 3 * static_cast<std::size_t>(n), Real(0));
    kernel(t, nt, buffer, buffer + n, buffer + 2 * n);
#pragma omp barrier
    // In atom order: out is then written in sequence (in slot order, its loads missed the cache:
    // half the time of this loop on 4000 waters), and the buffers, just written, are still cached.
#pragma omp for schedule(static)
    for (int a = 0; a < n_atoms_; ++a) {
      const int s = atom_slot[a];
      double sx = 0, sy = 0, sz = 0;
      for (int k = 0; k < nt; ++k) {
        const Real* b = buffers[k].data();
        sx += b[s];
        sy += b[n + s];
        sz += b[2 * n + s];
      }
      out(0, a) += sx;
      out(1, a) += sy;
      out(2, a) += sz;
    }
  }
}

namespace {

// Excluded pairs go in fixed blocks (independent of the thread count, like the per-half energies).
constexpr int kExcludedBlock = 1024;

}  // namespace

void NonbondedPairTerm::add_forces(const Coords& q, Coords& f, std::span<double> energies) {
  prepare(q);
  const bool coulomb = rf_.kind == CoulombKind::reaction_field, with_energies = !energies.empty();
  if (mixed_ || single_precision_)
    add_pair_forces(mixed_slots_,
                    simd::mixed_force_kernel(modifier_, coulomb, rf_.modifier, shared_switch_, with_energies), q, f,
                    energies);
  else
    add_pair_forces(slots_, simd::force_kernel(modifier_, coulomb, rf_.modifier, shared_switch_, with_energies), q, f,
                    energies);
}

template <class Real, class Kernel>
void NonbondedPairTerm::add_pair_forces(SlotArrays<Real>& slots, Kernel pair_kernel, const Coords& q, Coords& f,
                                        std::span<double> energies) {
  const PairViewOf<Real> view = pair_view<Real>();
  const NeighborList::ExcludedPair* excluded = list_.excluded_pairs().data();
  const int n_excluded = rf_.kind == CoulombKind::reaction_field ? static_cast<int>(list_.excluded_pairs().size()) : 0;
  const int n_halves = list_.n_halves();
  const int n_blocks = (n_excluded + kExcludedBlock - 1) / kExcludedBlock;
  partial_energies_.assign(2 * n_halves + n_blocks, 0.0);
  double* half_lj = partial_energies_.data();
  double* half_coulomb = half_lj + n_halves;
  double* block_coulomb = half_coulomb + n_halves;
  // Hessian–vector products at these positions will reuse them (find_inside_masks says which precisions).
  std::uint32_t* inside_masks = hessian_requested_ && !pair_set_fixed_
                                    ? record_inside_masks(q, std::is_same_v<Real, float>).data()
                                    : nullptr;
  run_parallel(slots.thread_buffers, [&] { list_.pack_positions(q, slots.x.data(), slots.y.data(), slots.z.data()); },
               [&](int t, int nt, Real* fx, Real* fy, Real* fz) {
                 for_thread_chunks(n_halves, t, nt, [&](int h0, int h1) {
                   pair_kernel(view, h0, h1, fx, fy, fz, half_lj, half_coulomb, inside_masks);
                 });
                 for (int b = t; b < n_blocks; b += nt)
                   block_coulomb[b] = excluded_forces(view, excluded, cutoff2_, b * kExcludedBlock,
                                                      std::min(n_excluded, (b + 1) * kExcludedBlock), fx, fy, fz);
               },
               f);
  if (energies.empty()) return;
  double lj_sum = 0, coulomb_sum = self_energy_;
  for (int h = 0; h < n_halves; ++h) lj_sum += half_lj[h];
  for (int h = 0; h < n_halves; ++h) coulomb_sum += half_coulomb[h];
  for (int b = 0; b < n_blocks; ++b) coulomb_sum += block_coulomb[b];
  energies[0] += lj_sum;
  energies[1] += coulomb_sum;
}

void NonbondedPairTerm::add_hessian_vector(const Coords& q, const Coords& u, Coords& out) {
  hessian_requested_ = true;
  prepare(q);
  const bool coulomb = rf_.kind == CoulombKind::reaction_field;
  if (single_precision_)
    add_pair_hessian_vector(mixed_slots_, simd::mixed_hessian_kernel(modifier_, coulomb, rf_.modifier, shared_switch_),
                            q, u, out);
  else
    add_pair_hessian_vector(slots_, simd::hessian_kernel(modifier_, coulomb, rf_.modifier, shared_switch_), q, u,
                            out);
}

template <class Real, class Kernel>
void NonbondedPairTerm::add_pair_hessian_vector(SlotArrays<Real>& slots, Kernel pair_kernel, const Coords& q,
                                                const Coords& u, Coords& out) {
  const PairViewOf<Real> view = pair_view<Real>();
  const NeighborList::ExcludedPair* excluded = list_.excluded_pairs().data();
  const int n_excluded = rf_.kind == CoulombKind::reaction_field ? static_cast<int>(list_.excluded_pairs().size()) : 0;
  const int n_blocks = (n_excluded + kExcludedBlock - 1) / kExcludedBlock;
  // The kernel takes the masks as the interacting pairs (it has no cut-off test of its own): a
  // force pass's at these positions; with a fixed pair set, the step list's own (its pairs); or
  // else each chunk's from the mask kernel just before it.
  const std::uint32_t* cached = find_inside_masks(q, std::is_same_v<Real, float>);
  const bool find_masks = !cached && !pair_set_fixed_;
  if (cached) {
    ++hessian_cache_hits_;
  } else {
    const auto& listed = entries();
    list_masks_.resize(listed.size());
    if (pair_set_fixed_)
      for (std::size_t e = 0; e < listed.size(); ++e) list_masks_[e] = listed[e].mask;
  }
  const std::uint32_t* masks = cached ? cached : list_masks_.data();
  const auto mask_kernel = [] {
    if constexpr (std::is_same_v<Real, float>)
      return simd::mixed_mask_kernel();
    else
      return simd::mask_kernel();
  }();
  run_parallel(
      slots.thread_buffers,
      [&] {
        list_.pack_positions(q, slots.x.data(), slots.y.data(), slots.z.data());
        list_.pack_vectors(u, slots.ux.data(), slots.uy.data(), slots.uz.data());
      },
      [&](int t, int nt, Real* ox, Real* oy, Real* oz) {
        for_thread_chunks(list_.n_halves(), t, nt, [&](int h0, int h1) {
          if (find_masks) mask_kernel(view, h0, h1, INFINITY, list_masks_.data());
          pair_kernel(view, slots.ux.data(), slots.uy.data(), slots.uz.data(), masks, h0, h1, ox, oy, oz);
        });
        for (int b = t; b < n_blocks; b += nt)
          excluded_hessian(view, excluded, cutoff2_, slots.ux.data(), slots.uy.data(), slots.uz.data(),
                           b * kExcludedBlock, std::min(n_excluded, (b + 1) * kExcludedBlock), ox, oy, oz);
      },
      out);
}

std::vector<std::uint32_t>& NonbondedPairTerm::record_inside_masks(const Coords& q, bool single) {
  InsideMasks* slot = nullptr;
  for (auto& c : inside_cache_)
    if (c.list_version == list_version() && c.single == single && same_positions(c.q, q)) slot = &c;
  if (!slot) {
    if (inside_cache_.size() < kHessianCacheSlots) {
      slot = &inside_cache_.emplace_back();
    } else {
      slot = &*std::min_element(inside_cache_.begin(), inside_cache_.end(),
                                [](const InsideMasks& a, const InsideMasks& b) { return a.last_used < b.last_used; });
    }
    slot->list_version = list_version();
    slot->single = single;
    slot->q = q;
  }
  slot->last_used = ++cache_clock_;
  slot->masks.resize(entries().size());
  return slot->masks;
}

const std::uint32_t* NonbondedPairTerm::find_inside_masks(const Coords& q, bool single) {
  // A single-precision product also takes a double-precision pass's masks (exact decisions, where
  // its own could differ only for pairs within float rounding of the cut-off): the variational
  // solve's products after double-precision stages then skip their mask pass.
  InsideMasks* found = nullptr;
  for (auto& c : inside_cache_)
    if (c.list_version == list_version() && (single || !c.single) && same_positions(c.q, q))
      if (!found || c.single == single) found = &c;
  if (!found) return nullptr;
  found->last_used = ++cache_clock_;
  return found->masks.data();
}

bool NonbondedPairTerm::same_positions(const Coords& a, const Coords& b) {
  return a.cols() == b.cols() && std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0;
}

}  // namespace vimd
