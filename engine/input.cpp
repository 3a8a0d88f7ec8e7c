#include "engine/input.hpp"

#include <algorithm>
#include <array>
#include <cstdio>
#include <map>
#include <numbers>
#include <optional>
#include <random>
#include <set>

#include "engine/errors.hpp"
#include "engine/gromacs/gro.hpp"
#include "engine/integrator.hpp"
#include "engine/gromacs/topology.hpp"

namespace vimd {

Coords maxwell_boltzmann_velocities(const System& system, double temperature, std::uint64_t seed) {
  const int n = system.n_atoms();
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  Coords v(3, n);
  for (int i = 0; i < n; ++i) {
    // A virtual site has no velocity of its own (the engine gives it its atoms').
    const double sigma = system.mass[i] > 0 ? std::sqrt(kBoltzmann * temperature / system.mass[i]) : 0.0;
    for (int k = 0; k < 3; ++k) v(k, i) = normal(rng) * sigma;
  }
  const Vec3 momentum = v * system.mass;
  v.colwise() -= momentum / system.mass.sum();
  for (const VirtualSite& s : system.virtual_sites) v.col(s.site).setZero();
  scale_to_temperature(system, temperature, v);
  return v;
}

void require_velocities(const RunInput& input) {
  if (input.state.v.cols() == input.state.q.cols()) return;
  throw SettingError("integrator", "temperature",
                     input.config.structure.string() +
                         " has no velocities: set [integrator] temperature to generate them (a run needs them)");
}

void scale_to_temperature(const System& system, double temperature, Coords& v) {
  const double kinetic = kinetic_energy(system.mass, v);
  const double target = 0.5 * system.degrees_of_freedom() * kBoltzmann * temperature;
  if (kinetic > 0) v *= std::sqrt(target / kinetic);
}

namespace {

std::string format(const char* spec, double value) {
  char buf[64];
  std::snprintf(buf, sizeof buf, spec, value);
  return buf;
}

std::string describe_atom(const System& s, int i) {
  return std::to_string(i + 1) + " (" + std::to_string(s.residue_numbers[i]) + s.residue_names[i] + " " +
         s.atom_names[i] + ")";
}

// Overlapping atoms make the first force evaluation meaningless (or infinite).
void check_overlaps(const System& s, const Coords& x, const Box& box, const std::filesystem::path& gro) {
  // Virtual sites sit close to their atoms by construction: only the other atoms count.
  std::vector<bool> is_site(x.cols(), false);
  for (const VirtualSite& v : s.virtual_sites) is_site[v.site] = true;
  std::vector<int> atoms;  // indices into x of the atoms looked at
  for (int a = 0; a < x.cols(); ++a)
    if (!is_site[a]) atoms.push_back(a);
  const auto overlap = find_overlap(x(Eigen::all, atoms), box, 0.05);
  if (!overlap) return;
  const int i = atoms[overlap->i], j = atoms[overlap->j];
  const double distance = overlap->distance;
  const int pairs = overlap->pairs;
  throw InputError(gro.string(), j + 3,
                   "atoms " + describe_atom(s, i) + " at line " + std::to_string(i + 3) + " and " + describe_atom(s, j) +
                       " are " + format("%.4f", distance) +
                       " nm apart, closer than 0.05 nm: overlapping atoms give huge forces from the first step" +
                       (pairs > 1 ? " (" + std::to_string(pairs) + " such pairs in all)" : std::string()));
}

// As grompp: a harmonic bond that is not also constrained oscillates with period 2π√(μ/k); fewer
// than ten steps per period integrate it badly or not at all.
std::optional<std::string> time_step_warning(const System& s, const RunConfig& c) {
  std::set<std::pair<int, int>> constrained;
  for (const Constraint& k : s.constraints) constrained.emplace(std::minmax(k.i, k.j));
  const Bond* fastest = nullptr;
  double shortest = INFINITY;
  int too_fast = 0;
  for (const Bond& b : s.bonds) {
    // A bond to a virtual site does not oscillate on its own.
    if (b.k <= 0 || constrained.count(std::minmax(b.i, b.j)) || s.mass[b.i] <= 0 || s.mass[b.j] <= 0) continue;
    const double reduced_mass = s.mass[b.i] * s.mass[b.j] / (s.mass[b.i] + s.mass[b.j]);
    const double period = 2 * std::numbers::pi * std::sqrt(reduced_mass / b.k);  // ps
    if (period >= 10 * c.dynamics.dt) continue;
    ++too_fast;
    if (period < shortest) shortest = period, fastest = &b;
  }
  if (!fastest) return std::nullopt;
  return c.topology.string() + ": the bond between atoms " + describe_atom(s, fastest->i) + " and " +
         describe_atom(s, fastest->j) + " oscillates with a period of " + format("%.3g", shortest) +
         " ps, less than 10 times dt = " + format("%g", c.dynamics.dt) + " ps set in " + c.file.string() +
         " (" + std::to_string(too_fast) + " unconstrained bond(s) affected): the integration will be inaccurate " +
         "or unstable; constrain these bonds ([system] constraints = \"h-bonds\" or \"all-bonds\") or use dt <= " +
         format("%.2g", shortest / 10) + " ps";
}

BondConstraints bond_constraints(const RunConfig& c) {
  if (c.constraints == "h-bonds") return BondConstraints::h_bonds;
  if (c.constraints == "all-bonds") return BondConstraints::all_bonds;
  return BondConstraints::none;
}

// constraints = "h-bonds" on a system without hydrogens is a mistake, not a request for nothing.
void check_hydrogens(const System& s, const RunConfig& c) {
  if (c.constraints != "h-bonds") return;
  if (std::any_of(s.atom_names.begin(), s.atom_names.end(), hydrogen_like)) return;
  throw SettingError("system", "constraints",
                     "[system] constraints = \"h-bonds\", but no atom of " + c.topology.string() +
                         " is a hydrogen (grompp's rule: an atom name starting with H), so no bond would become a "
                         "constraint: use \"all-bonds\" or \"none\"");
}

}  // namespace

std::optional<Overlap> find_overlap(const Coords& x, const Box& box, double min_distance) {
  // Cells at least min_distance wide: a close pair is always in the same or neighbouring cells.
  std::array<long, 3> n_cells{};
  for (int k = 0; k < 3; ++k)
    n_cells[k] = box.length[k] > 0 ? std::max(1L, static_cast<long>(box.length[k] / min_distance)) : 0;
  const auto cell_of = [&](const Vec3& r) {
    std::array<long, 3> c{};
    for (int k = 0; k < 3; ++k) {
      if (n_cells[k] == 0) {
        c[k] = static_cast<long>(std::floor(r[k] / min_distance));
      } else {
        const double wrapped = r[k] - box.length[k] * std::floor(r[k] / box.length[k]);
        c[k] = std::min(n_cells[k] - 1, static_cast<long>(wrapped / box.length[k] * n_cells[k]));
      }
    }
    return c;
  };
  const int n = static_cast<int>(x.cols());
  std::map<std::array<long, 3>, std::vector<int>> cells;
  for (int i = 0; i < n; ++i) cells[cell_of(x.col(i))].push_back(i);

  std::optional<Overlap> found;
  int pairs = 0;
  for (int i = 0; i < n; ++i) {
    const auto home = cell_of(x.col(i));
    std::set<std::array<long, 3>> visited;  // small periodic grids reach one cell by several shifts
    for (long dx = -1; dx <= 1; ++dx)
      for (long dy = -1; dy <= 1; ++dy)
        for (long dz = -1; dz <= 1; ++dz) {
          std::array<long, 3> c{home[0] + dx, home[1] + dy, home[2] + dz};
          for (int k = 0; k < 3; ++k)
            if (n_cells[k] > 0) c[k] = (c[k] + n_cells[k]) % n_cells[k];
          if (!visited.insert(c).second) continue;
          const auto it = cells.find(c);
          if (it == cells.end()) continue;
          for (int j : it->second) {
            if (j <= i) continue;
            const double d = box.minimum_image(x.col(i) - x.col(j)).norm();
            if (d >= min_distance) continue;
            ++pairs;
            if (!found || std::pair(i, j) < std::pair(found->i, found->j)) found = Overlap{i, j, d, 0};
          }
        }
  }
  if (found) found->pairs = pairs;
  return found;
}

RunInput read_run_input(const std::filesystem::path& config_file, const ConfigSchema& schema,
                        const ConfigOverrides& overrides, const InputCheck& check) {
  RunInput in;
  in.config = read_config(config_file, schema, overrides);
  const RunConfig& c = in.config;
  in.system = read_topology(c.topology, bond_constraints(c), &in.warnings);
  GroFrame frame = read_gro(c.structure);
  c.located([&] {
    check_hydrogens(in.system, c);
    for (auto& warning : apply_structure(in.system, frame, c.structure, c.topology))
      in.warnings.push_back(std::move(warning));
    if (check)
      for (auto& warning : check(c, in.system, frame.box, static_cast<int>(frame.x.cols()) + 3))
        in.warnings.push_back(std::move(warning));
  });
  check_overlaps(in.system, frame.x, frame.box, c.structure);
  if (auto warning = time_step_warning(in.system, c)) in.warnings.push_back(std::move(*warning));

  in.state.q = frame.x;
  if (frame.v) {
    in.state.v = *frame.v;
  } else if (c.dynamics.temperature) {
    in.state.v = maxwell_boltzmann_velocities(in.system, *c.dynamics.temperature, c.dynamics.seed);
    in.velocities_generated = true;
  }
  return in;
}

}  // namespace vimd
