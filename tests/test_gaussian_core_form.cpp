// A pair form that lives only in this file, a Gaussian core φ = qq exp(−α r²), run by the SIMD pair
// loops (forcefields/nonbonded/pair_loops-inl.h) on every target this CPU runs: its forces and
// Hessian–vector products against finite differences, its energy against a direct sum. A new form
// is its constants and its kernels; the loops, which know no form by name, take it as it is. The
// per-target part is compiled here for each target (Highway's foreach_target re-includes this file).
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "tests/test_gaussian_core_form.cpp"
#include "hwy/foreach_target.h"  // IWYU pragma: keep

#include <array>
#include <cstdint>
#include <string>
#include <tuple>
#include <vector>

#include "forcefields/nonbonded/kernel_combinations-inl.h"
#include "forcefields/nonbonded/pair_form.hpp"
#include "forcefields/nonbonded/pair_loops-inl.h"
#include "hwy/highway.h"

#ifndef VIMD_TESTS_GAUSSIAN_CORE_CONSTANTS_
#define VIMD_TESTS_GAUSSIAN_CORE_CONSTANTS_
namespace vimd::testing {

enum class GaussianVariant { plain };

// The constants, as any form's (pair_form.hpp).
struct GaussianCore {
  static constexpr PairEnergy kEnergy = PairEnergy::coulomb;
  static constexpr PairParameters kParameters = PairParameters::charge_product;
  static constexpr std::array kVariants{GaussianVariant::plain};
  static GaussianCore from_config(const ForceFieldConfig&) { return {}; }
  bool present() const { return true; }
  GaussianVariant variant() const { return GaussianVariant::plain; }
  int continuity(double) const { return -1; }
  std::string describe(double) const { return "Gaussian core"; }

  double prefactor = 1.0;  // kJ/mol e⁻²: qq = prefactor q_i q_j
  double alpha = 20.0;     // nm⁻²: exp(−α rc²) ≈ 1e-7 at rc = 0.9 nm, so that the cut-off hardly matters
};
static_assert(FormConstants<GaussianCore>);

using GaussianView = PairViewOf<double, std::tuple<GaussianCore>>;

}  // namespace vimd::testing
#endif

HWY_BEFORE_NAMESPACE();
namespace vimd {
namespace HWY_NAMESPACE {

// The kernels, as any form's: φ = qq e^(−αr²), g = −φ'/r = 2α φ, a = φ'/r = −2α φ, b = (φ'' − φ'/r)/r² = 4α² φ.
template <>
struct PairForm<testing::GaussianCore, testing::GaussianVariant::plain> {
  template <class T>
  static HWY_INLINE void energy_force(const testing::GaussianCore& k, const ChargeProduct<T>& pair,
                                      const PairDistance<T>& p, T& v, T& g) {
    v = pair.qq * simd_exp((-k.alpha) * p.r2);
    g = (2 * k.alpha) * v;
  }
  template <class T>
  static HWY_INLINE void hessian(const testing::GaussianCore& k, const ChargeProduct<T>& pair, const PairDistance<T>& p,
                                 T& a, T& b) {
    const T v = pair.qq * simd_exp((-k.alpha) * p.r2);
    a = (-2 * k.alpha) * v;
    b = (4 * k.alpha * k.alpha) * v;
  }
};

using GaussianKernel = Sum<PairForm<testing::GaussianCore, testing::GaussianVariant::plain>>;

// Forces added to (fx, fy, fz) and the energies of the halves [0, halves), with the inside masks.
void GaussianForces(const testing::GaussianView& view, int halves, double* fx, double* fy, double* fz,
                    double* half_energy, std::uint32_t* masks) {
  std::vector<double> half_vdw(halves);  // the form reports to Coulomb
  force_halves<GaussianKernel, double, true, true>(view, 0, halves, fx, fy, fz, half_vdw.data(), half_energy, masks);
}
// ∇²V u added to (ox, oy, oz) over the pairs the masks select.
void GaussianHessian(const testing::GaussianView& view, int halves, const double* ux, const double* uy,
                     const double* uz, const std::uint32_t* masks, double* ox, double* oy, double* oz) {
  hessian_halves<GaussianKernel, double>(view, ux, uy, uz, masks, 0, halves, ox, oy, oz);
}

}  // namespace HWY_NAMESPACE
}  // namespace vimd
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "forcefields/nonbonded/neighbor_list.hpp"
#include "simd/targets.hpp"

