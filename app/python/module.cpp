// `import vimd`: the engine from Python, a second composition root next to app/main.cpp that uses
// the same wiring (app/model.*). State arrays are NumPy views of the engine's own 3×N column-major
// Eigen matrices, which are exactly C-contiguous (N, 3) float64 buffers.
#include <omp.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <numeric>
#include <optional>
#include <stdexcept>
#include <thread>

#include "app/model.hpp"
#include "engine/errors.hpp"
#include "engine/observers.hpp"
#include "integrators/tableau.hpp"

namespace py = pybind11;
using namespace vimd;

namespace {

// Samples for summary() (every sample_every steps) and the user's callback (every callback_every).
class PythonObserver : public Observer {
 public:
  long every() const override { return callback ? std::gcd(sample_every, callback_every) : sample_every; }
  void observe(const RunInfo& info, const State& state, const Sample& s) override {
    last = s;
    has_last = true;
    const long done = state.step - info.first_step;
    if (done % sample_every == 0 && (done > 0 || time.empty())) {
      time.push_back(s.time);
      conserved.push_back(s.conserved);
      temperature.push_back(s.temperature);
    }
    if (callback && done > 0 && (done % callback_every == 0 || state.step == info.last_step)) callback();
  }
  long sample_every = 10, callback_every = 1;
  std::function<void()> callback;
  Sample last;
  bool has_last = false;
  std::vector<double> time, conserved, temperature;
};

// What a use of a Simulation does to it (PySimulation::check_use).
enum class Use { read, change };

class PySimulation {
 public:
  PySimulation(const std::filesystem::path& config, const ConfigOverrides& overrides)
      : model_(load_model(config, overrides)), run_(std::make_unique<Run>(*model_)) {
    // The input checks' warnings (the command line prints them) as Python's UserWarning.
    for (const std::string& warning : model_->input.warnings)
      if (PyErr_WarnEx(PyExc_UserWarning, warning.c_str(), 1) != 0) throw py::error_already_set();
    const long energy_every = model_->input.config.output.energy_every;
    sample_every_ = energy_every > 0 ? energy_every : 10;
    attach_observer();
  }

  State& state() { return model_->input.state; }
  // The state for a read that check_use allows (`what`: the read, for its message).
  const State& read_state(const std::string& what) const {
    check_use(Use::read, what);
    return model_->input.state;
  }
  double kinetic_energy(const State& state) const { return run_->integrator->kinetic_energy(run_->problem, state); }
  const Model& model() const { return *model_; }
  Run& run() { return *run_; }

  // A run in progress holds the simulation: its callback, on the running thread, may read the state
  // but neither change it nor start another run (the loop would go on from a state it did not make,
  // or from a freed one), and other threads may not use it at all. The GIL does not prevent this: it
  // passes to other threads while the callback runs Python code. Throws std::runtime_error
  // (RuntimeError) saying what was refused and what to do instead.
  void check_use(Use use, const std::string& what) const {
    if (!holder_) return;
    if (*holder_ != std::this_thread::get_id())
      throw std::runtime_error("vimd.Simulation: cannot " + what +
                               " here: a step() or run() in another thread holds this simulation until it returns. "
                               "Use a Simulation from one thread at a time (wait for the run, e.g. with "
                               "Thread.join()), or give each thread its own Simulation");
    if (use == Use::change)
      throw std::runtime_error("vimd.Simulation: cannot " + what +
                               " from a run() callback: the run in progress holds this simulation and would go on "
                               "from a state it did not make. A callback may read positions, velocities, forces(), "
                               "energy() and summary(); " + what + " after run() returns");
  }

  // Forces and energies at the current positions: the integrator's after a step, else computed.
  void ensure_forces() {
    if (forces_current_) return;
    Forces forces;
    model_->force_field->single_point(state().q, forces);
    state().f = forces.f;
    state().potential = forces.potential;
    state().energy_terms = forces.terms;
    forces_current_ = true;
  }

  void set_coords(Coords& target, py::array_t<double, py::array::c_style | py::array::forcecast> values,
                  const char* what) {
    check_use(Use::change, std::string("assign ") + what);
    const long n = model_->input.system.n_atoms();
    if (values.ndim() != 2 || values.shape(0) != n || values.shape(1) != 3)
      throw InputError("vimd.Simulation", 0,
                       std::string(what) + " must have shape (" + std::to_string(n) + ", 3), got " + shape(values));
    // Refused before anything changes: no force, energy or step is defined from a non-finite state.
    const Eigen::Map<const Coords> given(values.data(), 3, n);
    if (const int bad = first_non_finite(given); bad >= 0)
      throw InputError("vimd.Simulation", 0,
                       std::string(what) + " must be finite: " + model_->input.system.atom_label(bad) + " has " +
                           position_text(given, bad) + "; nothing was changed");
    std::copy(values.data(), values.data() + 3 * n, target.data());
    // A changed state starts afresh: constrained and its forces computed by the next run's init().
    forces_current_ = false;
    restart_run();
  }

