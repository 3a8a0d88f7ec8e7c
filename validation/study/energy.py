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


def equivalent_cost(reference, err):
    """What the reference integrator (RATTLE), given as (cost, error) points of its stable runs, costs
    at error err: (cost, "interpolated" | "extrapolated"), or None with fewer than two points."""
    front = pareto(reference)
    if len(front) < 2:
        return None
    cost, measured = reference_cost(front, power_fit(front), err)
    return float(cost), "interpolated" if bool(measured) else "extrapolated"


def crossover(reference, candidate):
    """Where a candidate integrator's cost curve crosses the reference's (RATTLE's), both given as
    (cost, error) points of stable runs. Compared on the candidate's own error range: the
    reference's cost there is interpolated between its measured points and, below its smallest
    measured error, extrapolated with its power law cost = A error^-k (fitted to its Pareto front;
    RATTLE's k is ~1/2 for a second-order method). The candidate's curve is never extrapolated.
    Returns kind ("cheaper throughout" | "dearer throughout" | "crossing" | "no data"), the
    compared range, the cost-ratio range, crossings (error values) with whether each lies where
    the reference was measured, and whether the candidate is the cheaper one at the small-error end."""
    ref, cand = pareto(reference), pareto(candidate)
    out = {"kind": "no data", "reference_points": len(ref), "candidate_points": len(cand)}
    if len(ref) < 2 or not cand:
        return out
    fit = power_fit(ref)
    out["fit_reference"] = fit
    ref_lo, ref_hi = ref[0][1], ref[-1][1]
    lo, hi = cand[0][1], min(cand[-1][1], ref_hi)
    if lo > hi:  # the candidate is everywhere less accurate than RATTLE at its largest stable step
        return out
    grid = np.exp(np.linspace(math.log(lo), math.log(hi), 400)) if hi > lo else np.array([lo])
    cand_cost = np.exp(_log_interp(cand, grid)) if len(cand) > 1 else np.full(len(grid), cand[0][0])
    ref_cost, measured = reference_cost(ref, fit, grid)
    ratio = cand_cost / ref_cost
    cheaper = ratio < 1
    out.update({"range": (lo, hi), "ratio_range": (float(ratio.min()), float(ratio.max())),
                "extrapolated_below": ref_lo if lo < ref_lo else None,
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
