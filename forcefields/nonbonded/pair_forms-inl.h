// The kernels of the forms listed in pair_forms.hpp, for the SIMD target being compiled: each
// form's <form>_kernels.h is compiled here, inside the target's namespace, with the loop's side of
// the contract (pair_form-inl.h), the switch functions and the SIMD operations in scope. A Highway
// per-target header: see simd/simd-inl.h.
#if defined(VIMD_FORCEFIELDS_NONBONDED_PAIR_FORMS_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef VIMD_FORCEFIELDS_NONBONDED_PAIR_FORMS_INL_H_
#undef VIMD_FORCEFIELDS_NONBONDED_PAIR_FORMS_INL_H_
#else
#define VIMD_FORCEFIELDS_NONBONDED_PAIR_FORMS_INL_H_
#endif

#include <cmath>
#include <cstddef>
#include <iterator>
#include <type_traits>

#include "forcefields/nonbonded/pair_form-inl.h"
#include "forcefields/nonbonded/pair_forms.hpp"
#include "forcefields/nonbonded/switch_function-inl.h"
#include "hwy/highway.h"
#include "simd/simd-inl.h"

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {

#include "forcefields/nonbonded/ewald_kernels.h"
#include "forcefields/nonbonded/lennard_jones_kernels.h"
#include "forcefields/nonbonded/reaction_field_kernels.h"

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#endif  // VIMD_FORCEFIELDS_NONBONDED_PAIR_FORMS_INL_H_
