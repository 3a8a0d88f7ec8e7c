"""Numbers from energy series and run results: drift, fluctuation, stability, largest stable step,
work-precision crossover, order-of-accuracy fits. Pure numpy; no I/O besides reading energy.csv."""
import csv
import math

import numpy as np


def read_energy_csv(path):
    """vimd's energy.csv as a dict of float arrays keyed by the header's column names."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], [r for r in rows[1:] if r]
    values = np.array([[float(x) for x in r] for r in body]) if body else np.zeros((0, len(header)))
    return {name.strip(): values[:, k] for k, name in enumerate(header)}


def energy_statistics(time, total, kinetic, atoms):
    """Total-energy drift (slope of a linear fit, kJ/mol/ps per atom), RMS fluctuation about that fit
    and about the mean (kJ/mol), the largest excursion from the first value and the mean kinetic
    energy. The same function serves vimd and GROMACS series."""
    t, e, k = (np.asarray(a, dtype=float) for a in (time, total, kinetic))
    if len(t) < 3:
        raise ValueError(f"only {len(t)} energy samples: too few for a drift fit")
    if not (np.all(np.isfinite(e)) and np.all(np.isfinite(k))):
        raise ValueError("non-finite energies in the series")
    slope, intercept = np.polyfit(t, e, 1)
    residual = e - (slope * t + intercept)
    return {
        "drift_per_atom": float(slope / atoms),
        "rms_fluctuation": float(np.sqrt(np.mean(residual ** 2))),
        "rms_about_mean": float(np.std(e)),
        "max_excursion": float(np.max(np.abs(e - e[0]))),
        "mean_kinetic": float(np.mean(k)),
        "samples": int(len(t)),
    }


def is_stable(stats, fraction):
    """A finished run is stable when its total energy never strays from the start by more than
    `fraction` of the mean kinetic energy (1 % of E_kin is a temperature change of ~3 K at 300 K)."""
    return stats["max_excursion"] < fraction * stats["mean_kinetic"]


def largest_stable(runs):
    """(largest stable dt, first dt that was not stable, its run) over one integrator's runs."""
    stable = [r["dt"] for r in runs if r["status"] == "ok"]
    bad = [r for r in runs if r["status"] in ("unstable", "failed")]
    first_bad = min(bad, key=lambda r: r["dt"]) if bad else None
    return (max(stable) if stable else None), first_bad


def pareto(points):
    """The (cost, error) points no other point beats in both, sorted by error."""
    pts = sorted(set(points), key=lambda p: (p[1], p[0]))
    front, best_cost = [], math.inf
    for cost, err in pts:
        if cost < best_cost:
            front.append((cost, err))
            best_cost = cost
    return front


def _log_interp(front, err):
    """log(cost) at log(err) on a Pareto front (piecewise linear in log-log)."""
    le = np.log([p[1] for p in front])
    lc = np.log([p[0] for p in front])
    return np.interp(np.log(err), le, lc)


def power_fit(front):
    """cost = A err^(-k) fitted to a Pareto front; returns (A, k) or None."""
    if len(front) < 2:
        return None
    slope, intercept = np.polyfit(np.log([p[1] for p in front]), np.log([p[0] for p in front]), 1)
    return math.exp(intercept), -slope


def reference_cost(front, fit, err):
    """The reference's cost at error(s) err: interpolated in log-log on its Pareto front where err lies
    in the front's range, else from its power law fit = (A, k), cost = A err^-k. Returns (cost,
    whether each err lies in the measured range)."""
    err = np.asarray(err, dtype=float)
    lo, hi = front[0][1], front[-1][1]
    measured = (err >= lo) & (err <= hi)
    interpolated = np.exp(_log_interp(front, np.clip(err, lo, hi)))
    return np.where(measured, interpolated, fit[0] * err ** -fit[1]), measured


def _reference_curves(references):
    """{key: (Pareto front, power law)} of the references with at least two points on their front."""
    fronts = {key: pareto(points) for key, points in references.items()}
    return {key: (front, power_fit(front)) for key, front in fronts.items() if len(front) >= 2}


def _cheapest(curves, err):
    costs, measured = [], []
    for front, fit in curves.values():
        cost, inside = reference_cost(front, fit, err)
        costs.append(cost)
        measured.append(inside)
    costs, measured = np.array(costs), np.array(measured)
    best, columns = costs.argmin(axis=0), np.arange(len(err))
    return costs[best, columns], [list(curves)[i] for i in best], measured[best, columns]


def cheapest_reference(references, err):
    """The cheapest of several reference integrators (RATTLE and its compositions) at error(s) err,
    each given as (cost, error) points of its stable runs; references with fewer than two points on
    their Pareto front are left out. Each one's cost is interpolated in log-log on its front and
    extrapolated beyond it with its power law (reference_cost). Returns (cost, key of the cheapest,
    whether its cost was measured) per error, or None without any usable reference."""
    curves = _reference_curves(references)
    if not curves:
        return None
    return _cheapest(curves, np.atleast_1d(np.asarray(err, dtype=float)))