namespace vimd {

HWY_EXPORT(GaussianForces);
HWY_EXPORT(GaussianHessian);

namespace {

using testing::GaussianCore;

constexpr int kAtoms = 60;
constexpr double kCutoff = 0.9, kSkin = 0.1;

// A periodic box of charged atoms, its cluster-pair list built once at the start positions (moves
// below the skin keep it valid), and the Gaussian core's energy, forces and Hessian–vector products
// at any positions through the per-target kernels.
class GaussianCoreSystem {
 public:
  GaussianCoreSystem() : list_(box(), kCutoff, kSkin, std::vector<std::vector<int>>(kAtoms)) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> position(0.0, 2.0), charge(-1.0, 1.0);
    q0_.resize(3, kAtoms);
    charge_.resize(kAtoms);
    for (int a = 0; a < kAtoms; ++a) {
      for (int k = 0; k < 3; ++k) q0_(k, a) = position(rng);
      charge_[a] = charge(rng);
    }
    list_.build(q0_);
    const int slots = list_.n_slots();
    slot_charge_.assign(slots, 0.0);
    for (int s = 0; s < slots; ++s)
      if (const int a = list_.slot_atom()[s]; a >= 0) slot_charge_[s] = charge_[a];
    slot_type_.assign(slots, 0);
    x_.resize(slots);
    y_.resize(slots);
    z_.resize(slots);
  }

  static Box box() { return Box{Vec3(2.0, 2.0, 2.0)}; }
  const Coords& start() const { return q0_; }

  // E(q); forces into f and the inside masks into masks where given.
  double energy(const Coords& q, Coords* f = nullptr, std::vector<std::uint32_t>* masks = nullptr) {
    const testing::GaussianView view = view_at(q);
    const int slots = list_.n_slots(), halves = list_.n_halves();
    std::vector<double> fx(slots), fy(slots), fz(slots), half_energy(halves);
    std::vector<std::uint32_t> inside(list_.entries().size());
    HWY_DYNAMIC_DISPATCH(GaussianForces)(view, halves, fx.data(), fy.data(), fz.data(), half_energy.data(), inside.data());
    if (f) *f = unpack(fx, fy, fz);
    if (masks) *masks = inside;
    double e = 0;
    for (double h : half_energy) e += h;
    return e;
  }

  // ∇²V(q) u.
  Coords hessian_vector(const Coords& q, const Coords& u) {
    std::vector<std::uint32_t> masks;
    energy(q, nullptr, &masks);
    const testing::GaussianView view = view_at(q);
    const int slots = list_.n_slots();
    std::vector<double> ux(slots), uy(slots), uz(slots), ox(slots), oy(slots), oz(slots);
    list_.pack_vectors(u, ux.data(), uy.data(), uz.data());
    HWY_DYNAMIC_DISPATCH(GaussianHessian)(view, list_.n_halves(), ux.data(), uy.data(), uz.data(), masks.data(),
                                          ox.data(), oy.data(), oz.data());
    return unpack(ox, oy, oz);
  }

  // Σ over pairs within the cut-off (minimum image) of q_i q_j e^(−α r²), written independently;
  // scale: the sum of the terms' magnitudes, what the sum's rounding is measured against.
  double direct_energy(const Coords& q, double& scale) const {
    const GaussianCore form;
    double e = 0;
    scale = 0;
    for (int i = 0; i < kAtoms; ++i)
      for (int j = i + 1; j < kAtoms; ++j) {
        const double r2 = box().minimum_image(q.col(i) - q.col(j)).squaredNorm();
        if (r2 >= kCutoff * kCutoff) continue;
        const double term = form.prefactor * charge_[i] * charge_[j] * std::exp(-form.alpha * r2);
        e += term;
        scale += std::abs(term);
      }
    return e;
  }

