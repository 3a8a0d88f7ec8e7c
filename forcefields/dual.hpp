#pragma once
// Forward-mode dual numbers for the bonded terms' Hessian–vector products: a term writes its
// gradient once as a template on the number type; evaluated on Dual with the direction u as the
// derivative part, the derivative parts of the gradient are exactly ∇²V u.
#include <cmath>

namespace vimd {

struct Dual {
  double v = 0, d = 0;
};
inline Dual operator+(Dual x, Dual y) { return {x.v + y.v, x.d + y.d}; }
inline Dual operator-(Dual x, Dual y) { return {x.v - y.v, x.d - y.d}; }
inline Dual operator-(Dual x) { return {-x.v, -x.d}; }
inline Dual operator*(Dual x, Dual y) { return {x.v * y.v, x.d * y.v + x.v * y.d}; }
inline Dual operator/(Dual x, Dual y) { return {x.v / y.v, (x.d * y.v - x.v * y.d) / (y.v * y.v)}; }
inline Dual operator*(double s, Dual x) { return {s * x.v, s * x.d}; }
inline Dual operator+(Dual x, double s) { return {x.v + s, x.d}; }
inline Dual operator+(double s, Dual x) { return {s + x.v, x.d}; }
inline Dual operator-(Dual x, double s) { return {x.v - s, x.d}; }
inline Dual operator-(double s, Dual x) { return {s - x.v, -x.d}; }
inline Dual sqrt(Dual x) {
  const double r = std::sqrt(x.v);
  return {r, x.d / (2 * r)};
}
inline Dual atan2(Dual y, Dual x) { return {std::atan2(y.v, x.v), (x.v * y.d - y.v * x.d) / (x.v * x.v + y.v * y.v)}; }
inline Dual sin(Dual x) { return {std::sin(x.v), std::cos(x.v) * x.d}; }
inline Dual cos(Dual x) { return {std::cos(x.v), -std::sin(x.v) * x.d}; }

// The plain value of a number, for branches that must not depend on the derivative part.
inline double value_of(double x) { return x; }
inline double value_of(Dual x) { return x.v; }

}  // namespace vimd
