#pragma once
// The SIMD target every kernel of the program runs on (the pair loops, the mesh, SETTLE, the per-atom
// passes): Highway's best for this CPU, chosen at run time, unless one is asked for.
#include <string>
#include <vector>

namespace vimd::simd {

// The target the kernels run on (e.g. "AVX2", "AVX3" = AVX-512) and its vector width in doubles.
std::string target_name();
int lanes();
// Targets compiled into this binary that this CPU can run, best first.
std::vector<std::string> available_targets();
// Restricts the kernels to one of available_targets() (tests, benchmarks, `--simd`); an empty name
// restores the automatic choice. Throws std::invalid_argument for a target that is not available.
void use_target(const std::string& name);

}  // namespace vimd::simd
