#pragma once
// What a run writes and shows: energy series (.xvg and .csv), the .trr trajectory, the final
// .gro, a progress bar, and the end-of-run summary. Files are written under a ".partial" name
// and renamed only when the run finishes, so a failed run leaves nothing posing as complete.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <vector>

#include "engine/simulation.hpp"

namespace vimd {

class TrrWriter;

// A file written as NAME.partial and renamed to NAME by commit().
class PendingFile {
 public:
  explicit PendingFile(std::filesystem::path final_path);
  const std::filesystem::path& partial_path() const { return partial_; }
  const std::filesystem::path& final_path() const { return final_; }
  void commit() const;

 private:
  std::filesystem::path final_, partial_;
};

class EnergyWriter : public Observer {
 public:
  EnergyWriter(const std::filesystem::path& dir, long every);
  long every() const override { return every_; }
  void begin(const RunInfo&) override;
  void observe(const RunInfo&, const State&, const Sample&) override;
  void finish(const RunInfo&, const State&, const RunTotals&) override;
  Carried checkpoint(const RunInfo&) override;
  void resume(const RunInfo&, const Carried&) override;
  void stop(const RunInfo&) override;
  void fail(const RunInfo& info, const State&) override { stop(info); }

 private:
  void check_written();
  long every_;
  PendingFile xvg_file_, csv_file_;
  std::ofstream xvg_, csv_;
};

class TrajectoryWriter : public Observer {
 public:
  TrajectoryWriter(const std::filesystem::path& dir, long every);
  ~TrajectoryWriter() override;
  long every() const override { return every_; }
  bool needs_sample() const override { return false; }
  bool reads_velocities() const override { return true; }
  void begin(const RunInfo&) override;
  void observe(const RunInfo&, const State&, const Sample&) override;
  void finish(const RunInfo&, const State&, const RunTotals&) override;
  Carried checkpoint(const RunInfo&) override;
  void resume(const RunInfo&, const Carried&) override;
  void stop(const RunInfo&) override;

 private:
  long every_;
  PendingFile file_;
  std::unique_ptr<TrrWriter> writer_;
};

// Truncates a stopped run's partial output back to its size at the checkpoint (frames written
// after it are written again); InputError if the file is missing or shorter.
void truncate_to_checkpoint(const std::filesystem::path& partial, double bytes);

// confout.gro at the end of a successful run; last_good.gro (the state before the failing step)
// when a run fails. Both without velocities when they mean nothing (a minimisation), so a run from
// them generates them from its temperature.
class FinalStructureWriter : public Observer {
 public:
  explicit FinalStructureWriter(const std::filesystem::path& dir, bool velocities = true)
      : dir_(dir), velocities_(velocities) {}
  long every() const override { return 0; }
  bool needs_sample() const override { return false; }
  void observe(const RunInfo&, const State&, const Sample&) override {}
  void finish(const RunInfo&, const State&, const RunTotals&) override;
  void fail(const RunInfo&, const State& last_good) override;

 private:
  std::filesystem::path dir_;
  bool velocities_;
};

// A bar with ETA and ns/day on a terminal; a plain line every 10% otherwise.
class ProgressReporter : public Observer {
 public:
  explicit ProgressReporter(std::FILE* out);
  // Ends an open bar line, so a message after a failed run starts on its own line.
  ~ProgressReporter() override;
  long every() const override { return 1; }
  bool needs_sample() const override { return false; }
  void begin(const RunInfo&) override;
  void observe(const RunInfo&, const State&, const Sample&) override;
  void finish(const RunInfo&, const State&, const RunTotals&) override;

 private:
  std::FILE* out_;
  bool terminal_;
  std::chrono::steady_clock::time_point start_, last_print_;
  int last_decile_ = -1;
  bool line_open_ = false;  // a bar was printed with \r and no newline yet
};

// Linear fit of the total energy against time.
struct EnergyStatistics {
  double drift = 0;                  // kJ/mol/ps per atom (slope of the fit / atoms)
  double rms_fluctuation = 0;        // kJ/mol, RMS about the mean (as gmx energy reports it)
  double detrended_fluctuation = 0;  // kJ/mol, RMS about the linear fit
  double mean = 0;                   // kJ/mol
};
EnergyStatistics energy_statistics(const std::vector<double>& time, const std::vector<double>& total, int atoms);

// Prints the end-of-run summary to `out` and writes summary.json into dir. Drift and fluctuation
// are those of the conserved energy (the total energy when no thermostat works).
class SummaryReporter : public Observer {
 public:
  // segments: the run's processes (one, or one per continue), each with facts about where it ran
  // (e.g. {"simd_target", "AVX2"}, {"threads", "2"}), this process's last. Its facts are printed next
  // to the cost and written to summary.json as strings, so every speed figure names its machine;
  // summary.json lists every segment's as well.
  SummaryReporter(const std::filesystem::path& dir, long every, std::FILE* out, std::vector<RunSegment> segments = {});
  long every() const override { return every_; }
  void observe(const RunInfo&, const State&, const Sample&) override;
  void finish(const RunInfo&, const State&, const RunTotals&) override;
  Carried checkpoint(const RunInfo&) override;
  void resume(const RunInfo&, const Carried&) override;

 private:
  long every_;
  std::filesystem::path dir_;
  std::FILE* out_;
  std::vector<RunSegment> segments_;
  std::vector<double> time_, conserved_, temperature_, constraint_rms_;
  std::vector<std::vector<double>> diagnostics_;
};

// The end of an energy minimisation (integrator diagnostics max_force, max_force_atom): final
// potential and its terms, the largest constrained force and the atom carrying it, whether it is
// below emtol; printed to `out` and written to summary.json in dir.
class MinimizationReporter : public Observer {
 public:
  MinimizationReporter(const std::filesystem::path& dir, double emtol, std::FILE* out);
  long every() const override { return 0; }
  void observe(const RunInfo&, const State&, const Sample& s) override { last_ = s; }
  void finish(const RunInfo&, const State&, const RunTotals&) override;

 private:
  std::filesystem::path dir_;
  double emtol_;
  std::FILE* out_;
  Sample last_;
};

}  // namespace vimd
