#include "forcefields/nonbonded_pair_term.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "engine/errors.hpp"

namespace vimd {

namespace {

constexpr int kC = NeighborList::kClusterSize;
constexpr int kH = NeighborList::kHalfSize;
static_assert(kC == kSimdWidth, "a j-cluster is one SIMD vector");

// Everything the inner loops read, as plain pointers. Positions, charges and LJ parameters are in
// slot order; lj_c6[t * n_slots + s] is c6 between type t and the atom in slot s (likewise c12),
// so a j-cluster's parameters for an i atom are one contiguous vector load.
struct PairView {
  const double *x, *y, *z;
  const double* charge;
  const int* type;
  const double *lj_c6, *lj_c12;
  std::size_t n_slots;
  const NeighborList::Entry* entries;
  const int* half_start;
  const Vec3* shifts;
  const NeighborList::ExcludedPair* excluded;
  double cutoff2;
  LjConstants lj;
  ReactionField rf;
};

// Lanes of an entry's mask row (8 bits) that interact and are inside the cut-off.
inline SimdMask lanes_inside(unsigned row_bits, SimdDouble r2, double cutoff2) {
  const SimdMask lane_bit = {1, 2, 4, 8, 16, 32, 64, 128};
  return (((SimdMask{} + static_cast<std::int64_t>(row_bits)) & lane_bit) != 0) & (r2 < cutoff2);
}

// The i-half's atoms, loaded once per half. The i sums stay in registers over the whole half; each
// j-cluster is updated once per entry.
struct HalfData {
  double x[kH], y[kH], z[kH], q[kH];
  const double *c6[kH], *c12[kH];
};

// Forces of the i-halves [h0, h1) into the SoA buffer (fx, fy, fz); the energies of half h into
// half_lj[h], half_coulomb[h], so that their total can be summed in an order that does not depend
// on the thread count (the Coulomb sum cancels strongly and would otherwise show it).
// If inside_masks is not null, inside_masks[e] receives the bits of entry e's pairs that were
// inside the cut-off.
template <VdwModifier M, bool kCoulomb, CoulombModifier C>
void force_halves(const PairView& d, int h0, int h1, double* fx, double* fy, double* fz, double* half_lj,
                  double* half_coulomb, std::uint32_t* inside_masks) {
  const SimdDouble one = simd_broadcast(1.0), zero{};
  for (int h = h0; h < h1; ++h) {
    const int e0 = d.half_start[h], e1 = d.half_start[h + 1];
    half_lj[h] = half_coulomb[h] = 0;
    if (e0 == e1) continue;
    const int ib = h * kH;
    HalfData hi;
    for (int ii = 0; ii < kH; ++ii) {
      hi.x[ii] = d.x[ib + ii];
      hi.y[ii] = d.y[ib + ii];
      hi.z[ii] = d.z[ib + ii];
      hi.q[ii] = d.rf.prefactor * d.charge[ib + ii];
      hi.c6[ii] = d.lj_c6 + d.type[ib + ii] * d.n_slots;
      hi.c12[ii] = d.lj_c12 + d.type[ib + ii] * d.n_slots;
    }
    SimdDouble fxi[kH] = {}, fyi[kH] = {}, fzi[kH] = {};
    SimdDouble e_lj = zero, e_coulomb = zero;
    for (int e = e0; e < e1; ++e) {
      const NeighborList::Entry entry = d.entries[e];
      const int jb = entry.j_cluster * kC;
      const Vec3& shift = d.shifts[entry.shift];
      const SimdDouble xj = simd_load(d.x + jb) + shift[0], yj = simd_load(d.y + jb) + shift[1],
                       zj = simd_load(d.z + jb) + shift[2];
      const SimdDouble qj = simd_load(d.charge + jb);
      SimdDouble fxj = zero, fyj = zero, fzj = zero;
      std::uint32_t inside_bits = 0;
#pragma GCC unroll 4  // keeps the i sums in registers
      for (int ii = 0; ii < kH; ++ii) {
        const unsigned bits = (entry.mask >> (ii * kC)) & 0xffu;
        if (bits == 0) continue;
        const SimdDouble dx = hi.x[ii] - xj, dy = hi.y[ii] - yj, dz = hi.z[ii] - zj;
        const SimdDouble r2 = dx * dx + dy * dy + dz * dz;
        const SimdMask inside = lanes_inside(bits, r2, d.cutoff2);
        if (inside_masks) inside_bits |= simd_bits(inside) << (ii * kC);
        const SimdDouble r2s = select(inside, r2, one);  // keeps masked lanes finite (r = 0 on the diagonal)
        const SimdDouble rinv = 1.0 / simd_sqrt(r2s);
        const SimdDouble rinv2 = rinv * rinv;
        SimdDouble v, g;
        lj_energy_force<M>(d.lj, simd_load(hi.c6[ii] + jb), simd_load(hi.c12[ii] + jb), rinv2, r2s * rinv, v, g);
        e_lj += select(inside, v, zero);
        if constexpr (kCoulomb) {
          SimdDouble vc, gc;
          rf_energy_force<C>(d.rf, hi.q[ii] * qj, rinv, r2s, vc, gc);
          e_coulomb += select(inside, vc, zero);
          g += gc;
        }
        g = select(inside, g, zero);
        const SimdDouble gx = g * dx, gy = g * dy, gz = g * dz;
        fxi[ii] += gx;
        fyi[ii] += gy;
        fzi[ii] += gz;
        fxj -= gx;
        fyj -= gy;
        fzj -= gz;
      }
      simd_store(fx + jb, simd_load(fx + jb) + fxj);
      simd_store(fy + jb, simd_load(fy + jb) + fyj);
      simd_store(fz + jb, simd_load(fz + jb) + fzj);
      if (inside_masks) inside_masks[e] = inside_bits;
    }
    for (int ii = 0; ii < kH; ++ii) {
      fx[ib + ii] += simd_sum(fxi[ii]);
      fy[ib + ii] += simd_sum(fyi[ii]);
      fz[ib + ii] += simd_sum(fzi[ii]);
    }
    half_lj[h] = simd_sum(e_lj);
    half_coulomb[h] = simd_sum(e_coulomb);
  }
}

// (∇²V u) of the i-halves [h0, h1) into the SoA buffer (ox, oy, oz): per pair a u_ij + b (d·u_ij) d.
// masks[e] selects the pairs of entry e: the list's own masks, or the inside-cut-off masks that a
// force evaluation at the same positions recorded (rows without such pairs are then skipped; the
// skipped rows contribute exact zeros otherwise, so both give identical results).
template <VdwModifier M, bool kCoulomb, CoulombModifier C>
void hessian_halves(const PairView& d, const double* ux, const double* uy, const double* uz, const std::uint32_t* masks,
                    int h0, int h1, double* ox, double* oy, double* oz) {
  const SimdDouble one = simd_broadcast(1.0), zero{};
  for (int h = h0; h < h1; ++h) {
    const int e0 = d.half_start[h], e1 = d.half_start[h + 1];
    if (e0 == e1) continue;
    const int ib = h * kH;
    HalfData hi;
    double uxi[kH], uyi[kH], uzi[kH];
    for (int ii = 0; ii < kH; ++ii) {
      hi.x[ii] = d.x[ib + ii];
      hi.y[ii] = d.y[ib + ii];
      hi.z[ii] = d.z[ib + ii];
      hi.q[ii] = d.rf.prefactor * d.charge[ib + ii];
      hi.c6[ii] = d.lj_c6 + d.type[ib + ii] * d.n_slots;
      hi.c12[ii] = d.lj_c12 + d.type[ib + ii] * d.n_slots;
      uxi[ii] = ux[ib + ii];
      uyi[ii] = uy[ib + ii];
      uzi[ii] = uz[ib + ii];
    }
    SimdDouble oxi[kH] = {}, oyi[kH] = {}, ozi[kH] = {};
    for (int e = e0; e < e1; ++e) {
      const NeighborList::Entry entry = d.entries[e];
      const int jb = entry.j_cluster * kC;
      const Vec3& shift = d.shifts[entry.shift];
      const SimdDouble xj = simd_load(d.x + jb) + shift[0], yj = simd_load(d.y + jb) + shift[1],
                       zj = simd_load(d.z + jb) + shift[2];
      const SimdDouble uxj = simd_load(ux + jb), uyj = simd_load(uy + jb), uzj = simd_load(uz + jb);
      const SimdDouble qj = simd_load(d.charge + jb);
      SimdDouble oxj = zero, oyj = zero, ozj = zero;
#pragma GCC unroll 4  // keeps the i sums in registers
      for (int ii = 0; ii < kH; ++ii) {
        const unsigned bits = (masks[e] >> (ii * kC)) & 0xffu;
        if (bits == 0) continue;
        const SimdDouble dx = hi.x[ii] - xj, dy = hi.y[ii] - yj, dz = hi.z[ii] - zj;
        const SimdDouble r2 = dx * dx + dy * dy + dz * dz;
        const SimdMask inside = lanes_inside(bits, r2, d.cutoff2);
        const SimdDouble r2s = select(inside, r2, one);
        const SimdDouble rinv = 1.0 / simd_sqrt(r2s);
        const SimdDouble rinv2 = rinv * rinv;
        SimdDouble a, b;
        lj_hessian<M>(d.lj, simd_load(hi.c6[ii] + jb), simd_load(hi.c12[ii] + jb), rinv2, r2s * rinv, a, b);
        if constexpr (kCoulomb) {
          SimdDouble ac, bc;
          rf_hessian<C>(d.rf, hi.q[ii] * qj, rinv, r2s, ac, bc);
          a += ac;
          b += bc;
        }
        a = select(inside, a, zero);
        b = select(inside, b, zero);
        const SimdDouble dux = uxi[ii] - uxj, duy = uyi[ii] - uyj, duz = uzi[ii] - uzj;
        const SimdDouble bp = b * (dx * dux + dy * duy + dz * duz);
        const SimdDouble hx = a * dux + bp * dx, hy = a * duy + bp * dy, hz = a * duz + bp * dz;
        oxi[ii] += hx;
        oyi[ii] += hy;
        ozi[ii] += hz;
        oxj -= hx;
        oyj -= hy;
        ozj -= hz;
      }
      simd_store(ox + jb, simd_load(ox + jb) + oxj);
      simd_store(oy + jb, simd_load(oy + jb) + oyj);
      simd_store(oz + jb, simd_load(oz + jb) + ozj);
    }
    for (int ii = 0; ii < kH; ++ii) {
      ox[ib + ii] += simd_sum(oxi[ii]);
      oy[ib + ii] += simd_sum(oyi[ii]);
      oz[ib + ii] += simd_sum(ozi[ii]);
    }
  }
}

// Reaction-field terms of the excluded pairs [p0, p1) (GROMACS keeps k_rf r² − c_rf for them).
double excluded_forces(const PairView& d, int p0, int p1, double* fx, double* fy, double* fz) {
  double e_coulomb = 0;
  for (int p = p0; p < p1; ++p) {
    const NeighborList::ExcludedPair& pair = d.excluded[p];
    const Vec3& shift = d.shifts[pair.shift];
    const int i = pair.i_slot, j = pair.j_slot;
    const double dx = d.x[i] - d.x[j] - shift[0], dy = d.y[i] - d.y[j] - shift[1], dz = d.z[i] - d.z[j] - shift[2];
    const double r2 = dx * dx + dy * dy + dz * dz;
    if (r2 >= d.cutoff2) continue;
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

void excluded_hessian(const PairView& d, const double* ux, const double* uy, const double* uz, int p0, int p1,
                      double* ox, double* oy, double* oz) {
  for (int p = p0; p < p1; ++p) {
    const NeighborList::ExcludedPair& pair = d.excluded[p];
    const Vec3& shift = d.shifts[pair.shift];
    const int i = pair.i_slot, j = pair.j_slot;
    const double dx = d.x[i] - d.x[j] - shift[0], dy = d.y[i] - d.y[j] - shift[1], dz = d.z[i] - d.z[j] - shift[2];
    const double r2 = dx * dx + dy * dy + dz * dz;
    if (r2 >= d.cutoff2) continue;
    double a, b;  // b ≠ 0 only where a switch acts
    rf_excluded_hessian(d.rf, d.rf.prefactor * d.charge[i] * d.charge[j], r2, a, b);
    const double dux = ux[i] - ux[j], duy = uy[i] - uy[j], duz = uz[i] - uz[j];
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

// i-halves of thread t when nt threads share the list, balanced by entry count.
std::pair<int, int> half_block(const std::vector<int>& half_start, int t, int nt) {
  const long total = half_start.back();
  auto boundary = [&](int k) {
    if (k == 0) return 0;
    if (k == nt) return static_cast<int>(half_start.size()) - 1;
    const long target = total * k / nt;
    return static_cast<int>(std::lower_bound(half_start.begin(), half_start.end(), target) - half_start.begin());
  };
  return {boundary(t), boundary(t + 1)};
}

}  // namespace

NonbondedPairTerm::NonbondedPairTerm(const System& system, const ForceFieldConfig& config)
    : n_atoms_(system.n_atoms()),
      modifier_(parse_vdw_modifier(config.vdw_modifier)),
      lj_(make_lj_constants(modifier_, config.cutoff, config.vdw_switch, config.switch_smoothness)),
      rf_(make_reaction_field(config.coulomb, config.epsilon_r, config.epsilon_rf, config.cutoff,
                              config.coulomb_modifier, config.coulomb_switch, config.switch_smoothness)),
      cutoff2_(config.cutoff * config.cutoff),
      n_types_(static_cast<int>(system.c6.rows())),
      charge_(system.charge),
      type_(system.type),
      list_(system.box, config.cutoff, config.neighbor_skin, system.exclusions) {
  if (system.c6.rows() != system.c6.cols() || system.c12.rows() != n_types_ || system.c12.cols() != n_types_)
    throw std::invalid_argument("NonbondedPairTerm: c6/c12 must be square matrices of the same size");
  if (static_cast<int>(type_.size()) != n_atoms_ || charge_.size() != n_atoms_)
    throw std::invalid_argument("NonbondedPairTerm: type and charge need one entry per atom");
  for (int t : type_)
    if (t < 0 || t >= n_types_) throw std::invalid_argument("NonbondedPairTerm: atom type index out of range");
  c6_.resize(static_cast<std::size_t>(n_types_) * n_types_);
  c12_.resize(c6_.size());
  for (int a = 0; a < n_types_; ++a)
    for (int b = 0; b < n_types_; ++b) {
      c6_[a * n_types_ + b] = system.c6(a, b);
      c12_[a * n_types_ + b] = system.c12(a, b);
    }
  double sum_q2 = 0;  // a plain loop: Eigen's AVX-512 reduction trips a GCC 12 false-positive warning
  for (double qi : charge_) sum_q2 += qi * qi;
  if (rf_.kind == CoulombKind::reaction_field) self_energy_ = rf_self_energy(rf_, sum_q2);
}

void NonbondedPairTerm::prepare(const Coords& q) {
  if (q.cols() != n_atoms_)
    throw std::invalid_argument("NonbondedPairTerm: " + std::to_string(q.cols()) + " positions for " +
                                std::to_string(n_atoms_) + " atoms");
  list_.update(q);
  refresh_layout();
}

void NonbondedPairTerm::refresh_layout() {
  if (layout_build_ == list_.builds()) return;
  const int n = list_.n_slots();
  slot_charge_.assign(n, 0.0);
  slot_type_.assign(n, 0);
  const auto& slot_atom = list_.slot_atom();
  for (int s = 0; s < n; ++s) {
    const int a = slot_atom[s];
    if (a < 0) continue;
    slot_charge_[s] = charge_[a];
    slot_type_[s] = type_[a];
  }
  for (auto* v : {&x_, &y_, &z_, &ux_, &uy_, &uz_}) v->resize(n);
  slot_c6_.assign(static_cast<std::size_t>(n_types_) * n, 0.0);
  slot_c12_.assign(slot_c6_.size(), 0.0);
  for (int t = 0; t < n_types_; ++t)
    for (int s = 0; s < n; ++s) {
      if (slot_atom[s] < 0) continue;
      slot_c6_[static_cast<std::size_t>(t) * n + s] = c6_[t * n_types_ + slot_type_[s]];
      slot_c12_[static_cast<std::size_t>(t) * n + s] = c12_[t * n_types_ + slot_type_[s]];
    }
  layout_build_ = list_.builds();
}

void NonbondedPairTerm::ensure_buffers() {
  const std::size_t size = 3 * static_cast<std::size_t>(list_.n_slots());
  thread_buffers_.resize(omp_get_max_threads());
  for (auto& b : thread_buffers_)
    if (b.size() != size) b.resize(size);
}

// Runs pack() (worksharing loops that fill the slot arrays), then kernel(thread, n_threads, fx, fy,
// fz) on every thread with a zeroed private buffer, then adds the buffers, in thread order, to out:
// one parallel region per evaluation.
template <class Pack, class Kernel>
void NonbondedPairTerm::run_parallel(Pack&& pack, Kernel&& kernel, Coords& out) {
  ensure_buffers();
  const int n = list_.n_slots();
  const auto& slot_atom = list_.slot_atom();
  // Small lists run on one thread: starting a team would cost more than the pairs.
  constexpr std::size_t kParallelEntries = 2048;
#pragma omp parallel if (list_.entries().size() >= kParallelEntries)
  {
    pack();
    const int t = omp_get_thread_num(), nt = omp_get_num_threads();
    double* buffer = thread_buffers_[t].data();
    std::fill(buffer, buffer + 3 * static_cast<std::size_t>(n), 0.0);
    kernel(t, nt, buffer, buffer + n, buffer + 2 * n);
#pragma omp barrier
#pragma omp for schedule(static)
    for (int s = 0; s < n; ++s) {
      const int a = slot_atom[s];
      if (a < 0) continue;
      double sx = 0, sy = 0, sz = 0;
      for (int k = 0; k < nt; ++k) {
        const double* b = thread_buffers_[k].data();
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

template <bool kCoulomb>
using ForceKernelFn = void (*)(const PairView&, int, int, double*, double*, double*, double*, double*, std::uint32_t*);

template <bool kCoulomb, CoulombModifier C>
ForceKernelFn<kCoulomb> force_kernel(VdwModifier m) {
  switch (m) {
    case VdwModifier::none:
      return force_halves<VdwModifier::none, kCoulomb, C>;
    case VdwModifier::potential_shift:
      return force_halves<VdwModifier::potential_shift, kCoulomb, C>;
    case VdwModifier::force_switch:
      return force_halves<VdwModifier::force_switch, kCoulomb, C>;
    case VdwModifier::potential_switch:
      return force_halves<VdwModifier::potential_switch, kCoulomb, C>;
  }
  throw std::logic_error("unknown VdwModifier");
}

using HessianKernelFn = void (*)(const PairView&, const double*, const double*, const double*, const std::uint32_t*,
                                 int, int, double*, double*, double*);

template <bool kCoulomb, CoulombModifier C>
HessianKernelFn hessian_kernel(VdwModifier m) {
  switch (m) {
    case VdwModifier::none:
      return hessian_halves<VdwModifier::none, kCoulomb, C>;
    case VdwModifier::potential_shift:
      return hessian_halves<VdwModifier::potential_shift, kCoulomb, C>;
    case VdwModifier::force_switch:
      return hessian_halves<VdwModifier::force_switch, kCoulomb, C>;
    case VdwModifier::potential_switch:
      return hessian_halves<VdwModifier::potential_switch, kCoulomb, C>;
  }
  throw std::logic_error("unknown VdwModifier");
}

// Excluded pairs go in fixed blocks (independent of the thread count, like the per-half energies).
constexpr int kExcludedBlock = 1024;

}  // namespace

void NonbondedPairTerm::add_forces(const Coords& q, Coords& f, std::span<double> energies) {
  prepare(q);
  const PairView view{x_.data(),
                      y_.data(),
                      z_.data(),
                      slot_charge_.data(),
                      slot_type_.data(),
                      slot_c6_.data(),
                      slot_c12_.data(),
                      static_cast<std::size_t>(list_.n_slots()),
                      list_.entries().data(),
                      list_.half_start().data(),
                      list_.shift_vectors().data(),
                      list_.excluded_pairs().data(),
                      cutoff2_,
                      lj_,
                      rf_};
  const bool coulomb = rf_.kind == CoulombKind::reaction_field;
  const auto pair_kernel = !coulomb ? force_kernel<false, CoulombModifier::none>(modifier_)
                           : rf_.modifier == CoulombModifier::none
                               ? force_kernel<true, CoulombModifier::none>(modifier_)
                               : force_kernel<true, CoulombModifier::potential_switch>(modifier_);
  const int n_excluded = coulomb ? static_cast<int>(list_.excluded_pairs().size()) : 0;
  const auto& half_start = list_.half_start();
  const int n_halves = list_.n_halves();
  const int n_blocks = (n_excluded + kExcludedBlock - 1) / kExcludedBlock;
  partial_energies_.assign(2 * n_halves + n_blocks, 0.0);
  double* half_lj = partial_energies_.data();
  double* half_coulomb = half_lj + n_halves;
  double* block_coulomb = half_coulomb + n_halves;
  std::uint32_t* inside_masks = hessian_requested_ ? record_inside_masks(q).data() : nullptr;
  run_parallel([&] { list_.pack_positions(q, x_.data(), y_.data(), z_.data()); },
               [&](int t, int nt, double* fx, double* fy, double* fz) {
                 const auto [h0, h1] = half_block(half_start, t, nt);
                 pair_kernel(view, h0, h1, fx, fy, fz, half_lj, half_coulomb, inside_masks);
                 for (int b = t; b < n_blocks; b += nt)
                   block_coulomb[b] = excluded_forces(view, b * kExcludedBlock,
                                                      std::min(n_excluded, (b + 1) * kExcludedBlock), fx, fy, fz);
               },
               f);
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
  const PairView view{x_.data(),
                      y_.data(),
                      z_.data(),
                      slot_charge_.data(),
                      slot_type_.data(),
                      slot_c6_.data(),
                      slot_c12_.data(),
                      static_cast<std::size_t>(list_.n_slots()),
                      list_.entries().data(),
                      list_.half_start().data(),
                      list_.shift_vectors().data(),
                      list_.excluded_pairs().data(),
                      cutoff2_,
                      lj_,
                      rf_};
  const bool coulomb = rf_.kind == CoulombKind::reaction_field;
  const auto pair_kernel = !coulomb ? hessian_kernel<false, CoulombModifier::none>(modifier_)
                           : rf_.modifier == CoulombModifier::none
                               ? hessian_kernel<true, CoulombModifier::none>(modifier_)
                               : hessian_kernel<true, CoulombModifier::potential_switch>(modifier_);
  const int n_excluded = coulomb ? static_cast<int>(list_.excluded_pairs().size()) : 0;
  const auto& half_start = list_.half_start();
  const int n_blocks = (n_excluded + kExcludedBlock - 1) / kExcludedBlock;
  const std::uint32_t* masks = find_inside_masks(q);
  if (masks) {
    ++hessian_cache_hits_;
  } else {
    list_masks_.resize(list_.entries().size());
    for (std::size_t e = 0; e < list_masks_.size(); ++e) list_masks_[e] = list_.entries()[e].mask;
    masks = list_masks_.data();
  }
  run_parallel(
      [&] {
        list_.pack_positions(q, x_.data(), y_.data(), z_.data());
        list_.pack_vectors(u, ux_.data(), uy_.data(), uz_.data());
      },
      [&](int t, int nt, double* ox, double* oy, double* oz) {
        const auto [h0, h1] = half_block(half_start, t, nt);
        pair_kernel(view, ux_.data(), uy_.data(), uz_.data(), masks, h0, h1, ox, oy, oz);
        for (int b = t; b < n_blocks; b += nt)
          excluded_hessian(view, ux_.data(), uy_.data(), uz_.data(), b * kExcludedBlock,
                           std::min(n_excluded, (b + 1) * kExcludedBlock), ox, oy, oz);
      },
      out);
}

std::vector<std::uint32_t>& NonbondedPairTerm::record_inside_masks(const Coords& q) {
  InsideMasks* slot = nullptr;
  for (auto& c : inside_cache_)
    if (c.build == list_.builds() && same_positions(c.q, q)) slot = &c;
  if (!slot) {
    if (inside_cache_.size() < kHessianCacheSlots) {
      slot = &inside_cache_.emplace_back();
    } else {
      slot = &*std::min_element(inside_cache_.begin(), inside_cache_.end(),
                                [](const InsideMasks& a, const InsideMasks& b) { return a.last_used < b.last_used; });
    }
    slot->build = list_.builds();
    slot->q = q;
  }
  slot->last_used = ++cache_clock_;
  slot->masks.resize(list_.entries().size());
  return slot->masks;
}

const std::uint32_t* NonbondedPairTerm::find_inside_masks(const Coords& q) {
  for (auto& c : inside_cache_)
    if (c.build == list_.builds() && same_positions(c.q, q)) {
      c.last_used = ++cache_clock_;
      return c.masks.data();
    }
  return nullptr;
}

bool NonbondedPairTerm::same_positions(const Coords& a, const Coords& b) {
  return a.cols() == b.cols() && std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0;
}

}  // namespace vimd
