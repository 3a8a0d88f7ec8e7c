#include "integrators/thermostat.hpp"

#include <cmath>
#include <stdexcept>
#include <vector>

#include "engine/errors.hpp"
#include "engine/integrator.hpp"

namespace vimd {

namespace {
std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
}  // namespace

std::array<std::uint64_t, 4> RandomStream::seeded(std::uint64_t seed) {
  std::array<std::uint64_t, 4> s;
  for (auto& word : s) {
    std::uint64_t z = (seed += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    word = z ^ (z >> 31);
  }
  return s;
}

void VRescaleThermostat::save(Carried& carried) const {
  std::vector<double> words;
  for (std::uint64_t word : state_.rng) {
    words.push_back(static_cast<double>(word >> 32));
    words.push_back(static_cast<double>(word & 0xffffffffULL));
  }
  carried.put("thermostat_rng", std::move(words));
  carried.put("thermostat_work", state_.work);
}

void VRescaleThermostat::load(const Carried& carried) {
  const std::vector<double>& words = carried.values("thermostat_rng");
  if (words.size() != 2 * state_.rng.size()) throw std::runtime_error("checkpoint: entry \"thermostat_rng\" has the wrong size");
  for (std::size_t k = 0; k < state_.rng.size(); ++k)
    state_.rng[k] = (static_cast<std::uint64_t>(words[2 * k]) << 32) | static_cast<std::uint64_t>(words[2 * k + 1]);
  state_.work = carried.number("thermostat_work");
}

double RandomStream::uniform() {
  const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
  const std::uint64_t t = s_[1] << 17;
  s_[2] ^= s_[0];
  s_[3] ^= s_[1];
  s_[1] ^= s_[2];
  s_[0] ^= s_[3];
  s_[2] ^= t;
  s_[3] = rotl(s_[3], 45);
  return ((result >> 11) + 0.5) * 0x1.0p-53;  // never 0 or 1: safe for log
}

double RandomStream::normal() {
  const double r = std::sqrt(-2.0 * std::log(uniform()));
  return r * std::cos(2.0 * M_PI * uniform());
}

double RandomStream::gamma(double shape) {
  if (shape < 1) return gamma(shape + 1) * std::pow(uniform(), 1.0 / shape);
  const double d = shape - 1.0 / 3.0, c = 1.0 / std::sqrt(9.0 * d);
  for (;;) {
    const double x = normal();
    double v = 1 + c * x;
    if (v <= 0) continue;
    v = v * v * v;
    const double u = uniform();
    if (u < 1 - 0.0331 * x * x * x * x || std::log(u) < 0.5 * x * x + d * (1 - v + std::log(v))) return d * v;
  }
}

double RandomStream::chi_squared(int n) { return n > 0 ? 2.0 * gamma(0.5 * n) : 0.0; }

VRescaleThermostat::VRescaleThermostat(double temperature, double tau_t, double dt, std::uint64_t seed)
    : temperature_(temperature), decay_(tau_t > 0 ? std::exp(-dt / tau_t) : 0.0) {
  state_.rng = RandomStream::seeded(seed);
}

double VRescaleThermostat::resample(double kinetic, int dof) {
  // Bussi et al. 2007, eq. (A7): the exact solution of the kinetic-energy SDE over one step.
  RandomStream random(state_.rng);
  const double target = 0.5 * dof * kBoltzmann * temperature_;
  const double r = random.normal();
  const double noise = random.chi_squared(dof - 1);
  const double c = decay_;
  const double k = kinetic + (1 - c) * (target * (noise + r * r) / dof - kinetic) +
                   2 * r * std::sqrt(kinetic * target / dof * (1 - c) * c);
  return std::max(k, 0.0);
}

void VRescaleThermostat::apply(const Eigen::VectorXd& mass, int dof, Coords& v) {
  const double kinetic = kinetic_energy(mass, v);
  if (!(kinetic > 0) || dof < 1) return;  // nothing to scale (a system at rest stays at rest)
  const double target = resample(kinetic, dof);
  v *= std::sqrt(target / kinetic);
  state_.work += target - kinetic;
}

std::optional<VRescaleThermostat> make_thermostat(const IntegratorConfig& config) {
  if (config.thermostat == "none") return std::nullopt;
  if (config.thermostat != "v-rescale")
    throw SettingError("integrator", "thermostat",
                       "thermostat = \"" + config.thermostat + "\" is not supported (none, v-rescale)");
  if (!config.temperature)
    throw SettingError("integrator", "temperature", "thermostat = \"v-rescale\" needs the reference temperature (K)");
  if (!(*config.temperature > 0))
    throw SettingError("integrator", "temperature", "thermostat temperature must be positive (K)");
  if (!(config.tau_t >= 0)) throw SettingError("integrator", "tau_t", "tau_t must not be negative (ps)");
  return VRescaleThermostat(*config.temperature, config.tau_t, config.dt, config.seed);
}

void refuse_thermostat(const IntegratorConfig& config, const std::string& why) {
  if (config.thermostat != "none")
    throw SettingError("integrator", "thermostat",
                       "type = \"" + config.type + "\" cannot use thermostat = \"" + config.thermostat + "\": " + why);
}

}  // namespace vimd
