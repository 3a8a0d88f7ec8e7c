#pragma once
// The one loop over steps. Integrators advance the state; observers (files, progress bar,
// summary) see samples of it. Nothing else in the code base loops over time steps.
#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "engine/integrator.hpp"

namespace vimd {

// Observables of one step, computed only on the steps someone samples.
struct Sample {
  long step = 0;
  double time = 0;         // ps
  double potential = 0;    // kJ/mol
  double kinetic = 0;      // kJ/mol
  double total = 0;        // kJ/mol
  double conserved = 0;    // kJ/mol: total − Integrator::thermostat_work() (= total without a thermostat)
  double temperature = 0;  // K
  double constraint_rms = 0;         // RMS relative deviation of constraint lengths
  std::vector<double> energy_terms;  // kJ/mol, per ForceField::energy_names()
  Vec3 momentum = Vec3::Zero();      // Σ m v, amu nm/ps
  std::vector<double> diagnostics;   // per Integrator::diagnostic_names()
};

struct RunInfo {
  const Problem& problem;
  const Integrator& integrator;
  long first_step, last_step;
  double dt;
  std::vector<std::string> energy_names, diagnostic_names;
};

struct RunTotals {
  double wall_seconds = 0;
  long steps = 0;
  long force_evaluations = 0, hessian_evaluations = 0, neighbor_rebuilds = 0;
  long solver_iterations = 0;  // summed StepReport::iterations
};

class Observer {
 public:
  virtual ~Observer() = default;
  // Steps on which this observer wants a sample (0: never, except the first and last).
  virtual long every() const = 0;
  // False for observers that only look at the step counter (the progress bar).
  virtual bool needs_sample() const { return true; }
  virtual void begin(const RunInfo&) {}
  virtual void observe(const RunInfo&, const State&, const Sample&) = 0;
  // Called only after a successful run.
  virtual void finish(const RunInfo&, const State&, const RunTotals&) {}
};

class Simulation {
 public:
  Simulation(Problem& problem, Integrator& integrator, double dt);
  void add_observer(std::unique_ptr<Observer> observer);
  // init() the integrator (on the first run only: a later run continues the same state), then
  // step `steps` times, or fewer when a step reports finished. Throws what the integrator throws
  // (ConvergenceError), after which no observer's finish() has run.
  RunTotals run(State& state, long steps);

 private:
  Sample sample(const State& state, const StepReport& report) const;

  Problem& problem_;
  Integrator& integrator_;
  double dt_;
  bool initialized_ = false;
  std::vector<std::unique_ptr<Observer>> observers_;
};

}  // namespace vimd
