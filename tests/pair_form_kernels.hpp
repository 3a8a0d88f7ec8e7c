#pragma once
// The pair forms' kernels (forcefields/nonbonded/*_kernels.h) on plain numbers, double for the
// reference sums and jets for the derivative jumps, in the build's static SIMD target, called with
// the arguments the references have: the parameters and the distance as the pair loop would pass them.
#include "forcefields/nonbonded/pair_forms-inl.h"

namespace vimd::testing {

using HWY_NAMESPACE::PairForm;

template <VdwModifier M, class T>
void lj_energy_force(const LjConstants& k, T c6, T c12, T rinv2, T r, T& v, T& g) {
  PairForm<LjConstants, M>::energy_force(k, LennardJonesPair<T>{c6, c12}, PairDistance<T>{r * r, rinv2 * r, rinv2}, v, g);
}
template <VdwModifier M, class T>
void lj_hessian(const LjConstants& k, T c6, T c12, T rinv2, T r, T& a, T& b) {
  PairForm<LjConstants, M>::hessian(k, LennardJonesPair<T>{c6, c12}, PairDistance<T>{r * r, rinv2 * r, rinv2}, a, b);
}
template <CoulombModifier C, class T>
void rf_energy_force(const ReactionField& rf, T qq, T rinv, T r2, T& v, T& g) {
  PairForm<ReactionField, C>::energy_force(rf, ChargeProduct<T>{qq}, PairDistance<T>{r2, rinv, rinv * rinv}, v, g);
}
template <CoulombModifier C, class T>
void rf_hessian(const ReactionField& rf, T qq, T rinv, T r2, T& a, T& b) {
  PairForm<ReactionField, C>::hessian(rf, ChargeProduct<T>{qq}, PairDistance<T>{r2, rinv, rinv * rinv}, a, b);
}
template <EwaldModifier M, class T>
void ewald_energy_force(const EwaldRealSpace& e, T qq, T rinv, T r2, T& v, T& g) {
  PairForm<EwaldRealSpace, M>::energy_force(e, ChargeProduct<T>{qq}, PairDistance<T>{r2, rinv, rinv * rinv}, v, g);
}
template <EwaldModifier M, class T>
void ewald_hessian(const EwaldRealSpace& e, T qq, T rinv, T r2, T& a, T& b) {
  PairForm<EwaldRealSpace, M>::hessian(e, ChargeProduct<T>{qq}, PairDistance<T>{r2, rinv, rinv * rinv}, a, b);
}

}  // namespace vimd::testing
