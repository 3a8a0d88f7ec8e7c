// The double-precision pair kernels of every SIMD target (Highway's foreach_target re-includes this
// file for each), dispatched at run time.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "forcefields/nonbonded/nonbonded_kernels_double.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include "forcefields/nonbonded/excluded_pairs-inl.h"
#include "forcefields/nonbonded/kernel_combinations-inl.h"
#include "forcefields/nonbonded/pruning-inl.h"
#include "hwy/highway.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {

// Entry points of this target, for HWY_DYNAMIC_DISPATCH.
ForceKernel ForceKernelFor(const PairFormConstants& forms, bool energies, bool masks) {
  return force_kernel_for<double>(forms, energies, masks);
}
HessianKernel HessianKernelFor(const PairFormConstants& forms) {
  return hessian_kernel_among<double>(forms, Combinations{});
}
MaskKernel MaskKernelFor() { return mask_halves<double>; }
NarrowKernel NarrowKernelFor() { return narrow_halves<double>; }
ExcludedKernelOf<double> ExcludedKernelFor() { return excluded_pairs<double>; }

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace vimd {

HWY_EXPORT(ForceKernelFor);
HWY_EXPORT(HessianKernelFor);
HWY_EXPORT(MaskKernelFor);
HWY_EXPORT(NarrowKernelFor);
HWY_EXPORT(ExcludedKernelFor);

namespace simd {

ForceKernel force_kernel(const PairFormConstants& forms, bool energies, bool masks) {
  return checked_kernel(HWY_DYNAMIC_DISPATCH(ForceKernelFor)(forms, energies, masks));
}

HessianKernel hessian_kernel(const PairFormConstants& forms) {
  return checked_kernel(HWY_DYNAMIC_DISPATCH(HessianKernelFor)(forms));
}

MaskKernel mask_kernel() { return HWY_DYNAMIC_DISPATCH(MaskKernelFor)(); }

NarrowKernel narrow_kernel() { return HWY_DYNAMIC_DISPATCH(NarrowKernelFor)(); }

ExcludedKernelOf<double> excluded_kernel() { return HWY_DYNAMIC_DISPATCH(ExcludedKernelFor)(); }

}  // namespace simd
}  // namespace vimd
#endif  // HWY_ONCE