  // `name`: the method called ("step()" or "run()"), for check_use's message.
  RunTotals advance(const char* name, long steps, std::function<void()> callback, long every) {
    check_use(Use::change, std::string("call ") + name);
    if (steps < 0) throw InputError("vimd.Simulation", 0, "the number of steps must not be negative");
    if (every < 1) throw InputError("vimd.Simulation", 0, "every must be at least 1");
    // A callback sees a stepped state, whose forces and energies are the integrator's: energy() and
    // forces() there must return them, not overwrite state.f (which the next step uses) with an
    // observation's, which differs in the last bits.
    observer_->callback = callback ? [this, callback] {
      forces_current_ = true;
      callback();
    } : std::function<void()>();
    observer_->callback_every = every;
    holder_ = std::this_thread::get_id();
    struct Release {
      PySimulation* s;
      ~Release() {
        s->observer_->callback = nullptr;
        s->holder_.reset();
      }
    } release{this};
    RunTotals t;
    try {
      t = run_->simulation->run(state(), steps);
    } catch (...) {
      // The simulation put the state back at the last good step; the next run starts afresh from
      // it, as from assigned positions, with forces computed there.
      forces_current_ = false;
      restart_run();
      throw;
    }
    forces_current_ = true;
    totals_.add(t);
    return t;
  }

  py::dict summary() {
    py::dict d;
    const System& system = model_->input.system;
    d["integrator"] = run_->integrator->name();
    d["atoms"] = system.n_atoms();
    d["steps"] = totals_.steps;
    d["time"] = state().time;
    if (observer_->has_last) {
      const Sample& s = observer_->last;
      d["potential"] = s.potential;
      d["kinetic"] = s.kinetic;
      d["total"] = s.total;
      d["conserved"] = s.conserved;
      d["temperature"] = s.temperature;
      d["constraint_rms"] = s.constraint_rms;
      const auto names = run_->integrator->diagnostic_names();
      for (std::size_t k = 0; k < names.size() && k < s.diagnostics.size(); ++k) d[names[k].c_str()] = s.diagnostics[k];
    }
    if (!observer_->time.empty()) {
      const EnergyStatistics stats = energy_statistics(observer_->time, observer_->conserved, system.n_atoms());
      double mean_temperature = 0;
      for (double t : observer_->temperature) mean_temperature += t / observer_->temperature.size();
      d["mean_conserved_energy"] = stats.mean;
      d["drift_per_atom"] = stats.drift;
      d["rms_fluctuation"] = stats.rms_fluctuation;
      d["detrended_fluctuation"] = stats.detrended_fluctuation;
      d["mean_temperature"] = mean_temperature;
      d["samples"] = observer_->time.size();
    }
    d["wall_seconds"] = totals_.wall_seconds;
    WorkCounters::fields([&](const char* name, auto counter) { d[name] = totals_.*counter; });
    d["solver_iterations"] = totals_.solver_iterations;
    return d;
  }

 private:
  static std::string shape(const py::array& a) {
    std::string s = "(";
    for (py::ssize_t k = 0; k < a.ndim(); ++k) s += (k ? ", " : "") + std::to_string(a.shape(k));
    return s + (a.ndim() == 1 ? ",)" : ")");
  }
  void attach_observer() {
    auto o = std::make_unique<PythonObserver>();
    o->sample_every = sample_every_;
    observer_ = o.get();
    run_->simulation->add_observer(std::move(o));
  }

  // A fresh Simulation, whose next run starts afresh (constrains the start, init()s the integrator),
  // with a new observer that keeps the series: the old observer goes with the old Simulation, so
  // its series are moved out first.
  void restart_run() {
    PythonObserver kept;
    kept.time = std::move(observer_->time);
    kept.conserved = std::move(observer_->conserved);
    kept.temperature = std::move(observer_->temperature);
    run_->restart();
    attach_observer();
    observer_->time = std::move(kept.time);
    observer_->conserved = std::move(kept.conserved);
    observer_->temperature = std::move(kept.temperature);
  }

