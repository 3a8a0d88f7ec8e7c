// The single-precision pair kernels of every SIMD target (Highway's foreach_target re-includes
// this file for each), dispatched at run time.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "forcefields/nonbonded/nonbonded_kernels_single.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include "forcefields/nonbonded/excluded_pairs-inl.h"
#include "forcefields/nonbonded/kernel_combinations-inl.h"
#include "forcefields/nonbonded/pruning-inl.h"
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {

// Entry points of this target, for HWY_DYNAMIC_DISPATCH.
SingleForceKernel SingleForceKernelFor(const PairFormConstants& forms, bool energies, bool masks) {
  return force_kernel_for<float>(forms, energies, masks);
}
SingleHessianKernel SingleHessianKernelFor(const PairFormConstants& forms) {
  return hessian_kernel_among<float>(forms, Combinations{});
}
SingleMaskKernel SingleMaskKernelFor() { return mask_halves<float>; }
SingleNarrowKernel SingleNarrowKernelFor() { return narrow_halves<float>; }
ExcludedKernelOf<float> SingleExcludedKernelFor() { return excluded_pairs<float>; }

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace vimd {

HWY_EXPORT(SingleForceKernelFor);
HWY_EXPORT(SingleHessianKernelFor);
HWY_EXPORT(SingleMaskKernelFor);
HWY_EXPORT(SingleNarrowKernelFor);
HWY_EXPORT(SingleExcludedKernelFor);

namespace simd {

SingleForceKernel single_force_kernel(const PairFormConstants& forms, bool energies, bool masks) {
  return checked_kernel(HWY_DYNAMIC_DISPATCH(SingleForceKernelFor)(forms, energies, masks));
}

SingleHessianKernel single_hessian_kernel(const PairFormConstants& forms) {
  return checked_kernel(HWY_DYNAMIC_DISPATCH(SingleHessianKernelFor)(forms));
}

SingleMaskKernel single_mask_kernel() { return HWY_DYNAMIC_DISPATCH(SingleMaskKernelFor)(); }

SingleNarrowKernel single_narrow_kernel() { return HWY_DYNAMIC_DISPATCH(SingleNarrowKernelFor)(); }

ExcludedKernelOf<float> single_excluded_kernel() { return HWY_DYNAMIC_DISPATCH(SingleExcludedKernelFor)(); }

}  // namespace simd
}  // namespace vimd
#endif  // HWY_ONCE
