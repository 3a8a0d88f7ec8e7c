// The pair loops over the cluster-pair list, once per SIMD target (Highway's foreach_target
// re-includes this file for each), dispatched at run time. A j-cluster (8 atoms) is processed as
// 8 / lanes vectors of the target's native width; the i-half's force sums stay in registers over
// the whole half, and each j sub-cluster is updated once per list entry.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "forcefields/nonbonded_kernels.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include "forcefields/lennard_jones-inl.h"
#include "forcefields/nonbonded_kernels.hpp"
#include "forcefields/reaction_field-inl.h"
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {
namespace {

constexpr int kC = NeighborList::kClusterSize;
constexpr int kH = NeighborList::kHalfSize;

// The i-half's atoms, loaded once per half.
template <class Real>
struct HalfData {
  Real x[kH], y[kH], z[kH], q[kH];
  const Real *c6[kH], *c12[kH];
  // Rows whose atom has no LJ with any type (water's hydrogens: 2 of 3 rows) skip the LJ terms:
  // they would add exact zeros.
  bool lj[kH];
};

template <class Real>
HWY_INLINE void load_half(const PairViewOf<Real>& d, int h, HalfData<Real>& hi) {
  const int ib = h * kH;
  for (int ii = 0; ii < kH; ++ii) {
    hi.x[ii] = d.x[ib + ii];
    hi.y[ii] = d.y[ib + ii];
    hi.z[ii] = d.z[ib + ii];
    hi.q[ii] = static_cast<Real>(d.rf.prefactor * d.charge[ib + ii]);
    hi.c6[ii] = d.lj_c6 + d.type[ib + ii] * d.n_slots;
    hi.c12[ii] = d.lj_c12 + d.type[ib + ii] * d.n_slots;
    hi.lj[ii] = d.type_has_lj[d.type[ib + ii]] != 0;
  }
}

// kSharedSwitch: LJ and Coulomb are switched by the same S (same r_switch and smoothness); the
// switch is then applied once, to their sum, instead of once for each. Real: the precision of the
// pair arithmetic and of the force sums (float: the single-precision kernel). kEnergies: also the
// energies (without them, half_lj and half_coulomb are not touched).
template <VdwModifier M, bool kCoulomb, CoulombModifier C, bool kSharedSwitch, class Real, bool kEnergies>
void force_halves(const PairViewOf<Real>& d, int h0, int h1, Real* fx, Real* fy, Real* fz, double* half_lj,
                  double* half_coulomb, std::uint32_t* inside_masks) {
  using V = SimdVec<Real>;
  using Mask = SimdMaskOf<Real>;
  const int lanes = V::lanes();
  const unsigned lane_bits = (1u << lanes) - 1;
  const V one = V::broadcast(1.0), zero = V::zero(), cutoff2 = V::broadcast(d.cutoff2);
  for (int h = h0; h < h1; ++h) {
    const int e0 = d.half_start[h], e1 = d.half_start[h + 1];
    if constexpr (kEnergies) half_lj[h] = half_coulomb[h] = 0;
    if (e0 == e1) continue;
    HalfData<Real> hi;
    load_half(d, h, hi);
    V fxi[kH], fyi[kH], fzi[kH];
    for (int ii = 0; ii < kH; ++ii) fxi[ii] = fyi[ii] = fzi[ii] = zero;
    V e_lj = zero, e_coulomb = zero;
    for (int e = e0; e < e1; ++e) {
      const NeighborList::Entry entry = d.entries[e];
      const Vec3& shift = d.shifts[entry.shift];
      const std::uint32_t mask = entry.mask;
      std::uint32_t inside_bits = 0;
      for (int js = 0; js < kC; js += lanes) {
        const int jb = entry.j_cluster * kC + js;
        const V xj = simd_load(d.x + jb) + shift[0], yj = simd_load(d.y + jb) + shift[1],
                zj = simd_load(d.z + jb) + shift[2];
        V fxj = zero, fyj = zero, fzj = zero;
#pragma GCC unroll 4  // the i sums are registers only if their index is a constant
        for (int ii = 0; ii < kH; ++ii) {
          const unsigned bits = (mask >> (ii * kC + js)) & lane_bits;
          if (bits == 0) continue;
          const V dx = V::broadcast(hi.x[ii]) - xj, dy = V::broadcast(hi.y[ii]) - yj, dz = V::broadcast(hi.z[ii]) - zj;
          const V r2 = dx * dx + dy * dy + dz * dz;
          const Mask inside = mask_from_bits<Real>(bits) & (r2 < cutoff2);
          if (inside_masks) inside_bits |= bits_from_mask(inside) << (ii * kC + js);
          const V r2s = select(inside, r2, one);  // keeps masked lanes finite (r = 0 on the diagonal)
          const V rinv = simd_rsqrt(r2s);
          const V rinv2 = rinv * rinv;
          V v, g;
          if constexpr (kSharedSwitch) {
            const V r = r2s * rinv;
            v = g = zero;
            if (hi.lj[ii])
              lj_energy_force<VdwModifier::none>(d.lj, simd_load(hi.c6[ii] + jb), simd_load(hi.c12[ii] + jb), rinv2, r,
                                                 v, g);
            V vc, gc, s, ds;
            rf_energy_force<CoulombModifier::none>(d.rf, hi.q[ii] * simd_load(d.charge + jb), rinv, r2s, vc, gc);
            switch_value_slope(d.lj.sw, r, s, ds);
            apply_switch_factors(s, ds, rinv, v, g);
            apply_switch_factors(s, ds, rinv, vc, gc);
            if constexpr (kEnergies) {
              e_lj += keep(inside, v);
              e_coulomb += keep(inside, vc);
            }
            g += gc;
          } else {
            g = zero;
            if (hi.lj[ii]) {
              lj_energy_force<M>(d.lj, simd_load(hi.c6[ii] + jb), simd_load(hi.c12[ii] + jb), rinv2, r2s * rinv, v, g);
              if constexpr (kEnergies) e_lj += keep(inside, v);
            }
            if constexpr (kCoulomb) {
              V vc;
              rf_add_energy_force<C>(d.rf, hi.q[ii] * simd_load(d.charge + jb), rinv, r2s, vc, g);
              if constexpr (kEnergies) e_coulomb += keep(inside, vc);
            }
          }
          g = keep(inside, g);
          const V gx = g * dx, gy = g * dy, gz = g * dz;
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
      }
      if (inside_masks) inside_masks[e] = inside_bits;
    }
    const int ib = h * kH;
    for (int ii = 0; ii < kH; ++ii) {
      fx[ib + ii] += simd_sum(fxi[ii]);
      fy[ib + ii] += simd_sum(fyi[ii]);
      fz[ib + ii] += simd_sum(fzi[ii]);
    }
    if constexpr (kEnergies) {
      half_lj[h] = simd_sum(e_lj);
      half_coulomb[h] = simd_sum(e_coulomb);
    }
  }
}

// Per pair a u_ij + b (d·u_ij) d, for exactly the pairs the masks select (no cut-off test here).
// Real: as in force_halves.
template <VdwModifier M, bool kCoulomb, CoulombModifier C, bool kSharedSwitch, class Real>
void hessian_halves(const PairViewOf<Real>& d, const Real* ux, const Real* uy, const Real* uz,
                    const std::uint32_t* masks, int h0, int h1, Real* ox, Real* oy, Real* oz) {
  using V = SimdVec<Real>;
  using Mask = SimdMaskOf<Real>;
  const int lanes = V::lanes();
  const unsigned lane_bits = (1u << lanes) - 1;
  const V one = V::broadcast(1.0), zero = V::zero();
  for (int h = h0; h < h1; ++h) {
    const int e0 = d.half_start[h], e1 = d.half_start[h + 1];
    if (e0 == e1) continue;
    HalfData<Real> hi;
    load_half(d, h, hi);
    const int ib = h * kH;
    Real uxi[kH], uyi[kH], uzi[kH];
    for (int ii = 0; ii < kH; ++ii) {
      uxi[ii] = ux[ib + ii];
      uyi[ii] = uy[ib + ii];
      uzi[ii] = uz[ib + ii];
    }
    V oxi[kH], oyi[kH], ozi[kH];
    for (int ii = 0; ii < kH; ++ii) oxi[ii] = oyi[ii] = ozi[ii] = zero;
    for (int e = e0; e < e1; ++e) {
      const NeighborList::Entry entry = d.entries[e];
      const Vec3& shift = d.shifts[entry.shift];
      const std::uint32_t mask = masks[e];
      for (int js = 0; js < kC; js += lanes) {
        const int jb = entry.j_cluster * kC + js;
        const V xj = simd_load(d.x + jb) + shift[0], yj = simd_load(d.y + jb) + shift[1],
                         zj = simd_load(d.z + jb) + shift[2];
        const V uxj = simd_load(ux + jb), uyj = simd_load(uy + jb), uzj = simd_load(uz + jb);
        V oxj = zero, oyj = zero, ozj = zero;
#pragma GCC unroll 4  // the i sums are registers only if their index is a constant
        for (int ii = 0; ii < kH; ++ii) {
          const unsigned bits = (mask >> (ii * kC + js)) & lane_bits;
          if (bits == 0) continue;
          const V dx = hi.x[ii] - xj, dy = hi.y[ii] - yj, dz = hi.z[ii] - zj;
          const V r2 = dx * dx + dy * dy + dz * dz;
          const Mask inside = mask_from_bits<Real>(bits);
          const V r2s = select(inside, r2, one);
          const V rinv = simd_rsqrt(r2s);
          const V rinv2 = rinv * rinv;
          V a, b;
          if constexpr (kSharedSwitch) {
            // The coefficients of U = U_LJ + U_Coulomb unswitched, then of U·S.
            const V r = r2s * rinv, qq = hi.q[ii] * simd_load(d.charge + jb);
            V u, unused;
            rf_hessian<CoulombModifier::none>(d.rf, qq, rinv, r2s, a, b);
            rf_energy_force<CoulombModifier::none>(d.rf, qq, rinv, r2s, u, unused);
            if (hi.lj[ii]) {
              const V c6 = simd_load(hi.c6[ii] + jb), c12 = simd_load(hi.c12[ii] + jb);
              V a_lj, b_lj, u_lj;
              lj_hessian<VdwModifier::none>(d.lj, c6, c12, rinv2, r, a_lj, b_lj);
              lj_energy_force<VdwModifier::none>(d.lj, c6, c12, rinv2, r, u_lj, unused);
              a += a_lj;
              b += b_lj;
              u += u_lj;
            }
            apply_switch_hessian(d.lj.sw, u, r, rinv, a, b);
          } else {
            a = b = zero;
            if (hi.lj[ii])
              lj_hessian<M>(d.lj, simd_load(hi.c6[ii] + jb), simd_load(hi.c12[ii] + jb), rinv2, r2s * rinv, a, b);
            if constexpr (kCoulomb) {
              V ac, bc;
              rf_hessian<C>(d.rf, hi.q[ii] * simd_load(d.charge + jb), rinv, r2s, ac, bc);
              a += ac;
              b += bc;
            }
          }
          a = keep(inside, a);
          b = keep(inside, b);
          const V dux = uxi[ii] - uxj, duy = uyi[ii] - uyj, duz = uzi[ii] - uzj;
          const V bp = b * (dx * dux + dy * duy + dz * duz);
          const V hx = a * dux + bp * dx, hy = a * duy + bp * dy, hz = a * duz + bp * dz;
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
    }
    for (int ii = 0; ii < kH; ++ii) {
      ox[ib + ii] += simd_sum(oxi[ii]);
      oy[ib + ii] += simd_sum(oyi[ii]);
      oz[ib + ii] += simd_sum(ozi[ii]);
    }
  }
}

template <class Real>
void mask_halves(const PairPositionsOf<Real>& d, int h0, int h1, double skip_from, std::uint32_t* inside_masks) {
  using V = SimdVec<Real>;
  const int lanes = V::lanes();
  const V range2 = V::broadcast(d.cutoff2);
  for (int h = h0; h < h1; ++h) {
    const int ib = h * kH;
    Real xi[kH], yi[kH], zi[kH];
    for (int ii = 0; ii < kH; ++ii) {
      xi[ii] = d.x[ib + ii];
      yi[ii] = d.y[ib + ii];
      zi[ii] = d.z[ib + ii];
    }
    for (int e = d.half_start[h]; e < d.half_start[h + 1]; ++e) {
      const NeighborList::Entry entry = d.entries[e];
      if (entry.nearest >= skip_from) {
        inside_masks[e] = 0;
        continue;
      }
      const Vec3& shift = d.shifts[entry.shift];
      std::uint32_t inside_bits = 0;
      for (int js = 0; js < kC; js += lanes) {
        const int jb = entry.j_cluster * kC + js;
        const V xj = simd_load(d.x + jb) + shift[0], yj = simd_load(d.y + jb) + shift[1],
                zj = simd_load(d.z + jb) + shift[2];
        // Every lane, listed or not (padding and excluded pairs have finite distances too); the
        // entry's mask then keeps the listed pairs: cheaper than a vector mask per row.
        for (int ii = 0; ii < kH; ++ii) {
          const V dx = V::broadcast(xi[ii]) - xj, dy = V::broadcast(yi[ii]) - yj, dz = V::broadcast(zi[ii]) - zj;
          inside_bits |= bits_from_mask(dx * dx + dy * dy + dz * dz < range2) << (ii * kC + js);
        }
      }
      inside_masks[e] = inside_bits & entry.mask;
    }
  }
}

template <class Real>
using ForceKernelOf = void (*)(const PairViewOf<Real>&, int, int, Real*, Real*, Real*, double*, double*,
                               std::uint32_t*);

template <bool kCoulomb, CoulombModifier C, class Real, bool kEnergies>
ForceKernelOf<Real> force_kernel_of(VdwModifier m) {
  switch (m) {
    case VdwModifier::none:
      return force_halves<VdwModifier::none, kCoulomb, C, false, Real, kEnergies>;
    case VdwModifier::potential_shift:
      return force_halves<VdwModifier::potential_shift, kCoulomb, C, false, Real, kEnergies>;
    case VdwModifier::force_switch:
      return force_halves<VdwModifier::force_switch, kCoulomb, C, false, Real, kEnergies>;
    case VdwModifier::potential_switch:
      return force_halves<VdwModifier::potential_switch, kCoulomb, C, false, Real, kEnergies>;
  }
  return nullptr;
}

template <class Real, bool kEnergies>
ForceKernelOf<Real> force_kernel_for(VdwModifier m, bool coulomb, CoulombModifier c, bool shared_switch) {
  if (shared_switch)
    return force_halves<VdwModifier::potential_switch, true, CoulombModifier::potential_switch, true, Real, kEnergies>;
  if (!coulomb) return force_kernel_of<false, CoulombModifier::none, Real, kEnergies>(m);
  return c == CoulombModifier::potential_switch
             ? force_kernel_of<true, CoulombModifier::potential_switch, Real, kEnergies>(m)
             : force_kernel_of<true, CoulombModifier::none, Real, kEnergies>(m);
}

template <class Real>
ForceKernelOf<Real> force_kernel_for(VdwModifier m, bool coulomb, CoulombModifier c, bool shared_switch,
                                     bool energies) {
  return energies ? force_kernel_for<Real, true>(m, coulomb, c, shared_switch)
                  : force_kernel_for<Real, false>(m, coulomb, c, shared_switch);
}

template <class Real>
using HessianKernelOf = void (*)(const PairViewOf<Real>&, const Real*, const Real*, const Real*, const std::uint32_t*,
                                 int, int, Real*, Real*, Real*);

template <bool kCoulomb, CoulombModifier C, class Real>
HessianKernelOf<Real> hessian_kernel_of(VdwModifier m) {
  switch (m) {
    case VdwModifier::none:
      return hessian_halves<VdwModifier::none, kCoulomb, C, false, Real>;
    case VdwModifier::potential_shift:
      return hessian_halves<VdwModifier::potential_shift, kCoulomb, C, false, Real>;
    case VdwModifier::force_switch:
      return hessian_halves<VdwModifier::force_switch, kCoulomb, C, false, Real>;
    case VdwModifier::potential_switch:
      return hessian_halves<VdwModifier::potential_switch, kCoulomb, C, false, Real>;
  }
  return nullptr;
}

template <class Real>
HessianKernelOf<Real> hessian_kernel_for(VdwModifier m, bool coulomb, CoulombModifier c, bool shared_switch) {
  if (shared_switch)
    return hessian_halves<VdwModifier::potential_switch, true, CoulombModifier::potential_switch, true, Real>;
  if (!coulomb) return hessian_kernel_of<false, CoulombModifier::none, Real>(m);
  return c == CoulombModifier::potential_switch ? hessian_kernel_of<true, CoulombModifier::potential_switch, Real>(m)
                                                : hessian_kernel_of<true, CoulombModifier::none, Real>(m);
}

}  // namespace

// Entry points of this target, for HWY_DYNAMIC_DISPATCH.
// Without Coulomb the Coulomb modifier is irrelevant: one instantiation.
ForceKernel ForceKernelFor(VdwModifier m, bool coulomb, CoulombModifier c, bool shared_switch, bool energies) {
  return force_kernel_for<double>(m, coulomb, c, shared_switch, energies);
}
SingleForceKernel SingleForceKernelFor(VdwModifier m, bool coulomb, CoulombModifier c, bool shared_switch,
                                       bool energies) {
  return force_kernel_for<float>(m, coulomb, c, shared_switch, energies);
}
HessianKernel HessianKernelFor(VdwModifier m, bool coulomb, CoulombModifier c, bool shared_switch) {
  return hessian_kernel_for<double>(m, coulomb, c, shared_switch);
}
SingleHessianKernel SingleHessianKernelFor(VdwModifier m, bool coulomb, CoulombModifier c, bool shared_switch) {
  return hessian_kernel_for<float>(m, coulomb, c, shared_switch);
}
MaskKernel MaskKernelFor() { return mask_halves<double>; }
SingleMaskKernel SingleMaskKernelFor() { return mask_halves<float>; }
std::int64_t Target() { return HWY_TARGET; }
int Lanes() { return SimdDouble::lanes(); }

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
#include <stdexcept>

#include "engine/errors.hpp"

namespace vimd {

HWY_EXPORT(ForceKernelFor);
HWY_EXPORT(SingleForceKernelFor);
HWY_EXPORT(HessianKernelFor);
HWY_EXPORT(SingleHessianKernelFor);
HWY_EXPORT(MaskKernelFor);
HWY_EXPORT(SingleMaskKernelFor);
HWY_EXPORT(Target);
HWY_EXPORT(Lanes);

namespace simd {

namespace {
// The dispatch tables return null only for a VdwModifier value outside the enum.
template <class Kernel>
Kernel checked(Kernel kernel) {
  if (!kernel) throw std::logic_error("unknown VdwModifier");
  return kernel;
}
}  // namespace

ForceKernel force_kernel(VdwModifier modifier, bool coulomb, CoulombModifier coulomb_modifier, bool shared_switch,
                         bool energies) {
  return checked(HWY_DYNAMIC_DISPATCH(ForceKernelFor)(modifier, coulomb, coulomb_modifier, shared_switch, energies));
}

SingleForceKernel single_force_kernel(VdwModifier modifier, bool coulomb, CoulombModifier coulomb_modifier,
                                      bool shared_switch, bool energies) {
  return checked(
      HWY_DYNAMIC_DISPATCH(SingleForceKernelFor)(modifier, coulomb, coulomb_modifier, shared_switch, energies));
}

HessianKernel hessian_kernel(VdwModifier modifier, bool coulomb, CoulombModifier coulomb_modifier,
                             bool shared_switch) {
  return checked(HWY_DYNAMIC_DISPATCH(HessianKernelFor)(modifier, coulomb, coulomb_modifier, shared_switch));
}

SingleHessianKernel single_hessian_kernel(VdwModifier modifier, bool coulomb, CoulombModifier coulomb_modifier,
                                          bool shared_switch) {
  return checked(HWY_DYNAMIC_DISPATCH(SingleHessianKernelFor)(modifier, coulomb, coulomb_modifier, shared_switch));
}

MaskKernel mask_kernel() { return HWY_DYNAMIC_DISPATCH(MaskKernelFor)(); }
SingleMaskKernel single_mask_kernel() { return HWY_DYNAMIC_DISPATCH(SingleMaskKernelFor)(); }

std::string target_name() { return hwy::TargetName(HWY_DYNAMIC_DISPATCH(Target)()); }
int lanes() { return HWY_DYNAMIC_DISPATCH(Lanes)(); }

std::vector<std::string> available_targets() {
  std::vector<std::string> names;
  // SupportedAndGeneratedTargets lists the lowest bit first; on x86 a lower bit is a better target.
  for (std::int64_t target : hwy::SupportedAndGeneratedTargets()) names.emplace_back(hwy::TargetName(target));
  return names;
}

void use_target(const std::string& name) {
  hwy::SetSupportedTargetsForTest(0);
  if (!name.empty()) {
    std::int64_t chosen = 0;
    std::string known;
    for (std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
      if (name == hwy::TargetName(target)) chosen = target;
      known += std::string(known.empty() ? "" : ", ") + hwy::TargetName(target);
    }
    if (chosen == 0)
      throw InputError("--simd", 0, "SIMD target '" + name + "' is not available on this CPU (available: " + known + ")");
    hwy::SetSupportedTargetsForTest(chosen);
  }
  hwy::GetChosenTarget().Update(hwy::SupportedTargets());
}

}  // namespace simd
}  // namespace vimd
#endif  // HWY_ONCE