  std::unique_ptr<Model> model_;
  std::unique_ptr<Run> run_;
  PythonObserver* observer_ = nullptr;  // owned by run_->simulation
  long sample_every_ = 10;
  bool forces_current_ = false;
  RunTotals totals_;
  std::optional<std::thread::id> holder_;  // the thread whose step() or run() is in progress
};

// A read-only (N, 3) view of a 3×N column-major matrix, kept alive by `owner`.
py::array view(const Coords& c, py::handle owner) {
  py::array_t<double> a({static_cast<py::ssize_t>(c.cols()), py::ssize_t{3}},
                        {static_cast<py::ssize_t>(3 * sizeof(double)), static_cast<py::ssize_t>(sizeof(double))},
                        c.data(), owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

ConfigValue to_config_value(const std::string& key, const py::handle& value) {
  // numbers.Integral / Real also admit NumPy scalars.
  const py::module_ numbers = py::module_::import("numbers");
  if (py::isinstance<py::bool_>(value)) return value.cast<bool>();
  if (py::isinstance(value, numbers.attr("Integral"))) return value.cast<long>();
  if (py::isinstance(value, numbers.attr("Real"))) return value.cast<double>();
  if (py::isinstance<py::str>(value)) return value.cast<std::string>();
  if (py::isinstance<TableauConfig>(value)) return value.cast<TableauConfig>();
  if (py::isinstance<py::sequence>(value)) return value.cast<std::vector<double>>();
  if (py::hasattr(value, "__fspath__")) return py::str(value.attr("__fspath__")()).cast<std::string>();
  throw InputError("vimd.Simulation", 0,
                   "setting '" + key + "' has an unsupported type " + py::str(value.get_type()).cast<std::string>());
}

ConfigOverrides to_overrides(const py::kwargs& kwargs) {
  ConfigOverrides overrides;
  for (const auto& [k, v] : kwargs) {
    std::string key = k.cast<std::string>();
    if (key == "integrator") key = "type";  // the table's name reads better than its key
    overrides.emplace_back(key, to_config_value(key, v));
  }
  return overrides;
}

py::dict energy_terms(PySimulation& sim) {
  sim.ensure_forces();
  const State& state = sim.state();
  const auto& names = sim.model().force_field->energy_names();
  py::dict d;
  for (std::size_t k = 0; k < names.size(); ++k) d[names[k].c_str()] = state.energy_terms[k];
  d["potential"] = state.potential;
  return d;
}

}  // namespace

PYBIND11_MODULE(vimd, m) {
  m.doc() = "vimd: molecular dynamics with RATTLE and variational integrators of any order";
  static py::exception<InputError> input_error(m, "InputError", PyExc_ValueError);
  static py::exception<ConvergenceError> convergence_error(m, "ConvergenceError", PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InputError& e) {
      PyErr_SetString(input_error.ptr(), e.what());
    } catch (const ConvergenceError& e) {
      PyErr_SetString(convergence_error.ptr(), e.what());
    }
  });

  py::class_<TableauConfig>(m, "Tableau", "An explicit Runge-Kutta tableau, checked against its order conditions")
      .def(py::init([](std::vector<std::vector<double>> a, std::vector<double> b, std::vector<double> c, int order) {
             TableauConfig t{std::move(a), std::move(b), std::move(c), order, 0};
             if (t.c.empty())
               for (const auto& row : t.a) {
                 double sum = 0;
                 for (double x : row) sum += x;
                 t.c.push_back(sum);
               }
             tableau_from_config(t, "vimd.Tableau");  // throws InputError naming the problem
             return t;
           }),
           py::arg("a"), py::arg("b"), py::arg("c") = std::vector<double>{}, py::arg("order"))
      .def_readonly("a", &TableauConfig::a)
      .def_readonly("b", &TableauConfig::b)
      .def_readonly("c", &TableauConfig::c)
      .def_readonly("order", &TableauConfig::order)
      .def("__repr__", [](const TableauConfig& t) {
        return "vimd.Tableau(" + std::to_string(t.b.size()) + " stages, order " + std::to_string(t.order) + ")";
      });
  m.def("tableau_names", &tableau_names, "names of the built-in tableaus (method = ...)");
  m.def("set_threads", [](int n) { omp_set_num_threads(n); }, py::arg("n"), "OpenMP threads for the force loops");

