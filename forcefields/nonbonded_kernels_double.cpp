// The double-precision pair kernels of every SIMD target (Highway's foreach_target re-includes this
// file for each), dispatched at run time; and the choice of the target (simd::).
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "forcefields/nonbonded_kernels_double.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include "forcefields/nonbonded_kernels-inl.h"
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
std::int64_t Target() { return HWY_TARGET; }
int Lanes() { return SimdDouble::lanes(); }

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
#include "engine/errors.hpp"

namespace vimd {

HWY_EXPORT(ForceKernelFor);
HWY_EXPORT(HessianKernelFor);
HWY_EXPORT(MaskKernelFor);
HWY_EXPORT(NarrowKernelFor);
HWY_EXPORT(ExcludedKernelFor);
HWY_EXPORT(Target);
HWY_EXPORT(Lanes);

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
