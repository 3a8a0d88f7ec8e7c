"""The study's sections: which runs each needs, and the numbers computed from them. Figures are
drawn here too (into the report directory); report.py turns the returned dicts into markdown."""
import math

import numpy as np

from gmx_common import ROOT
from . import energy, figures, trajectories
from .plan import (GMX_VARIANTS, LONG_VARIANTS, RATTLE, SCAN_VARIANTS, SYSTEMS, fs, order_variants, relative, rk,
                   scan_length, vi)


def energy_every(dt, interval):
    """Energy samples about every `interval` ps, whatever the step."""
    return max(1, int(round(interval / dt)))


def series_of(run):
    """A finished run's energy series: time, total, kinetic, temperature (and constraint_rms for vimd)."""
    out = ROOT / run["out"]
    if run["kind"] == "vimd":
        return energy.read_energy_csv(out / "energy.csv")
    return dict(np.load(out / "series.npz"))


def _sweep(run_one, dts):
    """Runs at increasing time steps until one is not stable; the larger steps are recorded as not
    run, with the reason."""
    runs = []
    for k, dt in enumerate(dts):
        r = run_one(dt)
        runs.append(r)
        if r["status"] != "ok":
            reason = ("not available in this build" if r["status"] == "not available"
                      else f"not stable at {fs(dt)} fs")
            for later in dts[k + 1:]:
                runs.append({key: r[key] for key in ("kind", "system", "variant", "label")} |
                            {"dt": later, "status": "not run", "message": reason})
            break
    return runs


# ------------------------------------------------------------------ 1 + 2: time-step scan
def scan(runner, plan, report_dir, log):
    results = {}
    for name in plan.scan_systems:
        system = SYSTEMS[name]
        dts, tag = plan.scan_dts[name], f"scan-{name}"
        series = {}
        for variant in SCAN_VARIANTS:
            log(f"[scan {name}] {variant.label}")
            series[variant.key] = _sweep(lambda dt: runner.vimd(
                system, variant, dt, scan_length(plan, name, dt), tag, energy_every(dt, plan.energy_interval_ps), 0,
                tolerance=plan.constraint_tolerance, stability_fraction=plan.stability_fraction), dts)
        if name == plan.gromacs_system:
            for gv in GMX_VARIANTS:
                log(f"[scan {name}] {gv.label}")
                series[gv.key] = _sweep(lambda dt: runner.gromacs(
                    system, gv, dt, scan_length(plan, name, dt), tag, energy_every(dt, plan.energy_interval_ps), 0,
                    stability_fraction=plan.stability_fraction), dts)
        largest = {}
        for key, runs in series.items():
            best, first_bad = energy.largest_stable(runs)
            largest[key] = {"dt": best, "first_bad": first_bad,
                            "best_run": next((r for r in runs if r["status"] == "ok" and r["dt"] == best), None)}
        crossovers = {}
        for key, runs in series.items():
            if key == RATTLE.key:
                continue
            crossovers[key] = {cost: energy.crossover(_points(series[RATTLE.key], cost), _points(runs, cost))
                               for cost in ("wall_per_ps", "evaluations_per_ps")}
        figures.scan(name, series, report_dir / f"scan_{name}.png")
        figures.work_precision(name, series, report_dir / f"work_precision_{name}.png")
        results[name] = {"system": name, "atoms": system.atoms, "forcefield": system.forcefield,
                         "note": system.note, "ps": plan.scan_ps[name],
                         "max_steps": plan.scan_max_steps[name], "dts": list(dts), "series": series, "largest": largest,
                         "crossovers": crossovers}
    return results


def _points(runs, cost):
    return [(r["cost"][cost], r["stats"]["rms_fluctuation"]) for r in runs
            if r["status"] == "ok" and r["stats"]["rms_fluctuation"] > 0 and r["cost"][cost] > 0
            and math.isfinite(r["cost"][cost])]


