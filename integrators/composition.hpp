#pragma once
// Symmetric compositions of a symmetric second-order one-step method Φ (RATTLE):
//   Ψ_h = Φ_{γ_s h} ∘ … ∘ Φ_{γ_1 h},  γ_k = γ_{s+1−k},  Σ γ_k = 1,
// as data: the built-in weight sets with their sources, and the checks a user's weights must pass.
// Ψ is symmetric, so its order is even; it keeps what every sub-step keeps (symplecticity,
// the constraints, momentum).
#include <string>
#include <vector>

#include "integrators/settings.hpp"

namespace vimd {

struct Composition {
  std::string name;
  int order = 2;                // claimed (and checked) order of Ψ
  std::vector<double> weights;  // γ_1 … γ_s
  int stages() const { return static_cast<int>(weights.size()); }
};

// The built-in compositions' names (composition = "none" and "user" are not among them).
std::vector<std::string> composition_names();
// A built-in composition; std::out_of_range (listing the names) for an unknown one.
const Composition& builtin_composition(const std::string& name);

// The largest even p ≤ max_order (at most 10) to which the weights satisfy the composition order
// conditions: through h^p, Ψ_h agrees with the exact flow for every symmetric Φ.
//
// How: the conditions are algebraic in γ and the same for every symmetric Φ, whose flow is
// exp(hA + h³B + h⁵C + h⁷D + h⁹E) for some vector fields A…E (only odd powers, Φ being
// symmetric). The check takes A…E to be fixed random 6×6 matrices, expands Ψ_h as a power series
// in h (matrix coefficients) and requires the coefficients of h^1…h^p to be those of exp(hA),
// each to 1e-12 relative to (Σ|γ_k|)^m / m!. Random 6×6 matrices satisfy no polynomial identity
// of degree below 12 (Amitsur–Levitzki), so every condition of order ≤ 10 shows; the three
// lowest are Σ γ_k = 1, Σ γ_k³ = 0 and Σ γ_k⁵ = 0.
int satisfied_composition_order(const std::vector<double>& weights, int max_order = 10);
// Everything wrong with weights claiming `order` (empty, not finite, not symmetric, not summing to
// 1, an order condition violated), or an empty string.
std::string composition_problem(const std::vector<double>& weights, int order);

// What [integrator] asks for: composition = "none" is the single weight {1}, a built-in name its
// composition, "user" composition_weights claiming composition_order, checked; InputError otherwise.
Composition resolve_composition(const IntegratorConfig& config);

}  // namespace vimd
