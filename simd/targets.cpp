// The choice of the SIMD target (targets.hpp). Compiled for every target (Highway's foreach_target
// re-includes this file) only to ask the dispatcher which one it picked.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "simd/targets.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include "hwy/highway.h"
#include "simd/simd-inl.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {

std::int64_t Target() { return HWY_TARGET; }
int Lanes() { return SimdDouble::lanes(); }

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
#include <stdexcept>

#include "simd/targets.hpp"

namespace vimd {

HWY_EXPORT(Target);
HWY_EXPORT(Lanes);

namespace simd {

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
      throw std::invalid_argument("SIMD target '" + name + "' is not available on this CPU (available: " + known + ")");
    hwy::SetSupportedTargetsForTest(chosen);
  }
  hwy::GetChosenTarget().Update(hwy::SupportedTargets());
}

}  // namespace simd
}  // namespace vimd
#endif  // HWY_ONCE
