#pragma once
// The one loop over steps. Integrators advance the state; observers (files, progress bar,
// summary) see samples of it. Nothing else in the code base loops over time steps.
#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "engine/checkpoint.hpp"
#include "engine/errors.hpp"
#include "engine/integrator.hpp"
#include "engine/start_state.hpp"

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
  std::vector<double> diagnostics;   // per Integrator::diagnostic_names(); empty before the first step
};

struct RunInfo {
  const Problem& problem;
  const Integrator& integrator;
  long first_step, last_step;  // the whole run's span, also when continued from a checkpoint
  long start_step;             // where this process started (first_step, or a checkpoint's step)
  double dt;
  std::vector<std::string> energy_names, diagnostic_names;
};

// The force field's work (WorkCounters) and the run's own.
struct RunTotals : WorkCounters {
  double wall_seconds = 0;
  long steps = 0;
  long solver_iterations = 0;  // summed StepReport::iterations
  int stop_signal = 0;         // the run stopped early, resumable, on this signal (0: it finished)

  // Accumulates the work of a later run of the same simulation.
  void add(const RunTotals& later) {
    WorkCounters::operator+=(later);
    wall_seconds += later.wall_seconds;
    steps += later.steps;
    solver_iterations += later.solver_iterations;
  }
};

class Observer {
 public:
  virtual ~Observer() = default;
  // Steps on which this observer wants a sample (0: never, except the first and last).
  virtual long every() const = 0;
  // False for observers that only look at the step counter (the progress bar).
  virtual bool needs_sample() const { return true; }
  // Whether what it observes includes the velocities (Problem::velocities_due).
  virtual bool reads_velocities() const { return needs_sample(); }
  virtual void begin(const RunInfo&) {}
  virtual void observe(const RunInfo&, const State&, const Sample&) = 0;
  // Called only after a successful run.
  virtual void finish(const RunInfo&, const State&, const RunTotals&) {}
  // Checkpoints: flush, and return what a continued run needs (file sizes, sampled series).
  virtual Carried checkpoint(const RunInfo&) { return {}; }
  // Replaces begin() on a run continued from a checkpoint.
  virtual void resume(const RunInfo& info, const Carried& /*carried*/) { begin(info); }
  // The run stopped on request (after a checkpoint): close files, keep them resumable.
  virtual void stop(const RunInfo&) {}
  // The run failed; last_good is the state before the failing step.
  virtual void fail(const RunInfo&, const State& /*last_good*/) {}
};

// When to write state.cpt: every `every_steps` steps, or (0) every `every_seconds` of wall time;
// always when the run stops on a signal and at its end.
struct CheckpointPolicy {
  std::filesystem::path file;  // empty: no checkpoints (and no stopping on signals)
  long every_steps = 0;
  double every_seconds = 900;
  RunIdentity identity;
  std::vector<RunSegment> segments;  // of the run so far, this process's last
};

// A run that cannot go on: a non-finite or absurd force, position, velocity or energy.
class BlowUpError : public ConvergenceError {
 public:
  BlowUpError(long step, const std::string& what) : ConvergenceError(what, step) {}
};

class Simulation {
 public:
  Simulation(Problem& problem, Integrator& integrator, double dt);
  void add_observer(std::unique_ptr<Observer> observer);
  void set_checkpoints(CheckpointPolicy policy) { checkpoints_ = std::move(policy); }
  // Told how far the first run's constrain_start moved the state read (once, before any step).
  void on_start_constrained(std::function<void(const StartReport&)> report) { start_report_ = std::move(report); }
  // On the first run only (a later run continues the same state): constrain the start
  // (constrain_start) and init() the integrator. Then step `steps` times, or fewer when a step
  // reports finished. Throws what the integrator throws (ConvergenceError) or BlowUpError, after
  // which no observer's finish() has run (their fail() has) and `state` is back at the last good
  // step (its forces and energies are not: compute them anew). Returns early, resumable, when a stop
  // signal arrives (engine/stop): totals.stop_signal says so.
  RunTotals run(State& state, long steps);
  // Continues a checkpointed run up to its step `last_step`; the observers must be those of the
  // stopped run, in the same order. Afterwards the outputs are those of an uninterrupted run.
  RunTotals resume(const Checkpoint& checkpoint, long last_step, State& state);

 private:
  Sample sample(const State& state, const StepReport& report) const;
  RunTotals loop(State& state, RunInfo& info, RunTotals totals);
  void write_checkpoint_now(const State& state, const RunInfo& info, const RunTotals& totals);
  // InputError or BlowUpError naming the atoms if the state is not fit to be written; else, given
  // `copy`, its q, v, step and time are the state's (copied in the same pass).
  void check_sane(const State& state, State* copy = nullptr) const;

  Problem& problem_;
  Integrator& integrator_;
  double dt_;
  bool initialized_ = false;
  std::function<void(const StartReport&)> start_report_;
  std::vector<std::unique_ptr<Observer>> observers_;
  CheckpointPolicy checkpoints_;
  WorkCounters work0_;  // the force field's work counters when this process's run started
  std::chrono::steady_clock::time_point wall0_;
  long start_step_ = 0;    // the run's first step
  double start_time_ = 0;  // ps, at the run's first step: time = start_time + (step − first_step) dt
};

}  // namespace vimd
