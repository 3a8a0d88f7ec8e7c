"""The study's sections: which runs each needs, and the numbers computed from them. Figures are
drawn here too (into the report directory); report.py turns the returned dicts into markdown."""
import math

import numpy as np

from gmx_common import ROOT
from . import energy, figures, trajectories
from .plan import (GMX_VARIANTS, LONG_VARIANTS, RATTLE, SCAN_VARIANTS, SMOOTH_PME_RATTLE, STANDARD_PME_RATTLE,
                   SWITCHED_RATTLE, SYSTEMS, alkane_melt, fs, order_variants, pme_standard, pme_water, relative, rk,
                   scan_length, switched, vi)


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
            crossovers[key] = {cost: energy.crossover({RATTLE.key: _points(series[RATTLE.key], cost)},
                                                       _points(runs, cost))
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
    variants = order_variants(plan.order_tableaus, tuple(plan.order_compositions))
    methods = [(v, v.order, lambda dt, v=v: run(v, dt, "order-cluster8"),
                plan.order_compositions.get(v.integrator.get("composition"), plan.order_dts)) for v in variants]
    methods += [(gv, 2, lambda dt, gv=gv: gromacs_run(gv, dt, "order-cluster8"), plan.order_dts) for gv in GMX_VARIANTS]
    rows = []
    for variant, nominal, run_at, dts in methods:
        log(f"[order] {variant.label}")
        runs, errors = [], []
        for dt in dts:
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


def analyse_water(r, log):
    """RDF, constraint deviations, MSD with D and temperature of one finished water run (vimd or
    GROMACS): (numbers for the report, curves for the figures); (numbers with "error", None) when
    MDAnalysis cannot open its trajectory."""
    out = ROOT / r["out"]
    names = ("confout.gro", "traj.trr") if r["kind"] == "vimd" else ("gmx.gro", "gmx.trr")
    gro, trr = out / names[0], out / names[1]
    log(f"[MDAnalysis] {r['label']}: Universe({relative(gro)}, {relative(trr)})")
    try:
        u = trajectories.water_universe(gro, trr)
    except Exception as e:  # a trajectory MDAnalysis cannot open is a result to report
        return {"label": r["label"], "error": f"MDAnalysis could not open it: {e}"}, None
    r_, g, peak_r, peak_g = trajectories.rdf_oo(u)
    dev = trajectories.constraint_deviations(u)
    lags, msd_values, diffusion, window, diffusion_error = trajectories.msd_diffusion(u)
    t, temp, dof = trajectories.temperature(u)
    s = series_of(r)
    curves = {"rdf": (r["label"], r_, g), "deviations": (r["label"], dev),
              "msd": (r["label"], lags, msd_values, diffusion, window),
              "temperature": (r["label"], t, temp, s["time"], s["temperature"]),
              "constraint_rms": (r["label"], s["time"], s["constraint_rms"]) if "constraint_rms" in s else None,
              "resolution": trajectories.float32_resolution(u)}
    result = {"label": r["label"], "command": r["command"], "frames": len(u.trajectory),
              "rdf_peak_r": peak_r, "rdf_peak_g": peak_g,
              "dev_median": float(np.median(np.abs(dev))), "dev_max": float(np.max(np.abs(dev))),
              "engine_constraint_rms_max": float(np.max(s["constraint_rms"])) if "constraint_rms" in s else None,
              "diffusion": diffusion, "diffusion_error": diffusion_error,
              "diffusion_blocks": trajectories.DIFFUSION_BLOCKS, "msd_window": window,
              "temperature_mdanalysis": float(np.mean(temp)), "temperature_engine": float(np.mean(s["temperature"])),
              "dof": dof}
    return result, curves


def rdf_rms_difference(rdf, reference):
    """RMS difference of two O-O RDF curves (label, r, g) from 0.2 nm out (below, both are zero), or
    None when they were binned differently."""
    (_, ref_r, ref_g), (_, _, g) = reference, rdf
    if len(g) != len(ref_g):
        return None
    mask = ref_r >= 0.2
    return float(np.sqrt(np.mean((g[mask] - ref_g[mask]) ** 2)))


def mdanalysis(long, report_dir, log):
    """RDF, constraint deviations, MSD and temperature of every finished long run and GROMACS's."""
    results, rdfs, deviations, rms, msds, temps = {}, {}, {}, {}, {}, {}
    resolution = None
    reference_key = GMX_VARIANTS[0].key
    for key, r in long["runs"].items():
        if "stats" not in r:
            continue
        results[key], curves = analyse_water(r, log)
        if curves is None:
            continue
        rdfs[key], deviations[key], msds[key], temps[key] = (curves[c] for c in ("rdf", "deviations", "msd",
                                                                                 "temperature"))
        if curves["constraint_rms"]:
            rms[key] = curves["constraint_rms"]
        resolution = curves["resolution"]
    if reference_key in rdfs:
        for key, curve in rdfs.items():
            difference = rdf_rms_difference(curve, rdfs[reference_key])
            if key != reference_key and difference is not None:
                results[key]["rdf_rms_vs_gromacs"] = difference
    if rdfs:
        figures.rdf(rdfs, reference_key, report_dir / "rdf_oo.png")
        figures.constraints(deviations, resolution, rms, report_dir / "constraint_deviations.png")
        figures.msd(msds, report_dir / "msd.png")
        figures.temperature(temps, report_dir / "temperature.png")
    return {"results": results, "resolution": resolution}


# ------------------------------------------------------------------ 6: smooth interactions
def exact_every(dt, interval):
    """Steps between energy samples when `interval` must be a whole number of steps (every run of a
    comparison sampled at the same times)."""
    every = energy_every(dt, interval)
    if abs(every * dt - interval) > 1e-9 * interval:
        raise ValueError(f"study plan: energy interval {interval:g} ps is not a multiple of dt = {dt:g} ps")
    return every


def smooth(runner, plan, report_dir, log, long):
    """Section 6: water with LJ and reaction field switched to zero smoothly (C^k pair potential),
    RATTLE against the variational integrators at every smoothness of the plan: RMS fluctuation vs
    dt with fitted slopes, wall time per ps, RATTLE's equivalent cost of every vi run and the
    crossover; then what the switch does to the RDF and D (the price of smoothness)."""
    started = runner.run_seconds
    base = SYSTEMS[plan.smooth_system]
    levels = {}
    for k in sorted({entry.smoothness for entry in plan.smooth_series}):
        system = switched(base, k)
        entries = [e for e in plan.smooth_series if e.smoothness == k]
        series = _level_runs(runner, plan, system, entries, plan.smooth_ps, plan.smooth_energy_interval_ps,
                             f"smooth-{base.name}-C{k}", lambda label: log(f"[smooth C{k}] {label}"))
        orders = {e.variant.key: e.variant.order for e in plan.smooth_series}
        levels[k] = _smooth_level(system, series, orders, plan.smooth_floor)
    figures.smooth_rms(levels, plan.smooth_floor, report_dir / "smooth_rms.png")
    figures.smooth_work_precision(levels, report_dir / "smooth_work_precision.png")
    price = price_of_smoothness(runner, plan, long, report_dir, log)
    return _levels_result(runner, plan, base, plan.smooth_ps, plan.smooth_energy_interval_ps, levels, started) | {
        "price": price, "tolerance": solver_tolerance(runner, plan, log)}


TOLERANCE_WITHIN = 0.01  # a tolerance "leaves the energy error unchanged" within 1 % of the tightest's RMS


def solver_tolerance(runner, plan, log):
    """vi's solver tolerance against its energy error and cost: each case of the plan at every fixed
    tolerance, the bias's default (unset) and "auto", on section 6's switched water; per case the
    loosest fixed tolerance whose RMS fluctuation is within TOLERANCE_WITHIN of the tightest's."""
    system = switched(SYSTEMS[plan.tolerance_system], plan.price_smoothness)
    settings = [(f"{t:g}", {"solver_tolerance": t}) for t in plan.tolerance_values] + [
        ("default", {}), ("auto", {"solver_tolerance": "auto"})]
    cases = []
    for method, dt in plan.tolerance_cases:
        variant = vi(method, "b01")
        log(f"[smooth tolerance] {variant.label}, {fs(dt)} fs")
        runs = {name: runner.vimd(system, variant, dt, plan.tolerance_ps, f"tolerance-{system.name}-{name}",
                                  energy_every(dt, plan.energy_interval_ps), 0,
                                  overrides | {"max_iterations": plan.smooth_max_iterations},
                                  tolerance=plan.constraint_tolerance, stability_fraction=plan.stability_fraction,
                                  threads=plan.smooth_threads)
                for name, overrides in settings}
        reference = runs[f"{plan.tolerance_values[-1]:g}"]
        loosest = None
        if reference["status"] == "ok":
            rms = reference["stats"]["rms_fluctuation"]
            for name, r in runs.items():
                if r["status"] == "ok":
                    r["rms_vs_tightest"] = r["stats"]["rms_fluctuation"] / rms - 1
            loosest = next((f"{t:g}" for t in plan.tolerance_values
                            if abs(runs[f"{t:g}"].get("rms_vs_tightest", math.inf)) <= TOLERANCE_WITHIN), None)
        cases.append({"method": method, "label": variant.label, "dt": dt, "runs": runs, "loosest": loosest})
    return {"system": system.name, "atoms": system.atoms, "note": system.note, "ps": plan.tolerance_ps,
            "within": TOLERANCE_WITHIN, "settings": [name for name, _ in settings], "cases": cases}


def _level_runs(runner, plan, system, entries, ps, interval, tag, log):
    """Each entry's integrator at its steps on `system` (sections 6 and 7): {variant key: runs}."""
    solver = {"solver_tolerance": plan.smooth_solver_tolerance, "max_iterations": plan.smooth_max_iterations}
    series = {}
    for entry in entries:
        v = entry.variant
        log(v.label)
        series[v.key] = _sweep(lambda dt: runner.vimd(
            system, v, dt, ps, tag, exact_every(dt, interval), 0, solver if v.family == "vi" else None,
            tolerance=plan.constraint_tolerance, stability_fraction=plan.stability_fraction,
            threads=plan.smooth_threads), entry.dts)
    return series


def _levels_result(runner, plan, base, ps, interval, levels, started):
    return {"system": base.name, "atoms": base.atoms, "ps": ps, "threads": plan.smooth_threads,
            "solver_tolerance": plan.smooth_solver_tolerance, "max_iterations": plan.smooth_max_iterations,
            "constraint_tolerance": plan.constraint_tolerance, "energy_interval": interval,
            "floor": plan.smooth_floor, "levels": levels, "run_minutes": (runner.run_seconds - started) / 60}


# ------------------------------------------------------------------ 7: PME water
def pme(runner, plan, report_dir, log):
    """Section 7: section 6's comparison on PME water, its real space and LJ switched to zero
    smoothly, at each B-spline order and smoothness of the plan: slopes of RMS fluctuation vs dt,
    wall time per ps, RATTLE's equivalent cost and the crossover."""
    started = runner.run_seconds
    base = SYSTEMS[plan.pme_system]
    levels = {}
    for level in dict.fromkeys(entry.level for entry in plan.pme_series):
        entries = [e for e in plan.pme_series if e.level == level]
        p, k = entries[0].pme_order, entries[0].smoothness
        system = pme_water(base, plan.pme_cutoff, plan.pme_switch, plan.pme_skin, p, k)
        series = _level_runs(runner, plan, system, entries, plan.pme_ps, plan.pme_energy_interval_ps,
                             f"pme-{base.name}-p{p}-C{k}", lambda label: log(f"[pme {level}] {label}"))
        levels[level] = _smooth_level(system, series, {e.variant.key: e.variant.order for e in entries},
                                      plan.smooth_floor) | {"pme_order": p}
    figures.smooth_rms(levels, plan.smooth_floor, report_dir / "pme_rms.png")
    figures.smooth_work_precision(levels, report_dir / "pme_work_precision.png")
    price = pme_price_of_smoothness(runner, plan, report_dir, log)
    return _levels_result(runner, plan, base, plan.pme_ps, plan.pme_energy_interval_ps, levels, started) | {
        "price": price}


# ------------------------------------------------------------------ 8: real polymers
def polymer(runner, plan, report_dir, log):
    """Section 8: section 6's comparison on the OPLS-AA alkane melt (dihedrals, 1-4 pairs, rigid C-H
    or all bonds), its LJ and reaction field switched to zero smoothly: slopes of RMS fluctuation vs
    dt, wall time per ps against the best peer and the crossover, per constraint set."""
    started = runner.run_seconds
    levels, system = {}, None
    for level in dict.fromkeys(entry.level for entry in plan.polymer_series):
        entries = [e for e in plan.polymer_series if e.level == level]
        system = alkane_melt(entries[0].constraints, entries[0].smoothness)
        series = _level_runs(runner, plan, system, entries, plan.polymer_ps, plan.polymer_energy_interval_ps,
                             f"polymer-{system.name}-{level.replace(' ', '-')}",
                             lambda label: log(f"[polymer {level}] {label}"))
        levels[level] = _smooth_level(system, series, {e.variant.key: e.variant.order for e in entries},
                                      plan.smooth_floor) | {"constraints": entries[0].constraints}
    figures.smooth_rms(levels, plan.smooth_floor, report_dir / "polymer_rms.png")
    figures.smooth_work_precision(levels, report_dir / "polymer_work_precision.png")
    return _levels_result(runner, plan, system, plan.polymer_ps, plan.polymer_energy_interval_ps, levels, started)


def _smooth_level(system, series, orders, floor):
    """At one smoothness: fitted slopes of RMS fluctuation vs dt; for every stable vi run, RATTLE's
    equivalent cost and the best peer's (the cheapest of RATTLE and its compositions at that
    accuracy); the crossover of every vi against RATTLE and against the best peer, and of every
    composition against RATTLE, in wall time per ps."""
    peers = {key: _points(runs, "wall_per_ps") for key, runs in series.items() if is_peer(key)}
    rattle = {RATTLE.key: peers[RATTLE.key]}
    fits, crossovers, peer_crossovers = {}, {}, {}
    for key, runs in series.items():
        ok = [r for r in runs if r["status"] == "ok"]
        slope, used, local = energy.fit_order([r["dt"] for r in ok], [r["stats"]["rms_fluctuation"] for r in ok],
                                              floor)
        fits[key] = {"order": orders[key], "slope": slope, "fit_dts": [p[0] for p in used], "local_slopes": local}
        if key == RATTLE.key:
            continue
        crossovers[key] = energy.crossover(rattle, _points(runs, "wall_per_ps"))
        compared = {"rattle_equivalent": rattle}
        if not is_peer(key):
            peer_crossovers[key] = energy.crossover(peers, _points(runs, "wall_per_ps"))
            compared["peer_equivalent"] = peers
        for r in ok:
            for name, references in compared.items():
                cheapest = energy.cheapest_reference(references, r["stats"]["rms_fluctuation"])
                if cheapest is not None:
                    cost, owner, measured = (x[0] for x in cheapest)
                    r[name] = {"wall_per_ps": float(cost), "peer": owner,
                               "basis": "interpolated" if measured else "extrapolated",
                               "ratio": float(cost) / r["cost"]["wall_per_ps"]}
    front = energy.pareto(peers[RATTLE.key])
    return {"smoothness": system.forcefield["switch_smoothness"], "forcefield": system.forcefield,
            "note": system.note, "series": series, "fits": fits, "crossovers": crossovers,
            "peer_crossovers": peer_crossovers, "rattle_fit": energy.power_fit(front) if len(front) >= 2 else None,
            "equal_accuracy": energy.equal_accuracy({key: _points(runs, "wall_per_ps") for key, runs in series.items()},
                                                    is_peer)}


def is_peer(key):
    """RATTLE and its compositions: the constrained methods a variational integrator must beat."""
    return key == RATTLE.key or key.startswith(RATTLE.key + "-")


PRICE_TAU_T = 0.1  # ps: v-rescale leaves the dynamics of water nearly unchanged (Bussi, Donadio, Parrinello 2007)


def price_of_smoothness(runner, plan, long, report_dir, log):
    """The long runs' system with LJ and RF switched (RATTLE, same step, length and frames as the long
    runs, held at the GROMACS run's mean temperature) against the long runs' GROMACS run (unswitched
    reaction field) and vimd's own unswitched RATTLE run: O-O RDF and self-diffusion by the same
    MDAnalysis code as section 5."""
    reference_key = GMX_VARIANTS[0].key
    if long is None:
        return {"skipped": "the long-runs section was not run (--sections without long): its GROMACS run is "
                           "the unswitched reference, so the switched run was not made either"}
    if "stats" not in long["runs"][reference_key]:
        return {"skipped": "GROMACS's long run (the unswitched reference) did not finish"}
    # NVE from the long runs' start, the switched interactions heat the box (water216 at C4, 1 ps:
    # 327 K mean against GROMACS's 288 K), which would move D more than the switch itself; a
    # v-rescale thermostat holds the switched run at GROMACS's mean temperature instead.
    temperature = round(float(np.mean(series_of(long["runs"][reference_key])["temperature"])), 1)
    thermostat = {"thermostat": "v-rescale", "temperature": temperature, "tau_t": PRICE_TAU_T}
    system = switched(SYSTEMS[long["system"]], plan.price_smoothness)
    frame = max(1, int(round(long["frame_ps"] / long["dt"])))
    log(f"[smooth] {SWITCHED_RATTLE.label} (C{plan.price_smoothness}), {long['ps']:g} ps at {temperature:g} K")
    # with a thermostat the total energy is not conserved: the run is not judged by it
    run = runner.vimd(system, SWITCHED_RATTLE, long["dt"], long["ps"], f"smooth-price-{system.name}", 5, frame,
                      thermostat, tolerance=plan.constraint_tolerance, timeout=6 * 3600,
                      stability_fraction=math.inf, threads=plan.smooth_threads)
    compared = {SWITCHED_RATTLE.key: run} | {k: long["runs"][k] for k in (reference_key, RATTLE.key)}
    return {"system": system.name, "atoms": system.atoms, "note": system.note, "smoothness": plan.price_smoothness,
            "dt": long["dt"], "ps": long["ps"], "temperature": temperature, "tau_t": PRICE_TAU_T, "run": run,
            "results": compare_structure(compared, reference_key, report_dir, "smooth", log)}


def compare_structure(compared, reference_key, report_dir, figures_prefix, log):
    """O-O RDF and D of each finished run in `compared` ({key: run}), each RDF's RMS difference to the
    reference run's, and the RDF and MSD figures (<prefix>_rdf_oo.png, <prefix>_msd.png)."""
    results, rdfs, msds = {}, {}, {}
    for key, r in compared.items():
        if "stats" not in r:
            results[key] = {"label": r["label"], "error": f"no finished run ({r['status']}: {r.get('message')})"}
            continue
        results[key], curves = analyse_water(r, log)
        if curves is not None:
            rdfs[key], msds[key] = curves["rdf"], curves["msd"]
    if reference_key in rdfs:
        for key, curve in rdfs.items():
            if key != reference_key:
                results[key]["rdf_rms_vs_gromacs"] = rdf_rms_difference(curve, rdfs[reference_key])
    if rdfs:
        figures.rdf(rdfs, reference_key, report_dir / f"{figures_prefix}_rdf_oo.png")
        figures.msd(msds, report_dir / f"{figures_prefix}_msd.png")
    return results


def pme_price_of_smoothness(runner, plan, report_dir, log):
    """Section 7's recommended smooth PME (plan.pme_price_level) against GROMACS's standard PME on the
    same box: RATTLE on the smooth settings, gmx_d md-vv and vimd RATTLE on the standard ones, all NVE
    from the box's conf.gro with the same step, length and frames; O-O RDF and D compared as in
    section 5. The sampled physics is the Hamiltonian's, so RATTLE stands for every integrator."""
    base = SYSTEMS[plan.pme_system]
    p, k = plan.pme_price_level
    smooth = pme_water(base, plan.pme_cutoff, plan.pme_switch, plan.pme_skin, p, k)
    standard = pme_standard(base, plan.pme_cutoff, plan.pme_skin)
    dt, ps = plan.long_dt, plan.pme_price_ps
    frame = max(1, int(round(plan.long_frame_ps / dt)))
    tag = f"pme-price-{base.name}"
    reference = GMX_VARIANTS[0]
    log(f"[pme price] {reference.label}, standard PME, {ps:g} ps")
    compared = {reference.key: runner.gromacs(standard, reference, dt, ps, tag, 5, frame, timeout=6 * 3600,
                                              stability_fraction=plan.stability_fraction)}
    for variant, system in ((SMOOTH_PME_RATTLE, smooth), (STANDARD_PME_RATTLE, standard)):
        log(f"[pme price] {variant.label}, {ps:g} ps")
        compared[variant.key] = runner.vimd(system, variant, dt, ps, tag, 5, frame, tolerance=plan.constraint_tolerance,
                                            timeout=6 * 3600, stability_fraction=plan.stability_fraction,
                                            threads=plan.smooth_threads)
    return {"system": base.name, "atoms": base.atoms, "level": f"p{p} C{k}", "smooth_note": smooth.note,
            "standard_note": standard.note, "dt": dt, "ps": ps, "frame_ps": frame * dt,
            "runs": compared, "results": compare_structure(compared, reference.key, report_dir, "pme", log)}
