// The kernel side of a nonbonded pair form (pair_form.hpp), for the SIMD target being compiled.
// A Highway per-target header: see engine/simd-inl.h.
//
// A form's -inl.h specialises PairForm<Constants, variant> for each of its variants with
//   using Constants; static constexpr auto kVariant;
//   template <class Real> struct Half: what the form reads of the i atoms of a half-cluster,
//     loaded once per half by load(view, first slot); active(ii): whether row ii has the form
//     at all (false: its terms are exact zeros and are skipped);
//   energy_force(view, half, ii, jb, distance, v, g): per pair of i atom ii with the j atoms at
//     slots jb.., the energy φ and g = −φ'(r)/r (the force on i is g d, d = r_i − r_j);
//   hessian(view, half, ii, jb, distance, a, b): a = φ'/r and b = (φ'' − φ'/r)/r², the pair's
//     Hessian block being a I + b d dᵀ;
//   optionally add_energy_force(..., v, g): as energy_force, its g added to g (when a fused
//     multiply-add makes that cheaper than a separate sum).
// All are templates on Real (double or float) with V = SimdVec<Real>, inlined into the pair
// loop: no branch on the variant or the form inside it.
#if defined(VIMD_FORCEFIELDS_PAIR_FORM_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef VIMD_FORCEFIELDS_PAIR_FORM_INL_H_
#undef VIMD_FORCEFIELDS_PAIR_FORM_INL_H_
#else
#define VIMD_FORCEFIELDS_PAIR_FORM_INL_H_
#endif

#include "engine/simd-inl.h"
#include "forcefields/nonbonded_kernels.hpp"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {

template <class Constants, auto kVariant>
struct PairForm;

// The distance of a pair, in the forms' terms. Lanes that do not interact carry r2 = 1.
template <class Real>
struct PairDistance {
  SimdVec<Real> r2, rinv, rinv2;
};

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#endif  // VIMD_FORCEFIELDS_PAIR_FORM_INL_H_