# ------------------------------------------------------------------ 3: order study
def order(runner, plan, report_dir, log):
    system = SYSTEMS[plan.order_system]
    horizon = plan.order_ps
    tol = plan.order_tolerance

    def run(variant, dt, tag):
        steps = int(round(horizon / dt))
        overrides = {"solver_tolerance": tol} if variant.family == "vi" else {}
        return runner.vimd(system, variant, dt, horizon, tag, max(1, steps // 50), steps, overrides, tolerance=tol,
                           stability_fraction=plan.stability_fraction)

    def positions(r):
        return runner.gromacs_positions(r, system.structure, r["steps"] * r["dt"])

    # Reference solution: the most accurate method the build offers, at a tiny step; its own error
    # is estimated from the same method at twice that step.
    reference = None
    for candidate in (rk("rk6"), vi("rk6", "b01"), rk("rk4"), RATTLE):
        log(f"[order] reference candidate {candidate.label}")
        fine = run(candidate, plan.order_reference_dt, "order-reference")
        coarse = run(candidate, 2 * plan.order_reference_dt, "order-reference")
        if "stats" in fine and "stats" in coarse:
            x_ref = positions(fine)
            reference = {"run": fine, "check": coarse, "label": candidate.label,
                         "error": float(np.max(np.linalg.norm(positions(coarse) - x_ref, axis=1)))}
            break
    floor = max(reference["error"] if reference else 0.0, plan.order_error_floor)

    def gromacs_run(gv, dt, tag):
        steps = int(round(horizon / dt))
        return runner.gromacs(system, gv, dt, horizon, tag, max(1, steps // 50), steps,
                              stability_fraction=plan.stability_fraction)

    # vimd's methods, then GROMACS's two integrators with SETTLE as a cross-check of RATTLE and SHAKE
    methods = [(v, v.order, lambda dt, v=v: run(v, dt, "order-cluster8")) for v in order_variants(plan.order_tableaus)]
    methods += [(gv, 2, lambda dt, gv=gv: gromacs_run(gv, dt, "order-cluster8")) for gv in GMX_VARIANTS]
    rows = []
    for variant, nominal, run_at in methods:
        log(f"[order] {variant.label}")
        runs, errors = [], []
        for dt in plan.order_dts:
            r = run_at(dt)
            runs.append(r)
            if reference is not None and "stats" in r:
                trajectory = "traj.trr" if r["kind"] == "vimd" else "gmx.trr"
                r["positions_command"] = (f"gmx_d traj -f {r['out']}/{trajectory} -s "
                                          f"{relative(system.structure)} -ox x.xvg -fp -nopbc "
                                          f"-b {r['steps'] * r['dt']:g} -e {r['steps'] * r['dt']:g}")
                errors.append(float(np.max(np.linalg.norm(positions(r) - x_ref, axis=1))))
            else:
                errors.append(None)
            if r["status"] == "not available":
                break
        slope, used, local = energy.fit_order([r["dt"] for r in runs], errors, floor)
        rows.append({"variant": variant.key, "label": variant.label, "order": nominal,
                     "dts": [r["dt"] for r in runs], "errors": errors, "runs": runs, "slope": slope,
                     "fit_dts": [p[0] for p in used], "local_slopes": local})
    figures.order(rows, reference["error"] if reference else None, report_dir / "order_cluster8.png")
    return {"system": system.name, "atoms": system.atoms, "forcefield": system.forcefield, "note": system.note,
            "horizon": horizon, "tolerance": tol, "reference": reference, "error_floor": plan.order_error_floor,
            "rows": rows}


# ------------------------------------------------------------------ 4 + 5: long runs, MDAnalysis
def long_runs(runner, plan, report_dir, log):
    system = SYSTEMS[plan.long_system]
    frame = max(1, int(round(plan.long_frame_ps / plan.long_dt)))
    tag = f"long-{system.name}"
    runs = {}
    for variant in LONG_VARIANTS:
        log(f"[long] {variant.label}, {plan.long_ps:g} ps")
        runs[variant.key] = runner.vimd(system, variant, plan.long_dt, plan.long_ps, tag, 5, frame,
                                        tolerance=plan.constraint_tolerance, timeout=6 * 3600,
                                        stability_fraction=plan.stability_fraction)
    gv = GMX_VARIANTS[0]
    log(f"[long] {gv.label}, {plan.gromacs_traj_ps:g} ps")
    runs[gv.key] = runner.gromacs(system, gv, plan.long_dt, plan.gromacs_traj_ps, tag, 5, frame,
                                  timeout=6 * 3600, stability_fraction=plan.stability_fraction)
    curves = {}
    for key, r in runs.items():
        if "stats" in r:
            s = series_of(r)
            curves[key] = (r["label"], s["time"], s["total"])
        elif (ROOT / r["out"] / "energy.csv.partial").exists():
            # a run that stopped with an error: vimd keeps its output up to that point
            s = energy.read_energy_csv(ROOT / r["out"] / "energy.csv.partial")
            if len(s["time"]) > 1:
                r["stopped_at"] = float(s["time"][-1])
                curves[key] = (f"{r['label']} (stopped at {s['time'][-1]:g} ps)", s["time"], s["total"])
    figures.long_runs(curves, report_dir / "long_runs.png")
    return {"system": system.name, "atoms": system.atoms, "forcefield": system.forcefield, "note": system.note,
            "dt": plan.long_dt, "ps": plan.long_ps, "frame_ps": frame * plan.long_dt, "runs": runs}


def mdanalysis(long, report_dir, log):
    """RDF, constraint deviations, MSD and temperature of every finished long run and GROMACS's."""
    results, rdfs, deviations, rms, msds, temps = {}, {}, {}, {}, {}, {}
    resolution = None
    reference_key = GMX_VARIANTS[0].key
    for key, r in long["runs"].items():
        if "stats" not in r:
            continue
        out = ROOT / r["out"]
        names = ("confout.gro", "traj.trr") if r["kind"] == "vimd" else ("gmx.gro", "gmx.trr")
        gro, trr = out / names[0], out / names[1]
        log(f"[MDAnalysis] {r['label']}: Universe({relative(gro)}, {relative(trr)})")
        try:
            u = trajectories.water_universe(gro, trr)
        except Exception as e:  # a trajectory MDAnalysis cannot open is a result to report
            results[key] = {"label": r["label"], "error": f"MDAnalysis could not open it: {e}"}
            continue
        r_, g, peak_r, peak_g = trajectories.rdf_oo(u)
        dev = trajectories.constraint_deviations(u)
        lags, msd_values, diffusion, window = trajectories.msd_diffusion(u)
        t, temp, dof = trajectories.temperature(u)
        s = series_of(r)
        resolution = trajectories.float32_resolution(u)
        rdfs[key] = (r["label"], r_, g)
        deviations[key] = (r["label"], dev)
        msds[key] = (r["label"], lags, msd_values, diffusion, window)
        temps[key] = (r["label"], t, temp, s["time"], s["temperature"])
        if "constraint_rms" in s:
            rms[key] = (r["label"], s["time"], s["constraint_rms"])
        results[key] = {"label": r["label"], "command": r["command"], "frames": len(u.trajectory),
                        "rdf_peak_r": peak_r, "rdf_peak_g": peak_g,
                        "dev_median": float(np.median(np.abs(dev))), "dev_max": float(np.max(np.abs(dev))),
                        "engine_constraint_rms_max":
                            float(np.max(s["constraint_rms"])) if "constraint_rms" in s else None,
                        "diffusion": diffusion, "msd_window": window, "temperature_mdanalysis": float(np.mean(temp)),
                        "temperature_engine": float(np.mean(s["temperature"])), "dof": dof}
    if reference_key in rdfs:
        ref_r, ref_g = rdfs[reference_key][1], rdfs[reference_key][2]
        for key, (_, r_, g) in rdfs.items():
            if key != reference_key and len(g) == len(ref_g):
                mask = ref_r >= 0.2
                results[key]["rdf_rms_vs_gromacs"] = float(np.sqrt(np.mean((g[mask] - ref_g[mask]) ** 2)))
    if rdfs:
        figures.rdf(rdfs, reference_key, report_dir / "rdf_oo.png")
        figures.constraints(deviations, resolution, rms, report_dir / "constraint_deviations.png")
        figures.msd(msds, report_dir / "msd.png")
        figures.temperature(temps, report_dir / "temperature.png")
    return {"results": results, "resolution": resolution}
