#include "forcefields/nonbonded_pair_term.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "engine/errors.hpp"

namespace vimd {

namespace {

constexpr int kC = NeighborList::kClusterSize;
constexpr int kH = NeighborList::kHalfSize;

// Everything the inner loops read, as plain pointers.
struct PairView {
  const double *x, *y, *z;
  const double* charge;
  const int* type;
  const double *c6, *c12;
  int n_types;
  const NeighborList::Entry* entries;
  const int* half_start;
  const Vec3* shifts;
  const NeighborList::ExcludedPair* excluded;
  double cutoff2;
  LjConstants lj;
  ReactionField rf;
};

// Forces of the i-halves [h0, h1) into the SoA buffer (fx, fy, fz); the energies of half h into
// half_lj[h], half_coulomb[h], so that their total can be summed in an order that does not depend
// on the thread count (the Coulomb sum cancels strongly and would otherwise show it).
template <VdwModifier M, bool kCoulomb>
void force_halves(const PairView& d, int h0, int h1, double* fx, double* fy, double* fz, double* half_lj,
                  double* half_coulomb) {
  for (int h = h0; h < h1; ++h) {
    const int e0 = d.half_start[h], e1 = d.half_start[h + 1];
    half_lj[h] = half_coulomb[h] = 0;
    if (e0 == e1) continue;
    alignas(64) double lane_lj[kC] = {}, lane_coulomb[kC] = {};
    const int ib = h * kH;
    double xi[kH], yi[kH], zi[kH], qi[kH];
    int row[kH];
    for (int ii = 0; ii < kH; ++ii) {
      xi[ii] = d.x[ib + ii];
      yi[ii] = d.y[ib + ii];
      zi[ii] = d.z[ib + ii];
      qi[ii] = d.rf.prefactor * d.charge[ib + ii];
      row[ii] = d.type[ib + ii] * d.n_types;
    }
    alignas(64) double fxi[kH][kC] = {}, fyi[kH][kC] = {}, fzi[kH][kC] = {};
    for (int e = e0; e < e1; ++e) {
      const NeighborList::Entry entry = d.entries[e];
      const int jb = entry.j_cluster * kC;
      const Vec3& shift = d.shifts[entry.shift];
      const double* xj = d.x + jb;
      const double* yj = d.y + jb;
      const double* zj = d.z + jb;
      const double* qj = d.charge + jb;
      const int* tj = d.type + jb;
      alignas(64) double fxj[kC] = {}, fyj[kC] = {}, fzj[kC] = {};
      for (int ii = 0; ii < kH; ++ii) {
        const unsigned bits = (entry.mask >> (ii * kC)) & 0xffu;
        if (bits == 0) continue;
        const double xs = xi[ii] - shift[0], ys = yi[ii] - shift[1], zs = zi[ii] - shift[2];
        const double* c6row = d.c6 + row[ii];
        const double* c12row = d.c12 + row[ii];
        const double qqi = qi[ii];
#pragma omp simd
        for (int jj = 0; jj < kC; ++jj) {
          const double dx = xs - xj[jj], dy = ys - yj[jj], dz = zs - zj[jj];
          const double r2 = dx * dx + dy * dy + dz * dz;
          const bool inside = ((bits >> jj) & 1u) && r2 < d.cutoff2;
          const double r2s = inside ? r2 : 1.0;  // keeps masked lanes finite (r = 0 on the diagonal)
          const double rinv = 1.0 / std::sqrt(r2s);
          const double rinv2 = rinv * rinv;
          double v, g;
          lj_energy_force<M>(d.lj, c6row[tj[jj]], c12row[tj[jj]], rinv2, r2s * rinv, v, g);
          double vc = 0, gc = 0;
          if constexpr (kCoulomb) rf_energy_force(d.rf, qqi * qj[jj], rinv, r2s, vc, gc);
          const double gt = inside ? g + gc : 0.0;
          lane_lj[jj] += inside ? v : 0.0;
          lane_coulomb[jj] += inside ? vc : 0.0;
          const double fx_ = gt * dx, fy_ = gt * dy, fz_ = gt * dz;
          fxi[ii][jj] += fx_;
          fyi[ii][jj] += fy_;
          fzi[ii][jj] += fz_;
          fxj[jj] -= fx_;
          fyj[jj] -= fy_;
          fzj[jj] -= fz_;
        }
      }
#pragma omp simd
      for (int jj = 0; jj < kC; ++jj) {
        fx[jb + jj] += fxj[jj];
        fy[jb + jj] += fyj[jj];
        fz[jb + jj] += fzj[jj];
      }
    }
    for (int ii = 0; ii < kH; ++ii) {
      double sx = 0, sy = 0, sz = 0;
      for (int jj = 0; jj < kC; ++jj) {
        sx += fxi[ii][jj];
        sy += fyi[ii][jj];
        sz += fzi[ii][jj];
      }
      fx[ib + ii] += sx;
      fy[ib + ii] += sy;
      fz[ib + ii] += sz;
    }
    for (int jj = 0; jj < kC; ++jj) {
      half_lj[h] += lane_lj[jj];
      half_coulomb[h] += lane_coulomb[jj];
    }
  }
}

// (∇²V u) of the i-halves [h0, h1) into the SoA buffer (ox, oy, oz).
template <VdwModifier M, bool kCoulomb>
void hessian_halves(const PairView& d, const double* ux, const double* uy, const double* uz, int h0, int h1,
                    double* ox, double* oy, double* oz) {
  for (int h = h0; h < h1; ++h) {
    const int e0 = d.half_start[h], e1 = d.half_start[h + 1];
    if (e0 == e1) continue;
    const int ib = h * kH;
    double xi[kH], yi[kH], zi[kH], qi[kH], uxi[kH], uyi[kH], uzi[kH];
    int row[kH];
    for (int ii = 0; ii < kH; ++ii) {
      xi[ii] = d.x[ib + ii];
      yi[ii] = d.y[ib + ii];
      zi[ii] = d.z[ib + ii];
      uxi[ii] = ux[ib + ii];
      uyi[ii] = uy[ib + ii];
      uzi[ii] = uz[ib + ii];
      qi[ii] = d.rf.prefactor * d.charge[ib + ii];
      row[ii] = d.type[ib + ii] * d.n_types;
    }
    alignas(64) double oxi[kH][kC] = {}, oyi[kH][kC] = {}, ozi[kH][kC] = {};
    for (int e = e0; e < e1; ++e) {
      const NeighborList::Entry entry = d.entries[e];
      const int jb = entry.j_cluster * kC;
      const Vec3& shift = d.shifts[entry.shift];
      const double* xj = d.x + jb;
      const double* yj = d.y + jb;
      const double* zj = d.z + jb;
      const double* uxj = ux + jb;
      const double* uyj = uy + jb;
      const double* uzj = uz + jb;
      const double* qj = d.charge + jb;
      const int* tj = d.type + jb;
      alignas(64) double oxj[kC] = {}, oyj[kC] = {}, ozj[kC] = {};
      for (int ii = 0; ii < kH; ++ii) {
        const unsigned bits = (entry.mask >> (ii * kC)) & 0xffu;
        if (bits == 0) continue;
        const double xs = xi[ii] - shift[0], ys = yi[ii] - shift[1], zs = zi[ii] - shift[2];
        const double* c6row = d.c6 + row[ii];
        const double* c12row = d.c12 + row[ii];
        const double qqi = qi[ii];
#pragma omp simd
        for (int jj = 0; jj < kC; ++jj) {
          const double dx = xs - xj[jj], dy = ys - yj[jj], dz = zs - zj[jj];
          const double r2 = dx * dx + dy * dy + dz * dz;
          const bool inside = ((bits >> jj) & 1u) && r2 < d.cutoff2;
          const double r2s = inside ? r2 : 1.0;
          const double rinv = 1.0 / std::sqrt(r2s);
          const double rinv2 = rinv * rinv;
          double a, b;
          lj_hessian<M>(d.lj, c6row[tj[jj]], c12row[tj[jj]], rinv2, r2s * rinv, a, b);
          if constexpr (kCoulomb) {
            double ac, bc;
            rf_hessian(d.rf, qqi * qj[jj], rinv, ac, bc);
            a += ac;
            b += bc;
          }
          const double dux = uxi[ii] - uxj[jj], duy = uyi[ii] - uyj[jj], duz = uzi[ii] - uzj[jj];
          const double bp = inside ? b * (dx * dux + dy * duy + dz * duz) : 0.0;
          const double am = inside ? a : 0.0;
          const double hx = am * dux + bp * dx, hy = am * duy + bp * dy, hz = am * duz + bp * dz;
          oxi[ii][jj] += hx;
          oyi[ii][jj] += hy;
          ozi[ii][jj] += hz;
          oxj[jj] -= hx;
          oyj[jj] -= hy;
          ozj[jj] -= hz;
        }
      }
#pragma omp simd
      for (int jj = 0; jj < kC; ++jj) {
        ox[jb + jj] += oxj[jj];
        oy[jb + jj] += oyj[jj];
        oz[jb + jj] += ozj[jj];
      }
    }
    for (int ii = 0; ii < kH; ++ii) {
      double sx = 0, sy = 0, sz = 0;
      for (int jj = 0; jj < kC; ++jj) {
        sx += oxi[ii][jj];
        sy += oyi[ii][jj];
        sz += ozi[ii][jj];
      }
      ox[ib + ii] += sx;
      oy[ib + ii] += sy;
      oz[ib + ii] += sz;
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
    if (dx * dx + dy * dy + dz * dz >= d.cutoff2) continue;
    const double a = rf_excluded_hessian(d.rf, d.rf.prefactor * d.charge[i] * d.charge[j]);
    const double hx = a * (ux[i] - ux[j]), hy = a * (uy[i] - uy[j]), hz = a * (uz[i] - uz[j]);
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
      lj_(make_lj_constants(modifier_, config.cutoff, config.vdw_switch)),
      rf_(make_reaction_field(config.coulomb, config.epsilon_r, config.epsilon_rf, config.cutoff)),
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
  if (rf_.kind == CoulombKind::reaction_field) self_energy_ = rf_self_energy(rf_, charge_.squaredNorm());
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
  layout_build_ = list_.builds();
}

void NonbondedPairTerm::ensure_buffers() {
  const std::size_t size = 3 * static_cast<std::size_t>(list_.n_slots());
  thread_buffers_.resize(omp_get_max_threads());
  for (auto& b : thread_buffers_)
    if (b.size() != size) b.resize(size);
}

// Runs kernel(thread, n_threads, fx, fy, fz) on every thread with a zeroed private buffer, then
// adds the buffers, in thread order, to out.
template <class Kernel>
void NonbondedPairTerm::run_parallel(Kernel&& kernel, Coords& out) {
  ensure_buffers();
  const int n = list_.n_slots();
  const auto& slot_atom = list_.slot_atom();
#pragma omp parallel
  {
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
using ForceKernelFn = void (*)(const PairView&, int, int, double*, double*, double*, double*, double*);

template <bool kCoulomb>
ForceKernelFn<kCoulomb> force_kernel(VdwModifier m) {
  switch (m) {
    case VdwModifier::none: return force_halves<VdwModifier::none, kCoulomb>;
    case VdwModifier::potential_shift: return force_halves<VdwModifier::potential_shift, kCoulomb>;
    case VdwModifier::force_switch: return force_halves<VdwModifier::force_switch, kCoulomb>;
    case VdwModifier::potential_switch: return force_halves<VdwModifier::potential_switch, kCoulomb>;
  }
  throw std::logic_error("unknown VdwModifier");
}

using HessianKernelFn = void (*)(const PairView&, const double*, const double*, const double*, int, int, double*,
                                 double*, double*);

template <bool kCoulomb>
HessianKernelFn hessian_kernel(VdwModifier m) {
  switch (m) {
    case VdwModifier::none: return hessian_halves<VdwModifier::none, kCoulomb>;
    case VdwModifier::potential_shift: return hessian_halves<VdwModifier::potential_shift, kCoulomb>;
    case VdwModifier::force_switch: return hessian_halves<VdwModifier::force_switch, kCoulomb>;
    case VdwModifier::potential_switch: return hessian_halves<VdwModifier::potential_switch, kCoulomb>;
  }
  throw std::logic_error("unknown VdwModifier");
}

// Excluded pairs go in fixed blocks (independent of the thread count, like the per-half energies).
constexpr int kExcludedBlock = 1024;

}  // namespace

void NonbondedPairTerm::add_forces(const Coords& q, Coords& f, std::span<double> energies) {
  prepare(q);
  list_.pack_positions(q, x_.data(), y_.data(), z_.data());
  const PairView view{x_.data(),  y_.data(),  z_.data(),  slot_charge_.data(), slot_type_.data(),
                      c6_.data(), c12_.data(), n_types_,  list_.entries().data(), list_.half_start().data(),
                      list_.shift_vectors().data(), list_.excluded_pairs().data(), cutoff2_, lj_, rf_};
  const bool coulomb = rf_.kind == CoulombKind::reaction_field;
  const auto pair_kernel = coulomb ? force_kernel<true>(modifier_) : force_kernel<false>(modifier_);
  const int n_excluded = coulomb ? static_cast<int>(list_.excluded_pairs().size()) : 0;
  const auto& half_start = list_.half_start();
  const int n_halves = list_.n_halves();
  const int n_blocks = (n_excluded + kExcludedBlock - 1) / kExcludedBlock;
  partial_energies_.assign(2 * n_halves + n_blocks, 0.0);
  double* half_lj = partial_energies_.data();
  double* half_coulomb = half_lj + n_halves;
  double* block_coulomb = half_coulomb + n_halves;
  run_parallel(
      [&](int t, int nt, double* fx, double* fy, double* fz) {
        const auto [h0, h1] = half_block(half_start, t, nt);
        pair_kernel(view, h0, h1, fx, fy, fz, half_lj, half_coulomb);
        for (int b = t; b < n_blocks; b += nt)
          block_coulomb[b] = excluded_forces(view, b * kExcludedBlock, std::min(n_excluded, (b + 1) * kExcludedBlock), fx, fy, fz);
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
  prepare(q);
  list_.pack_positions(q, x_.data(), y_.data(), z_.data());
  list_.pack_vectors(u, ux_.data(), uy_.data(), uz_.data());
  const PairView view{x_.data(),  y_.data(),  z_.data(),  slot_charge_.data(), slot_type_.data(),
                      c6_.data(), c12_.data(), n_types_,  list_.entries().data(), list_.half_start().data(),
                      list_.shift_vectors().data(), list_.excluded_pairs().data(), cutoff2_, lj_, rf_};
  const bool coulomb = rf_.kind == CoulombKind::reaction_field;
  const auto pair_kernel = coulomb ? hessian_kernel<true>(modifier_) : hessian_kernel<false>(modifier_);
  const int n_excluded = coulomb ? static_cast<int>(list_.excluded_pairs().size()) : 0;
  const auto& half_start = list_.half_start();
  const int n_blocks = (n_excluded + kExcludedBlock - 1) / kExcludedBlock;
  run_parallel(
      [&](int t, int nt, double* ox, double* oy, double* oz) {
        const auto [h0, h1] = half_block(half_start, t, nt);
        pair_kernel(view, ux_.data(), uy_.data(), uz_.data(), h0, h1, ox, oy, oz);
        for (int b = t; b < n_blocks; b += nt)
          excluded_hessian(view, ux_.data(), uy_.data(), uz_.data(), b * kExcludedBlock,
                           std::min(n_excluded, (b + 1) * kExcludedBlock), ox, oy, oz);
      },
      out);
}

}  // namespace vimd
