#!/usr/bin/python3
"""Fits the Ewald real-space corrections of the SIMD pair kernels (forcefields/nonbonded/ewald-inl.h) and prints
their coefficients and errors (run it to check them or to refit; it writes nothing; ~10 s).

The kernels, like GROMACS's nbnxm kernels, write the real-space pair terms as the bare Coulomb term
minus a smooth correction, so that a pair needs rational functions of z = (βr)² and no exp or erfc:
    erfc(βr)/r = 1/r − β E(z),                          E(z) = erf(x)/x,
    (erfc(βr)/r + 2β/√π e^(−z))/r² = 1/r³ − β³ F(z),    F(z) = (erf(x)/x − 2/√π e^(−z))/z,   x = √z.
Both are even, entire functions of x, so rationals P(z)/Q(z) (Q(0) = 1) fit them well on 0 ≤ x ≤ X_MAX
(a β·cut-off beyond it falls back to erfc). An error counts against the bare term the correction is
subtracted from: δE·x and δF·x³ (but at least δ·f/100, f the function's value, so that short distances
stay accurate as well). Fitted on mpmath's values by iteratively reweighted linear least squares
(Sanathanan–Koerner, with Lawson's weights toward the minimax error) in 40-digit arithmetic; the
errors printed are those of the kernels' evaluation (Horner's rule; in double, on the even and the odd
powers apart) in the kernel's precision.
    /usr/bin/python3 validation/fit_ewald_corrections.py
"""
import mpmath as mp
import numpy as np

X_MAX = mp.mpf("4.5")  # EwaldRealSpace::kRationalRange
DEGREES = {"float": {"E": (5, 6), "F": (5, 6)}, "double": {"E": (10, 10), "F": (8, 8)}}  # (P, Q)
mp.mp.dps = 40


def exact(name, z):
    if z == 0:
        return 2 / mp.sqrt(mp.pi) * (1 if name == "E" else mp.mpf(2) / 3)
    x = mp.sqrt(z)
    erf_x = mp.erf(x) / x
    return erf_x if name == "E" else (erf_x - 2 / mp.sqrt(mp.pi) * mp.exp(-z)) / z


def error_weight(name, z, f):
    x = mp.sqrt(z)
    return max(x if name == "E" else x**3, f / 100)


def fit(name, m, n, nodes=160, rounds=12):
    zs = [(1 - mp.cos(mp.pi * (k + mp.mpf(1) / 2) / nodes)) / 2 * X_MAX**2 for k in range(nodes)]
    fs = [exact(name, z) for z in zs]
    weights = [error_weight(name, z, f) for z, f in zip(zs, fs)]
    q_prev, weight = [mp.mpf(1)] * nodes, [mp.mpf(1)] * nodes
    for _ in range(rounds):
        a, b = mp.matrix(nodes, m + n + 1), mp.matrix(nodes, 1)
        for i, (z, f) in enumerate(zip(zs, fs)):
            d = weight[i] * weights[i] / q_prev[i]
            for k in range(m + 1):
                a[i, k] = z**k * d
            for k in range(1, n + 1):
                a[i, m + k] = -f * z**k * d
            b[i] = f * d
        c, _ = mp.qr_solve(a, b)
        p = [c[k] for k in range(m + 1)]
        q = [mp.mpf(1)] + [c[m + k] for k in range(1, n + 1)]
        q_prev = [mp.polyval(q[::-1], z) for z in zs]
        err = [abs(mp.polyval(p[::-1], z) / qz - f) * w for z, qz, f, w in zip(zs, q_prev, fs, weights)]
        worst = max(err)
        weight = [w * mp.sqrt(e / worst + mp.mpf("1e-3")) for w, e in zip(weight, err)]
        weight = [w / max(weight) for w in weight]
    return p, q


def horner(coefficients, z, real):
    acc = real(coefficients[-1])
    for c in coefficients[-2::-1]:
        acc = real(acc * z + real(c))
    return acc


def even_odd(coefficients, z, real):
    """As the double-precision kernels evaluate: even and odd powers, each by Horner's rule in z²."""
    z2 = real(z * z)
    return real(horner(coefficients[0::2], z2, real) + real(z * horner(coefficients[1::2], z2, real)))


def main():
    for precision, degrees in DEGREES.items():
        real = np.float32 if precision == "float" else np.float64
        evaluate = horner if precision == "float" else even_odd
        for name, (m, n) in degrees.items():
            p, q = fit(name, m, n)
            pr, qr = [real(float(v)) for v in p], [real(float(v)) for v in q]
            worst = 0.0
            for k in range(2001):
                z = real(float(X_MAX**2) * k / 2000)
                f = exact(name, mp.mpf(float(z)))
                value = evaluate(pr, z, real) / evaluate(qr, z, real)
                worst = max(worst, float(abs(mp.mpf(float(value)) - f) * error_weight(name, mp.mpf(float(z)), f)))
            digits = 10 if precision == "float" else 17
            print(f"{precision} {name}: P degree {m}, Q degree {n}, 0 <= x <= {X_MAX}: max error against the bare "
                  f"Coulomb term {worst:.2e} ({evaluate.__name__} in {precision})")
            print("  P:", ", ".join(f"{float(v):.{digits}g}" for v in p))
            print("  Q:", ", ".join(f"{float(v):.{digits}g}" for v in q))
            if min(q) < 0:
                print("  (Q has a negative coefficient: check that it has no root for z >= 0)")


if __name__ == "__main__":
    main()
