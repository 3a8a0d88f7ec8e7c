// The kernels of the forms listed in pair_forms.hpp, for the SIMD target being compiled. A Highway
// per-target header: see simd/simd-inl.h.
#if defined(VIMD_FORCEFIELDS_NONBONDED_PAIR_FORMS_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef VIMD_FORCEFIELDS_NONBONDED_PAIR_FORMS_INL_H_
#undef VIMD_FORCEFIELDS_NONBONDED_PAIR_FORMS_INL_H_
#else
#define VIMD_FORCEFIELDS_NONBONDED_PAIR_FORMS_INL_H_
#endif

#include "forcefields/nonbonded/ewald-inl.h"
#include "forcefields/nonbonded/lennard_jones-inl.h"
#include "forcefields/nonbonded/reaction_field-inl.h"

#endif  // VIMD_FORCEFIELDS_NONBONDED_PAIR_FORMS_INL_H_