def measured_cost(points, err):
    """An integrator's cost at error err, interpolated in log-log on the Pareto front of its (cost,
    error) points; None outside the errors it was measured at (never extrapolated)."""
    front = pareto(points)
    if not front or not front[0][1] <= err <= front[-1][1]:
        return None
    return float(np.exp(_log_interp(front, err))) if len(front) > 1 else front[0][0]


def equal_accuracy(series_points, is_peer):
    """Work-precision at equal accuracy: at each decade of RMS fluctuation inside the measured range,
    every integrator's measured_cost, the cheapest peer and the cheapest other integrator there, and
    the peer's cost over the other's. series_points: {key: (cost, error) points}."""
    errors = [e for points in series_points.values() for _, e in points]
    if not errors:
        return []
    rows = []
    for exponent in range(math.floor(math.log10(max(errors))), math.ceil(math.log10(min(errors))) - 1, -1):
        err = 10.0 ** exponent
        costs = {key: measured_cost(points, err) for key, points in series_points.items()}
        best = {}
        for side, member in (("peer", is_peer), ("candidate", lambda key: not is_peer(key))):
            known = {key: c for key, c in costs.items() if c is not None and member(key)}
            best[side] = min(known, key=known.get) if known else None
        ratio = (costs[best["peer"]] / costs[best["candidate"]]) if best["peer"] and best["candidate"] else None
        rows.append({"error": err, "costs": costs, "best_peer": best["peer"], "best_candidate": best["candidate"],
                     "peer_over_candidate": ratio})
    return rows


def crossover(references, candidate):
    """Where a candidate integrator's cost curve crosses the cheapest reference's (RATTLE, or the best
    of RATTLE and its compositions), the references given as {key: (cost, error) points of stable
    runs}, the candidate as such points. Compared on the candidate's own error range up to the
    largest error any reference reached: each reference's cost there as cheapest_reference takes it
    (interpolated between its measured points, below its smallest measured error extrapolated with
    its power law cost = A error^-k; RATTLE's k is ~1/2 for a second-order method). The candidate's
    curve is never extrapolated. Returns kind ("cheaper throughout" | "dearer throughout" |
    "crossing" | "no data"), the compared range, the cost-ratio range, crossings (error values) with
    whether each lies where the reference was measured, whether the candidate is the cheaper one at
    the small-error end, and which reference is the cheapest where (segments of the range)."""
    curves, cand = _reference_curves(references), pareto(candidate)
    out = {"kind": "no data", "reference_points": max((len(pareto(p)) for p in references.values()), default=0),
           "candidate_points": len(cand)}
    if not curves or not cand:
        return out
    lo, hi = cand[0][1], min(cand[-1][1], max(front[-1][1] for front, _ in curves.values()))
    if lo > hi:  # the candidate is everywhere less accurate than every reference at its largest stable step
        return out
    grid = np.exp(np.linspace(math.log(lo), math.log(hi), 400)) if hi > lo else np.array([lo])
    cand_cost = np.exp(_log_interp(cand, grid)) if len(cand) > 1 else np.full(len(grid), cand[0][0])
    ref_cost, owner, measured = _cheapest(curves, grid)
    ratio = cand_cost / ref_cost
    cheaper = ratio < 1
    low_front, low_fit = curves[owner[0]]
    segments = []
    for i, key in enumerate(owner):
        if segments and segments[-1][0] == key:
            segments[-1][2] = float(grid[i])
        else:
            segments.append([key, float(grid[i]), float(grid[i])])
    out.update({"range": (lo, hi), "ratio_range": (float(ratio.min()), float(ratio.max())),
                "fit_reference": low_fit, "cheapest_reference": [tuple(s) for s in segments],
                "extrapolated_below": low_front[0][1] if not measured[0] else None,
                "cheaper_below": bool(cheaper[0])})
    if cheaper.all():
        out["kind"] = "cheaper throughout"
    elif not cheaper.any():
        out["kind"] = "dearer throughout"
    else:
        flips = np.nonzero(np.diff(cheaper.astype(int)))[0]
        out["kind"] = "crossing"
        out["crossings"] = [(float(math.sqrt(grid[i] * grid[i + 1])), bool(measured[i] and measured[i + 1]))
                            for i in flips]
    return out


def fit_order(dts, errors, floor):
    """Observed order of accuracy: slope of log(error) against log(dt), fitted over the three
    smallest steps whose error is at least 10x above the floor (the larger of the reference's own
    error and round-off); also the local slopes between successive steps. Returns (slope or None, points used, locals)."""
    pairs = sorted((dt, e) for dt, e in zip(dts, errors) if e is not None and math.isfinite(e) and e > 0)
    usable = [(dt, e) for dt, e in pairs if e > 10 * floor][:3]
    local = [math.log(e2 / e1) / math.log(d2 / d1) for (d1, e1), (d2, e2) in zip(pairs, pairs[1:])]
    if len(usable) < 2:
        return None, usable, local
    slope = np.polyfit(np.log([p[0] for p in usable]), np.log([p[1] for p in usable]), 1)[0]
    return float(slope), usable, local
