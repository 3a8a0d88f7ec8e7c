#!/usr/bin/python3
"""Fits the single-precision Ewald real-space corrections of forcefields/ewald-inl.h and prints their
coefficients and errors (run it to check them or to refit; it writes nothing).

In single precision vimd, like GROMACS's nbnxm kernels, writes the real-space pair terms as the bare
Coulomb term minus a smooth correction, so that a pair needs one rational function of z = (βr)² and
no exp or erfc:
    erfc(βr)/r = 1/r − β E(z),                 E(z) = erf(x)/x,
    (erfc(βr)/r + 2β/√π e^(−z))/r² = 1/r³ − β³ F(z),   F(z) = (erf(x)/x − 2/√π e^(−z))/z,   x = √z.
Both are even, entire functions of x, so rationals P(z)/Q(z) fit them well on 0 ≤ x ≤ X_MAX (β·cut-off
beyond it falls back to erfc). Fitted by iteratively reweighted linear least squares toward the
minimax relative error, on mpmath's values; errors are reported in exact arithmetic and for the
float32 Horner evaluation the kernel does.
    /usr/bin/python3 validation/fit_ewald_float.py
"""
import mpmath
import numpy as np

X_MAX = 4.5  # EwaldRealSpace::kRationalRange
DEGREES = {"E": (5, 6), "F": (5, 6)}
mpmath.mp.dps = 40


def exact(name, z):
    x = mpmath.sqrt(z)
    if z == 0:
        return 2 / mpmath.sqrt(mpmath.pi) * (1 if name == "E" else mpmath.mpf(2) / 3)
    erf_x = mpmath.erf(x) / x
    if name == "E":
        return erf_x
    return (erf_x - 2 / mpmath.sqrt(mpmath.pi) * mpmath.exp(-z)) / z


def error_scale(name, zs, f):
    """What an error of the fit is measured against: the bare Coulomb term it is subtracted from, 1/r
    (E) and 1/r³ (F) in units of β and β³, i.e. an error δ of E counts as δ·x, of F as δ·x³; never less
    than 1 % of the function itself, so that short distances stay accurate too."""
    x = np.sqrt(zs)
    return 1 / np.maximum(x if name == "E" else x**3, 0.01 * f)


def fit(name, m, n, nodes=4000, rounds=30):
    # Chebyshev nodes in z over [0, X_MAX²]
    zs = (1 - np.cos(np.pi * (np.arange(nodes) + 0.5) / nodes)) / 2 * X_MAX**2
    f = np.array([float(exact(name, mpmath.mpf(z))) for z in zs])
    scale = error_scale(name, zs, f)
    q_prev = np.ones_like(zs)
    weight = np.ones_like(zs)
    for _ in range(rounds):
        # P(z) − f Q(z) ≈ 0 with Q(0) = 1, divided by Q_prev and the scale (Sanathanan–Koerner)
        cols = [zs**k for k in range(m + 1)] + [-f * zs**k for k in range(1, n + 1)]
        a = np.stack(cols, axis=1) / (scale * q_prev)[:, None] * weight[:, None]
        b = f / (scale * q_prev) * weight
        c, *_ = np.linalg.lstsq(a, b, rcond=None)
        p, q = c[: m + 1], np.concatenate([[1.0], c[m + 1:]])
        q_prev = np.polyval(q[::-1], zs)
        err = np.abs(np.polyval(p[::-1], zs) / q_prev - f) / scale
        weight *= np.sqrt(err / err.max() + 1e-3)  # Lawson's step: push the weight to where the error peaks
        weight /= weight.max()
    return p, q


def horner32(c, z):
    acc = np.float32(c[-1])
    for k in range(len(c) - 2, -1, -1):
        acc = np.float32(acc * z + np.float32(c[k]))
    return acc


def main():
    zs_check = np.linspace(0, X_MAX**2, 20001)
    for name, (m, n) in DEGREES.items():
        p, q = fit(name, m, n)
        f = np.array([float(exact(name, mpmath.mpf(z))) for z in zs_check])
        scale = error_scale(name, zs_check, f)
        exact_err = (np.abs(np.polyval(p[::-1], zs_check) / np.polyval(q[::-1], zs_check) - f) / scale).max()
        z32 = zs_check.astype(np.float32)
        f32 = np.array([horner32(p, z) / horner32(q, z) for z in z32], dtype=np.float64)
        f_at_z32 = np.array([float(exact(name, mpmath.mpf(float(z)))) for z in z32])
        float_err = (np.abs(f32 - f_at_z32) / error_scale(name, z32.astype(np.float64), f_at_z32)).max()
        print(f"{name}: P degree {m}, Q degree {n}, 0 <= x <= {X_MAX}: max error against the bare Coulomb term "
              f"{exact_err:.2e} exact, {float_err:.2e} in float32")
        print("  P:", ", ".join(f"{v:.9e}" for v in p))
        print("  Q:", ", ".join(f"{v:.9e}" for v in q))
        if np.any(q < 0):
            print("  (Q has a negative coefficient: check it has no root for z >= 0)")


if __name__ == "__main__":
    main()