 private:
  testing::GaussianView view_at(const Coords& q) {
    list_.pack_positions(q, x_.data(), y_.data(), z_.data());
    testing::GaussianView view{};
    view.x = x_.data();
    view.y = y_.data();
    view.z = z_.data();
    view.entries = list_.entries().data();
    view.half_start = list_.half_start().data();
    view.shifts = list_.shift_vectors().data();
    view.cutoff2 = kCutoff * kCutoff;
    view.charge = slot_charge_.data();
    view.type = slot_type_.data();
    view.n_slots = static_cast<std::size_t>(list_.n_slots());
    view.forms = std::tuple<GaussianCore>{};
    return view;
  }
  Coords unpack(const std::vector<double>& x, const std::vector<double>& y, const std::vector<double>& z) const {
    Coords out = Coords::Zero(3, kAtoms);
    for (int a = 0; a < kAtoms; ++a) {
      const int s = list_.atom_slot()[a];
      out.col(a) = Vec3(x[s], y[s], z[s]);
    }
    return out;
  }

  NeighborList list_;
  Coords q0_;
  std::vector<double> charge_, slot_charge_;
  std::vector<int> slot_type_;
  std::vector<double> x_, y_, z_;
};

class GaussianCoreForm : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override { simd::use_target(GetParam()); }
  void TearDown() override { simd::use_target(""); }
};

TEST_P(GaussianCoreForm, EnergyIsTheDirectSum) {
  GaussianCoreSystem system;
  double scale;
  const double direct = system.direct_energy(system.start(), scale);
  ASSERT_GT(scale, 1.0);  // pairs inside the cut-off, not a vacuous comparison
  EXPECT_NEAR(system.energy(system.start()), direct, 1e-13 * scale);
}

TEST_P(GaussianCoreForm, ForcesAreMinusTheEnergyGradient) {
  GaussianCoreSystem system;
  Coords f;
  system.energy(system.start(), &f);
  const double h = 1e-5;
  double worst = 0;
  for (int a = 0; a < kAtoms; ++a)
    for (int k = 0; k < 3; ++k) {
      Coords plus = system.start(), minus = system.start();
      plus(k, a) += h;
      minus(k, a) -= h;
      const double slope = (system.energy(plus) - system.energy(minus)) / (2 * h);
      worst = std::max(worst, std::abs(f(k, a) + slope));
    }
  EXPECT_LT(worst, 1e-6 * f.cwiseAbs().maxCoeff()) << "largest |F + dE/dx|";
}

TEST_P(GaussianCoreForm, HessianVectorProductIsTheForcesDerivative) {
  GaussianCoreSystem system;
  std::mt19937 rng(11);
  std::normal_distribution<double> normal;
  Coords u(3, kAtoms);
  for (int a = 0; a < kAtoms; ++a)
    for (int k = 0; k < 3; ++k) u(k, a) = normal(rng);
  const Coords hu = system.hessian_vector(system.start(), u);
  const double h = 1e-5;
  Coords f_plus, f_minus;
  system.energy(system.start() + h * u, &f_plus);
  system.energy(system.start() - h * u, &f_minus);
  const Coords expected = -(f_plus - f_minus) / (2 * h);
  EXPECT_LT((hu - expected).cwiseAbs().maxCoeff(), 1e-6 * expected.cwiseAbs().maxCoeff());
}

INSTANTIATE_TEST_SUITE_P(EveryAvailableSimdTarget, GaussianCoreForm, ::testing::ValuesIn(simd::available_targets()),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace vimd
#endif  // HWY_ONCE
