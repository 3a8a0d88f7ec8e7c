#include "forcefields/nonbonded/switch_function.hpp"

#include <cmath>
#include <sstream>

#include "engine/errors.hpp"

namespace vimd {

namespace {
double binomial(int n, int k) {
  double c = 1;
  for (int i = 1; i <= k; ++i) c = c * (n - k + i) / i;
  return c;
}
}  // namespace

SwitchFunction make_switch_function(double r_switch, double cutoff, int smoothness, const char* what) {
  if (!(r_switch >= 0 && r_switch < cutoff)) {
    std::ostringstream msg;
    msg << what << " (" << r_switch << " nm) must lie in [0, cutoff = " << cutoff << " nm) for a switched potential";
    throw SettingError("forcefield", what, msg.str());
  }
  if (smoothness < SwitchFunction::kMinSmoothness || smoothness > SwitchFunction::kMaxSmoothness)
    throw SettingError("forcefield", "switch_smoothness",
                       "switch_smoothness must be between " + std::to_string(SwitchFunction::kMinSmoothness) + " and " +
                           std::to_string(SwitchFunction::kMaxSmoothness) + ", got " + std::to_string(smoothness));
  SwitchFunction sw;
  sw.smoothness = smoothness;
  sw.r_switch = r_switch;
  const int k = smoothness;
  const double w = cutoff - r_switch;
  for (int n = 0; n <= k; ++n) {
    const int p = k + 1 + n;  // the power of x this coefficient multiplies
    const double smoothstep = (n % 2 ? -1 : 1) * binomial(k + n, n) * binomial(2 * k + 1, k - n);
    sw.value[n] = -smoothstep / std::pow(w, p);
    sw.slope[n] = p * sw.value[n];
    sw.curvature[n] = p * (p - 1) * sw.value[n];
  }
  return sw;
}

}  // namespace vimd
