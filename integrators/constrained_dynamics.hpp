#pragma once
// The constrained vector field in index-1 form and its vector–Jacobian product (docs/
// variational-integrator.md, "Setting" and "The one-step method and its adjoint"):
//   S(q) = G M⁻¹ Gᵀ,  S λ = −D²g(v,v) − G M⁻¹ f,  A(q,v) = M⁻¹(f + Gᵀλ),  L(q,v) = ½vᵀMv − V(q).
// Defined off the constraint manifold too, as Runge–Kutta stages need.
#include "engine/constraints.hpp"
#include "engine/force_field.hpp"
#include "engine/integrator.hpp"

namespace vimd {

// Everything the reverse pass needs from one evaluation of the vector field.
struct DynamicsPoint {
  Coords q, v;
  Forces forces;                        // f, V and its terms at q (V NaN where not computed)
  Coords a;                             // A(q, v)
  Eigen::VectorXd lambda;               // constraint multipliers
  Constraints::Factorization s_factor;  // S(q) = G M⁻¹ Gᵀ
  double lagrangian = 0;                // L(q, v) (NaN without V)
};

// Which evaluations use the force field's single-precision pair kernels, given with each
// evaluation: the stages inside a segment (a segment's start stays double: its forces are the
// state's, and a solve reuses them), and the Hessian–vector products. For a solve's first
// iteration, and its products where the tolerance is far above their rounding
// (VariationalSettings::mixed_precision_solve). Double by default.
struct DynamicsPrecision {
  bool single_stages = false;
  bool single_products = false;
};

class ConstrainedDynamics {
 public:
  explicit ConstrainedDynamics(Problem& problem);

  // Which evaluations compute the potential energy (and so the Lagrangian): all (the default: a
  // segment's action needs them), or only a segment's start when the problem's energies are due
  // (a variational step: the stages need forces alone, and the state it writes is a segment start).
  enum class Energies { everywhere, at_due_starts };
  void set_energies(Energies energies) { energies_ = energies; }
  // Starts a variational step at q (ForceField::start_step): this and every later evaluation is
  // over the step's pair set, until the next start.
  void start_step(const Coords& q);
  // ∇²V(q) u, in single precision with precision.single_products. forces_at_q: an evaluation at
  // exactly q (its masks save work).
  void hessian_vector(const Coords& q, const Coords& u, Coords& out, const Forces* forces_at_q = nullptr,
                      const DynamicsPrecision& precision = {});

  // Evaluates the field at (q, v); `segment_start`: (q, v) starts a segment. `forces_at_q`, when
  // given, must be the forces at exactly this q and saves the force evaluation.
  void evaluate(const Coords& q, const Coords& v, DynamicsPoint& point, const Forces* forces_at_q = nullptr,
                bool segment_start = true, const DynamicsPrecision& precision = {});

  // q_bar += ā·∂A/∂q and v_bar += ā·∂A/∂v at `point`: with u = M⁻¹ā, z = S⁻¹Gu, ũ = u − M⁻¹Gᵀz,
  //   ā·∂A/∂q = −∇²V ũ + Σ_a (λ_a H_a ũ − z_a H_a A),   ā·∂A/∂v = −2 Σ_a z_a H_a v.
  // With `deferred_hvp` given, the −∇²V ũ term is left out and ũ is added to *deferred_hvp instead,
  // so that several VJPs at the same q can share one Hessian–vector product (∇²V is linear in ũ).
  void add_vjp(const DynamicsPoint& point, const Coords& a_bar, Coords& q_bar, Coords& v_bar,
               Coords* deferred_hvp = nullptr, const DynamicsPrecision& precision = {});

  Problem& problem() { return problem_; }
  const Constraints& constraints() const { return problem_.constraints; }
  const Eigen::VectorXd& mass() const { return problem_.system.mass; }
  const Eigen::VectorXd& inverse_mass() const { return problem_.inverse_mass; }
  int n_atoms() const { return static_cast<int>(problem_.inverse_mass.size()); }

 private:
  Problem& problem_;
  Energies energies_ = Energies::everywhere;
  StepPairSet step_pairs_;
  bool in_step_ = false;
  // Once a Hessian–vector product has been asked for, force passes keep their masks for the
  // products at their positions (before that, force-only use pays nothing).
  bool keep_masks_ = false;
  Evaluation evaluation(bool single_precision);
  // Scratch, sized once, so evaluations do not allocate.
  Coords u_tangent_, hessian_u_;
  Eigen::VectorXd z_, coefficients_;
};

}  // namespace vimd
