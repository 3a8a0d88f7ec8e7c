#pragma once
// Energy minimisation with constraints: steepest descent with an adaptive step, as GROMACS's
// `steep`. One step() is one trial move: every atom moves along its constrained force, the
// largest move being h; the constraints are then solved again (SHAKE-like, from the old
// positions; a move they cannot follow counts as rejected). A lower potential is accepted and h grows by 1.2; otherwise the old state stays and
// h shrinks by 0.2. The constrained force is the force's orthogonal projection onto the tangent
// space of the constraint manifold (f − Gᵀ(GGᵀ)⁻¹G f): the steepest-descent direction on the
// manifold, zero at a constrained minimum, so its largest per-atom norm is what `emtol` bounds.
// (GROMACS projects M⁻¹-weighted instead; that direction need not descend.)
#include "integrators/settings.hpp"
#include "engine/integrator.hpp"

namespace vimd {

class SteepestDescent : public Integrator {
 public:
  explicit SteepestDescent(const IntegratorConfig& config);
  std::string name() const override { return "minimize"; }
  // Zeroes the velocities and evaluates the forces of the start (the engine has constrained it).
  void init(Problem& problem, State& state) override;
  // iterations / residual: those of the constraint solve of the trial move. finished: the largest
  // constrained force is below emtol, or the step has shrunk below what double precision resolves.
  StepReport step(Problem& problem, State& state) override;
  // max_force: kJ/mol/nm, max_force_atom: 1-based, step_size: nm (the next trial's h).
  std::vector<std::string> diagnostic_names() const override { return {"max_force", "max_force_atom", "step_size"}; }
  // The step size h: all a checkpoint needs besides the State.
  Carried carried_state() const override;
  void restore(Problem& problem, const State& state, const Carried& carried) override;

  // The largest constrained force at the current state and the atom (0-based) that carries it.
  double max_force() const { return max_force_; }
  int max_force_atom() const { return max_force_atom_; }

 private:
  void constrained_force(const Problem& problem, const State& state);
  StepReport report() const;

  double emtol_, step_size_, tolerance_;
  int max_iterations_;
  Forces forces_;
  State trial_;
  Coords constrained_f_;  // at the current state
  Eigen::VectorXd ones_;  // Euclidean weights for the projections
  double max_force_ = 0;
  int max_force_atom_ = 0;
};

}  // namespace vimd
