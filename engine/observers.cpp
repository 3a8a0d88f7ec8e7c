#include "engine/observers.hpp"

#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "engine/errors.hpp"
#include "engine/gromacs/gro.hpp"
#include "engine/gromacs/trr.hpp"

namespace vimd {
namespace {

std::string number(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.15g", x);
  return buf;
}

std::ofstream open_output(const std::filesystem::path& path, std::ios::openmode mode = std::ios::out) {
  std::ofstream out(path, mode);
  if (!out) throw InputError(path.string(), 0, std::string("cannot open for writing: ") + std::strerror(errno));
  return out;
}

// After a flush or close: a full disk or a file-size limit shows up here.
void check_stream(const std::ostream& out, const std::filesystem::path& path) {
  if (!out) throw std::runtime_error(path.string() + ": cannot write (disk full?): " + std::strerror(errno));
}

std::string duration_text(double seconds) {
  char buf[32];
  const long s = std::lround(seconds);
  if (s >= 3600)
    std::snprintf(buf, sizeof buf, "%ldh%02ldm", s / 3600, (s % 3600) / 60);
  else
    std::snprintf(buf, sizeof buf, "%ldm%02lds", s / 60, s % 60);
  return buf;
}

double ns_per_day(double simulated_ps, double wall_seconds) {
  return wall_seconds > 0 ? simulated_ps * 1e-3 / (wall_seconds / 86400.0) : 0.0;
}

}  // namespace

PendingFile::PendingFile(std::filesystem::path final_path)
    : final_(std::move(final_path)), partial_(final_.string() + ".partial") {}

void PendingFile::commit() const { std::filesystem::rename(partial_, final_); }

void truncate_to_checkpoint(const std::filesystem::path& partial, double bytes) {
  std::error_code error;
  const auto size = std::filesystem::file_size(partial, error);
  if (error || static_cast<double>(size) < bytes)
    throw InputError(partial.string(), 0,
                     error ? "missing: the stopped run's output cannot be continued"
                           : "shorter than at the checkpoint: the stopped run's output cannot be continued");
  std::filesystem::resize_file(partial, static_cast<std::uintmax_t>(bytes));
}

// ---------------------------------------------------------------- energies

EnergyWriter::EnergyWriter(const std::filesystem::path& dir, long every)
    : every_(every), xvg_file_(dir / "energy.xvg"), csv_file_(dir / "energy.csv") {}

void EnergyWriter::begin(const RunInfo& info) {
  xvg_ = open_output(xvg_file_.partial_path());
  csv_ = open_output(csv_file_.partial_path());
  std::vector<std::string> columns = {"potential", "kinetic", "total", "conserved", "temperature",
                                      "constraint_rms"};
  columns.insert(columns.end(), info.energy_names.begin(), info.energy_names.end());
  for (const char* m : {"momentum_x", "momentum_y", "momentum_z"}) columns.push_back(m);
  columns.insert(columns.end(), info.diagnostic_names.begin(), info.diagnostic_names.end());

  xvg_ << "# energies written by vimd (" << info.integrator.name() << ")\n"
       << "@    title \"vimd energies\"\n@    xaxis  label \"Time (ps)\"\n"
       << "@    yaxis  label \"kJ/mol, K, amu nm/ps\"\n@TYPE xy\n@ legend on\n";
  csv_ << "time";
  for (std::size_t k = 0; k < columns.size(); ++k) {
    xvg_ << "@ s" << k << " legend \"" << columns[k] << "\"\n";
    csv_ << ',' << columns[k];
  }
  csv_ << '\n';
  check_written();
}

void EnergyWriter::check_written() {
  check_stream(xvg_, xvg_file_.partial_path());
  check_stream(csv_, csv_file_.partial_path());
}

Carried EnergyWriter::checkpoint(const RunInfo&) {
  xvg_.flush();
  csv_.flush();
  check_written();
  Carried c;
  c.put("xvg_bytes", static_cast<double>(std::filesystem::file_size(xvg_file_.partial_path())));
  c.put("csv_bytes", static_cast<double>(std::filesystem::file_size(csv_file_.partial_path())));
  return c;
}

void EnergyWriter::resume(const RunInfo&, const Carried& c) {
  truncate_to_checkpoint(xvg_file_.partial_path(), c.number("xvg_bytes"));
  truncate_to_checkpoint(csv_file_.partial_path(), c.number("csv_bytes"));
  xvg_ = open_output(xvg_file_.partial_path(), std::ios::app);
  csv_ = open_output(csv_file_.partial_path(), std::ios::app);
}

void EnergyWriter::stop(const RunInfo&) {
  xvg_.close();
  csv_.close();
  check_written();
}

void EnergyWriter::observe(const RunInfo& info, const State&, const Sample& s) {
  std::vector<double> values = {s.time,      s.potential,   s.kinetic,       s.total,
                                 s.conserved, s.temperature, s.constraint_rms};
  values.insert(values.end(), s.energy_terms.begin(), s.energy_terms.end());
  for (int k = 0; k < 3; ++k) values.push_back(s.momentum[k]);
  if (s.diagnostics.empty())  // the start: no step has run yet, no NaN in the file
    values.resize(values.size() + info.diagnostic_names.size(), 0.0);
  else
    values.insert(values.end(), s.diagnostics.begin(), s.diagnostics.end());
  for (std::size_t k = 0; k < values.size(); ++k) {
    const std::string text = number(values[k]);
    xvg_ << (k ? "  " : "") << text;
    csv_ << (k ? "," : "") << text;
  }
  xvg_ << '\n';
  csv_ << '\n';
  check_written();
}

void EnergyWriter::finish(const RunInfo&, const State&, const RunTotals&) {
  xvg_.close();
  csv_.close();
  check_written();
  xvg_file_.commit();
  csv_file_.commit();
}

// ---------------------------------------------------------------- trajectory

TrajectoryWriter::TrajectoryWriter(const std::filesystem::path& dir, long every)
    : every_(every), file_(dir / "traj.trr") {}

TrajectoryWriter::~TrajectoryWriter() = default;

void TrajectoryWriter::begin(const RunInfo& info) {
  writer_ = std::make_unique<TrrWriter>(file_.partial_path(), info.problem.system.n_atoms());
}

Carried TrajectoryWriter::checkpoint(const RunInfo&) {
  Carried c;  // every frame is flushed as it is written
  c.put("trr_bytes", static_cast<double>(std::filesystem::file_size(file_.partial_path())));
  return c;
}

void TrajectoryWriter::resume(const RunInfo& info, const Carried& c) {
  truncate_to_checkpoint(file_.partial_path(), c.number("trr_bytes"));
  writer_ = std::make_unique<TrrWriter>(file_.partial_path(), info.problem.system.n_atoms(), /*append=*/true);
}

void TrajectoryWriter::stop(const RunInfo&) { writer_.reset(); }

void TrajectoryWriter::observe(const RunInfo& info, const State& state, const Sample&) {
  writer_->write(state.step, state.time, info.problem.system.box, &state.q, &state.v, &state.f);
}

void TrajectoryWriter::finish(const RunInfo&, const State&, const RunTotals&) {
  writer_.reset();
  file_.commit();
}

void FinalStructureWriter::finish(const RunInfo& info, const State& state, const RunTotals&) {
  const System& system = info.problem.system;
  write_gro(dir_ / "confout.gro", system.title, system, state.q, velocities_ ? &state.v : nullptr, system.box);
}

void FinalStructureWriter::fail(const RunInfo& info, const State& last_good) {
  const System& system = info.problem.system;
  if (last_good.q.cols() != system.n_atoms()) return;  // failed before the first step
  write_gro(dir_ / "last_good.gro", system.title + " (last good frame, step " + std::to_string(last_good.step) + ")",
            system, last_good.q, velocities_ ? &last_good.v : nullptr, system.box);
}

// ---------------------------------------------------------------- progress

ProgressReporter::ProgressReporter(std::FILE* out) : out_(out), terminal_(isatty(fileno(out))) {}

ProgressReporter::~ProgressReporter() {
  if (line_open_) std::fputc('\n', out_);
}

void ProgressReporter::begin(const RunInfo&) { start_ = last_print_ = std::chrono::steady_clock::now(); }

void ProgressReporter::observe(const RunInfo& info, const State& state, const Sample&) {
  const long total = info.last_step - info.start_step;
  const long done = state.step - info.start_step;
  if (total <= 0 || done == 0) return;
  const auto now = std::chrono::steady_clock::now();
  const double fraction = static_cast<double>(done) / total;
  const int decile = static_cast<int>(10 * fraction);
  if (terminal_) {
    if (done != total && now - last_print_ < std::chrono::milliseconds(250)) return;
  } else if (decile == last_decile_) {
    return;
  }
  last_print_ = now;
  last_decile_ = decile;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double eta = elapsed / fraction - elapsed;
  const double rate = ns_per_day(done * info.dt, elapsed);
  if (terminal_) {
    constexpr int width = 30;
    const int filled = static_cast<int>(width * fraction);
    std::string bar(filled, '#');
    bar.resize(width, '.');
    std::fprintf(out_, "\r[%s] %3.0f%%  step %ld/%ld  %.2f ns/day  ETA %s ", bar.c_str(), 100 * fraction, done, total,
                 rate, duration_text(eta).c_str());
    line_open_ = true;
  } else {
    std::fprintf(out_, "step %ld/%ld (%.0f%%)  %.2f ns/day  ETA %s\n", done, total, 100 * fraction, rate,
                 duration_text(eta).c_str());
  }
  std::fflush(out_);
}

void ProgressReporter::finish(const RunInfo&, const State&, const RunTotals&) {
  if (line_open_) std::fputc('\n', out_);
  line_open_ = false;
}

// ---------------------------------------------------------------- summary

EnergyStatistics energy_statistics(const std::vector<double>& time, const std::vector<double>& total, int atoms) {
  EnergyStatistics s;
  const std::size_t n = time.size();
  if (n == 0) return s;
  double mt = 0, me = 0;
  for (std::size_t k = 0; k < n; ++k) mt += time[k], me += total[k];
  mt /= n, me /= n;
  double stt = 0, ste = 0, see = 0;
  for (std::size_t k = 0; k < n; ++k) {
    stt += (time[k] - mt) * (time[k] - mt);
    ste += (time[k] - mt) * (total[k] - me);
    see += (total[k] - me) * (total[k] - me);
  }
  const double slope = stt > 0 ? ste / stt : 0.0;
  s.mean = me;
  s.drift = slope / atoms;
  s.rms_fluctuation = std::sqrt(see / n);
  s.detrended_fluctuation = std::sqrt(std::max(0.0, see - slope * ste) / n);
  return s;
}

SummaryReporter::SummaryReporter(const std::filesystem::path& dir, long every, std::FILE* out,
                                 std::vector<RunSegment> segments)
    : every_(every), dir_(dir), out_(out), segments_(std::move(segments)) {}

void SummaryReporter::observe(const RunInfo& info, const State&, const Sample& s) {
  time_.push_back(s.time);
  conserved_.push_back(s.conserved);  // the total energy itself unless a thermostat works on it
  temperature_.push_back(s.temperature);
  constraint_rms_.push_back(s.constraint_rms);
  diagnostics_.resize(info.diagnostic_names.size());
  for (std::size_t k = 0; k < s.diagnostics.size(); ++k)
    if (std::isfinite(s.diagnostics[k])) diagnostics_[k].push_back(s.diagnostics[k]);
}

Carried SummaryReporter::checkpoint(const RunInfo&) {
  Carried c;
  c.put("time", time_);
  c.put("conserved", conserved_);
  c.put("temperature", temperature_);
  c.put("constraint_rms", constraint_rms_);
  for (std::size_t k = 0; k < diagnostics_.size(); ++k) c.put("diagnostic_" + std::to_string(k), diagnostics_[k]);
  return c;
}

void SummaryReporter::resume(const RunInfo& info, const Carried& c) {
  time_ = c.values("time");
  conserved_ = c.values("conserved");
  temperature_ = c.values("temperature");
  constraint_rms_ = c.values("constraint_rms");
  diagnostics_.resize(info.diagnostic_names.size());
  for (std::size_t k = 0; k < diagnostics_.size(); ++k) diagnostics_[k] = c.values("diagnostic_" + std::to_string(k));
}

void SummaryReporter::finish(const RunInfo& info, const State&, const RunTotals& totals) {
  const int atoms = info.problem.system.n_atoms();
  const EnergyStatistics stats = energy_statistics(time_, conserved_, atoms);
  auto mean = [](const std::vector<double>& x) {
    double sum = 0;
    for (double v : x) sum += v;
    return x.empty() ? 0.0 : sum / x.size();
  };
  double max_constraint = 0;
  for (double c : constraint_rms_) max_constraint = std::max(max_constraint, c);
  const double steps = std::max<long>(totals.steps, 1);
  const double simulated = totals.steps * info.dt;
  const double rate = ns_per_day(simulated, totals.wall_seconds);

  std::fprintf(out_,
               "\nSummary (%s, %d atoms, %ld steps of %g ps = %g ps)\n"
               "  conserved energy  mean %.6f kJ/mol (total energy minus thermostat work)\n"
               "  energy drift      %.4e kJ/mol/ps per atom (linear fit over %zu samples)\n"
               "  RMS fluctuation   %.4e kJ/mol (about the mean), %.4e kJ/mol (about the fit)\n"
               "  temperature       mean %.2f K\n"
               "  constraints       max RMS relative deviation %.3e\n"
               "  cost              %.3f s wall, %.3f ms/step, %.2f ns/day\n"
               "                    %.2f force evaluations/step, %.2f Hessian-vector products/step, "
               "%ld neighbour-list searches and %ld prunings (%.3f ms/step)\n",
               info.integrator.name().c_str(), atoms, totals.steps, info.dt, simulated, stats.mean, stats.drift,
               time_.size(), stats.rms_fluctuation, stats.detrended_fluctuation, mean(temperature_), max_constraint,
               totals.wall_seconds, 1e3 * totals.wall_seconds / steps, rate, totals.force_evaluations / steps,
               totals.hessian_evaluations / steps, totals.neighbor_rebuilds, totals.neighbor_prunes,
               1e3 * totals.neighbor_build_seconds / steps);
  if (totals.single_precision_force_evaluations + totals.single_precision_hessian_evaluations > 0)
    std::fprintf(out_, "                    of which in single precision (mixed-precision solve): %.2f and %.2f\n",
                 totals.single_precision_force_evaluations / steps,
                 totals.single_precision_hessian_evaluations / steps);
  if (totals.mesh_seconds > 0)
    std::fprintf(out_, "                    PME mesh %.3f ms/step (%.1f%% of the wall time)\n",
                 1e3 * totals.mesh_seconds / steps, 100 * totals.mesh_seconds / totals.wall_seconds);
  for (const RunSegment& segment : segments_) {
    std::fprintf(out_, "  platform         ");
    if (segments_.size() > 1) std::fprintf(out_, " from step %ld:", segment.first_step);
    for (const auto& [key, value] : segment.platform) std::fprintf(out_, " %s %s;", key.c_str(), value.c_str());
    std::fprintf(out_, "\n");
  }
  for (std::size_t k = 0; k < diagnostics_.size(); ++k)
    std::fprintf(out_, "  %-17s mean %.4g\n", info.diagnostic_names[k].c_str(), mean(diagnostics_[k]));
  std::fflush(out_);

  PendingFile json(dir_ / "summary.json");
  {
    std::ofstream out = open_output(json.partial_path());
    out << "{\n  \"integrator\": \"" << info.integrator.name() << "\",\n"
        << "  \"atoms\": " << atoms << ",\n  \"steps\": " << totals.steps << ",\n"
        << "  \"dt\": " << number(info.dt) << ",\n"
        << "  \"mean_total_energy\": " << number(stats.mean) << ",\n"
        << "  \"drift_per_atom\": " << number(stats.drift) << ",\n"
        << "  \"rms_fluctuation\": " << number(stats.rms_fluctuation) << ",\n"
        << "  \"detrended_fluctuation\": " << number(stats.detrended_fluctuation) << ",\n"
        << "  \"mean_temperature\": " << number(mean(temperature_)) << ",\n"
        << "  \"max_constraint_rms\": " << number(max_constraint) << ",\n"
        << "  \"wall_seconds\": " << number(totals.wall_seconds) << ",\n"
        << "  \"ns_per_day\": " << number(rate) << ",\n"
        << "  \"force_evaluations_per_step\": " << number(totals.force_evaluations / steps) << ",\n"
        << "  \"hessian_evaluations_per_step\": " << number(totals.hessian_evaluations / steps) << ",\n"
        << "  \"single_precision_force_evaluations_per_step\": "
        << number(totals.single_precision_force_evaluations / steps) << ",\n"
        << "  \"single_precision_hessian_evaluations_per_step\": "
        << number(totals.single_precision_hessian_evaluations / steps) << ",\n"
        << "  \"neighbor_rebuilds\": " << totals.neighbor_rebuilds << ",\n"
        << "  \"neighbor_prunes\": " << totals.neighbor_prunes << ",\n"
        << "  \"neighbor_build_seconds\": " << number(totals.neighbor_build_seconds) << ",\n"
        << "  \"mesh_seconds\": " << number(totals.mesh_seconds) << ",\n"
        << "  \"mean_iterations\": " << number(totals.solver_iterations / steps);
    if (!segments_.empty()) {  // this process's facts, then every segment's (one line each)
      for (const auto& [key, value] : segments_.back().platform) out << ",\n  \"" << key << "\": \"" << value << "\"";
      out << ",\n  \"segments\": [";
      for (std::size_t k = 0; k < segments_.size(); ++k) {
        out << (k ? "," : "") << "\n    {\"first_step\": " << segments_[k].first_step;
        for (const auto& [key, value] : segments_[k].platform) out << ", \"" << key << "\": \"" << value << "\"";
        out << "}";
      }
      out << "\n  ]";
    }
    for (std::size_t k = 0; k < diagnostics_.size(); ++k)
      out << ",\n  \"mean_" << info.diagnostic_names[k] << "\": " << number(mean(diagnostics_[k]));
    out << "\n}\n";
    out.close();
    check_stream(out, json.partial_path());
  }
  json.commit();
}

// ---------------------------------------------------------------- minimisation

MinimizationReporter::MinimizationReporter(const std::filesystem::path& dir, double emtol, std::FILE* out)
    : dir_(dir), emtol_(emtol), out_(out) {}

void MinimizationReporter::finish(const RunInfo& info, const State&, const RunTotals& totals) {
  auto diagnostic = [&](const char* name) {
    for (std::size_t k = 0; k < info.diagnostic_names.size(); ++k)
      if (info.diagnostic_names[k] == name && k < last_.diagnostics.size()) return last_.diagnostics[k];
    throw std::logic_error(std::string("MinimizationReporter: the integrator reports no ") + name);
  };
  const double max_force = diagnostic("max_force");
  const int atom = static_cast<int>(diagnostic("max_force_atom"));  // 1-based
  const System& system = info.problem.system;
  const bool converged = max_force < emtol_;
  const std::string where = system.atom_names[atom - 1] + " of " + system.residue_names[atom - 1] +
                            std::to_string(system.residue_numbers[atom - 1]);

  std::fprintf(out_, "\nMinimisation (%s, %d atoms): %s after %ld steps\n", info.integrator.name().c_str(),
               system.n_atoms(), converged ? "converged" : "NOT converged", totals.steps);
  std::fprintf(out_, "  potential         %.6f kJ/mol\n", last_.potential);
  for (std::size_t k = 0; k < info.energy_names.size(); ++k)
    std::fprintf(out_, "    %-15s %.6f kJ/mol\n", info.energy_names[k].c_str(), last_.energy_terms[k]);
  std::fprintf(out_, "  max force         %.6g kJ/mol/nm on atom %d (%s); emtol %g\n", max_force, atom, where.c_str(),
               emtol_);
  if (!converged)
    std::fprintf(out_, "  the step limit or double precision ended the descent before emtol was reached\n");
  std::fflush(out_);

  PendingFile json(dir_ / "summary.json");
  {
    std::ofstream out = open_output(json.partial_path());
    out << "{\n  \"integrator\": \"" << info.integrator.name() << "\",\n  \"atoms\": " << system.n_atoms()
        << ",\n  \"steps\": " << totals.steps << ",\n  \"converged\": " << (converged ? "true" : "false")
        << ",\n  \"emtol\": " << number(emtol_) << ",\n  \"potential\": " << number(last_.potential);
    for (std::size_t k = 0; k < info.energy_names.size(); ++k)
      out << ",\n  \"" << info.energy_names[k] << "\": " << number(last_.energy_terms[k]);
    out << ",\n  \"max_force\": " << number(max_force) << ",\n  \"max_force_atom\": " << atom
        << ",\n  \"wall_seconds\": " << number(totals.wall_seconds)
        << ",\n  \"force_evaluations\": " << totals.force_evaluations << "\n}\n";
  }
  json.commit();
}

}  // namespace vimd