  py::class_<PySimulation>(m, "Simulation", R"doc(
A run file (TOML, as for `vimd run`) with settings overridden by keyword, e.g.
  sim = vimd.Simulation("run.toml", integrator="vi", method="rk6", dt=0.001)
  sim = vimd.Simulation("run.toml", integrator="vi", tableau=vimd.Tableau(a, b, order=2))
Any key of the file's tables can be given; `integrator` stands for [integrator] type.)doc")
      .def(py::init([](const std::filesystem::path& config, const py::kwargs& kwargs) {
             return std::make_unique<PySimulation>(config, to_overrides(kwargs));
           }),
           py::arg("config"))
      .def(
          "energy",
          [](PySimulation& s) {
            s.check_use(Use::read, "call energy()");
            return energy_terms(s);
          },
          "potential-energy terms at the current positions (kJ/mol), keyed as `vimd energy --json`")
      .def(
          "forces",
          [](py::object self) {
            auto& s = self.cast<PySimulation&>();
            s.check_use(Use::read, "call forces()");
            s.ensure_forces();
            return view(s.state().f, self);
          },
          "forces (N, 3) in kJ/mol/nm: a read-only view, valid until the next step (np.array(...) keeps it)")
      .def_property(
          "positions",
          [](py::object self) { return view(self.cast<PySimulation&>().read_state("read positions").q, self); },
          [](PySimulation& s, py::array_t<double, py::array::c_style | py::array::forcecast> x) {
            s.set_coords(s.state().q, x, "positions");
          },
          "positions (N, 3) in nm: a read-only view of the engine's array, valid until the next step; "
          "assigning copies new positions in (constrained at the next step)")
      .def_property(
          "velocities",
          [](py::object self) { return view(self.cast<PySimulation&>().read_state("read velocities").v, self); },
          [](PySimulation& s, py::array_t<double, py::array::c_style | py::array::forcecast> v) {
            s.set_coords(s.state().v, v, "velocities");
          },
          "velocities (N, 3) in nm/ps (on-step; SHAKE's are half-step), read-only view; assigning copies")
      .def(
          "step", [](PySimulation& s, long n) { s.advance("step()", n, nullptr, 1); }, py::arg("n") = 1,
          "advance n steps (a minimiser stops early once converged)")
      .def(
          "run",
          [](py::object self, std::optional<long> n, std::optional<py::function> callback, long every) {
            auto& s = self.cast<PySimulation&>();
            std::function<void()> call;
            if (callback) call = [f = *callback, self]() { f(self); };
            s.advance("run()", n.value_or(s.model().input.config.dynamics.steps), call, every);
          },
          py::arg("n") = py::none(), py::arg("callback") = py::none(), py::arg("every") = 1,
          "advance n steps (default: the file's steps), calling callback(sim) after every `every`-th step "
          "and after the last; the callback may read the state, but changing it or stepping raises RuntimeError, "
          "as does any use from another thread while the run is in progress")
      .def("summary",
           [](PySimulation& s) {
             s.check_use(Use::read, "call summary()");
             return s.summary();
           },
           "the current observables, the integrator's diagnostics, and energy statistics and cost over all runs")
      .def_property_readonly("time", [](PySimulation& s) { return s.read_state("read time").time; }, "ps")
      .def_property_readonly("current_step", [](PySimulation& s) { return s.read_state("read current_step").step; })
      .def_property_readonly("n_atoms", [](PySimulation& s) { return s.model().input.system.n_atoms(); })
      .def_property_readonly("integrator", [](PySimulation& s) { return s.run().integrator->name(); })
      .def_property_readonly("masses",
                             [](PySimulation& s) {
                               const Eigen::VectorXd& m = s.model().input.system.mass;
                               return py::array_t<double>(m.size(), m.data());
                             })
      .def_property_readonly("box",
                             [](PySimulation& s) {
                               const Vec3& l = s.model().input.system.box.length;
                               return py::array_t<double>(3, l.data());
                             })
      .def_property_readonly("structure", [](PySimulation& s) { return s.model().input.config.structure; })
      .def_property_readonly("topology", [](PySimulation& s) { return s.model().input.config.topology; })
      .def("kinetic_energy",
           [](PySimulation& s) { return s.kinetic_energy(s.read_state("call kinetic_energy()")); })
      .def("temperature", [](PySimulation& s) {
        const double k = s.kinetic_energy(s.read_state("call temperature()"));
        const int dof = s.model().input.system.degrees_of_freedom();
        return dof > 0 ? 2 * k / (dof * kBoltzmann) : 0.0;
      });
}
