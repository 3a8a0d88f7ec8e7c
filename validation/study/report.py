"""Markdown for validation/report/README.md from the sections' results. Every table row that shows a
number names the command of the run it comes from; derived numbers name the function that derived
them (in validation/study)."""
import math

from .plan import fs

NOT_AVAILABLE = "not available in this build"


def num(x, digits=4):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "n/a"
    if x == 0:
        return "0"
    if 1e-2 <= abs(x) < 1e4:
        return f"{x:.{digits}g}"
    return f"{x:.{digits - 1}e}"


def code(text):
    return f"`{text}`" if text else "-"


def table(header, rows):
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(str(c).replace("|", "\\|").replace("\n", " ") for c in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def status_text(r):
    if r["status"] == "ok":
        return "stable"
    if r["status"] == "not available":
        return f"**{NOT_AVAILABLE}**: {r['message']}"
    if r["status"] == "unstable":
        return f"**unstable**: {r['message']}"
    if r["status"] == "failed":
        return f"**failed** (counted as unstable): {r['message']}"
    return f"not run ({r['message']})"


def details(summary, body):
    return f"<details><summary>{summary}</summary>\n\n{body}\n</details>\n"


# ---------------------------------------------------------------- section 1
def run_row(r):
    if "stats" not in r:
        return [r["label"], fs(r["dt"]), status_text(r)] + ["-"] * 7 + [code(r.get("command"))]
    s, c = r["stats"], r["cost"]
    mean_t = r.get("summary", {}).get("mean_temperature")
    return [r["label"], fs(r["dt"]), status_text(r), num(s["drift_per_atom"]), num(s["rms_fluctuation"]),
            num(s["max_excursion"]), num(mean_t) if mean_t is not None else "-", num(c["evaluations_per_step"]),
            num(c["mean_iterations"]), num(c["wall_per_ps"]), code(r["command"])]


RUN_HEADER = ["integrator", "dt (fs)", "status", "drift (kJ/mol/ps/atom)", "RMS fluct. (kJ/mol)",
              "max abs(E-E0) (kJ/mol)", "mean T (K)", "force+HVP evals/step", "iterations/step", "wall s/ps",
              "command"]


def availability(scan, order, long):
    """Which integrator variants the build rejected, per part of the study."""
    cells = {}
    for name, sres in scan.items():
        for key, runs in sres["series"].items():
            cells.setdefault(key, {"label": runs[0]["label"]})[f"scan {name}"] = runs[0]
    if order:
        for row in order["rows"]:
            cells.setdefault(row["variant"], {"label": row["label"]})["order study"] = row["runs"][0]
    if long:
        for key, r in long["runs"].items():
            cells.setdefault(key, {"label": r["label"]})["long runs"] = r
    columns = [f"scan {n}" for n in scan] + (["order study"] if order else []) + (["long runs"] if long else [])
    rows = []
    for key, cell in cells.items():
        row = [cell["label"]]
        for col in columns:
            r = cell.get(col)
            if r is None:
                row.append("-")
            elif r["status"] == "not available":
                row.append(f"**{NOT_AVAILABLE}**: {r['message']}")
            else:
                row.append("available")
        rows.append(row)
    return table(["integrator"] + columns, rows)


def scan_section(sres):
    name = sres["system"]
    out = [f"### {name} ({sres['atoms']} atoms)\n",
           f"Force field: {sres['note']}. Each run: NVE from `inputs/{name}/conf.gro` (its velocities) for "
           f"{sres['ps']:g} ps or {sres['max_steps']} steps, whichever is shorter; time steps "
           f"{', '.join(fs(d) for d in sres['dts'])} fs in turn until the first step that is not stable.\n",
           f"![drift and fluctuation vs time step, {name}](scan_{name}.png)\n",
           "**Largest stable time step** (study.energy.largest_stable):\n"]
    rows = []
    for key, info in sres["largest"].items():
        runs = sres["series"][key]
        label = runs[0]["label"]
        if runs[0]["status"] == "not available":
            rows.append([label, f"**{NOT_AVAILABLE}**", "-", runs[0]["message"], "-", "-", code(runs[0]["command"])])
            continue
        best, bad = info["best_run"], info["first_bad"]
        if bad is not None:
            why = bad["message"] if bad["status"] == "unstable" else f"run stopped: {bad['message']}"
            bad_dt = fs(bad["dt"])
        else:
            why, bad_dt = "stable at every step tried", "-"
        if best is None:
            rows.append([label, "none", bad_dt, why, "-", "-", code(bad["command"] if bad else "")])
        else:
            rows.append([label, f"**{fs(best['dt'])}**", bad_dt, why, num(best["stats"]["drift_per_atom"]),
                         num(best["stats"]["rms_fluctuation"]), code(best["command"])])
    out.append(table(["integrator", "largest stable dt (fs)", "first dt not stable (fs)", "why",
                      "drift at largest (kJ/mol/ps/atom)", "RMS fluct. at largest (kJ/mol)",
                      "command (largest stable run)"], rows))
    all_rows = []
    for key, runs in sres["series"].items():
        if runs[0]["status"] == "not available":
            all_rows.append(run_row(runs[0]))
        else:
            all_rows += [run_row(r) for r in runs]
    out.append(details(f"All {name} runs ({sum(1 for rs in sres['series'].values() for r in rs if 'command' in r)} "
                       f"commands)", table(RUN_HEADER, all_rows)))
    return "\n".join(out)


# ---------------------------------------------------------------- section 2
def crossover_sentence(label, c, cost_name):
    """One sentence for a candidate-vs-RATTLE crossover dict; also the error below which the
    candidate is cheaper (or None) and whether that rests on RATTLE's measured curve or its fit."""
    kind = c.get("kind")
    if kind == "no data":
        if c.get("reference_points", 0) < 2:
            return f"{label}: RATTLE has fewer than two stable runs, so there is no cost curve to compare.", None, None
        if not c.get("candidate_points"):
            return f"{label}: no stable runs to compare.", None, None
        return (f"{label} is less accurate at every step than RATTLE at its largest stable step: no common "
                f"accuracy.", None, None)
    lo, hi = c["range"]
    r0, r1 = c["ratio_range"]
    below = c.get("extrapolated_below")
    basis = (f" (RATTLE's cost below {num(below, 3)} kJ/mol extrapolated with its power law cost ∝ "
             f"error^-{c['fit_reference'][1]:.2f})" if below else "")
    if kind == "cheaper throughout":
        return (f"{label} is cheaper than RATTLE in {cost_name} at every accuracy compared, RMS fluctuation "
                f"{num(lo, 3)}-{num(hi, 3)} kJ/mol ({num(r0, 3)}-{num(r1, 3)}x RATTLE's cost){basis}.",
                hi, "cheaper at every accuracy compared, the least accurate being this")
    if kind == "dearer throughout":
        return (f"{label} costs more than RATTLE in {cost_name} at every accuracy compared, RMS fluctuation "
                f"{num(lo, 3)}-{num(hi, 3)} kJ/mol ({num(r0, 3)}-{num(r1, 3)}x RATTLE's cost){basis}.", None, None)
    xs = ", ".join(f"{num(x, 3)} kJ/mol ({'measured' if m else 'RATTLE extrapolated'})" for x, m in c["crossings"])
    if c["cheaper_below"]:
        x, m = c["crossings"][0]
        return (f"{label} is cheaper than RATTLE in {cost_name} for RMS fluctuation below {xs}, dearer above "
                f"(compared over {num(lo, 3)}-{num(hi, 3)} kJ/mol){basis}.", x,
                "measured crossing" if m else "crossing with RATTLE's cost extrapolated")
    return (f"{label} is cheaper than RATTLE in {cost_name} only above {xs} (compared over {num(lo, 3)}-"
            f"{num(hi, 3)} kJ/mol){basis}.", None, None)


COSTS = (("wall_per_ps", "wall time per ps"), ("evaluations_per_ps", "force-evaluation equivalents per ps"))


def crossover_block(sres):
    """The crossover statement (per cost measure, the variational integrator that becomes cheaper
    than RATTLE at the loosest accuracy) and the table of every integrator against RATTLE."""
    rows, best = [], {}
    for key, costs in sres["crossovers"].items():
        label = sres["series"][key][0]["label"]
        for cost, cost_name in COSTS:
            sentence, threshold, how = crossover_sentence(label, costs[cost], cost_name)
            rows.append([label, cost_name, sentence])
            if key.startswith("vi-") and threshold is not None and (cost not in best or threshold > best[cost][1]):
                best[cost] = (label, threshold, how)
    ran = [k for k, runs in sres["series"].items() if k.startswith("vi-") and any(r["status"] == "ok" for r in runs)]
    if not ran:
        headline = (f"On {sres['system']}, no variational integrator has a stable run in this build (see the "
                    f"availability table), so no crossover can be stated.")
    else:
        parts = []
        for cost, cost_name in COSTS:
            if cost in best:
                label, threshold, how = best[cost]
                parts.append(f"in {cost_name}, the variational integrators are cheaper than RATTLE from an RMS "
                             f"energy fluctuation of about {num(threshold, 3)} kJ/mol downward ({label}; {how})")
            else:
                parts.append(f"in {cost_name}, no variational integrator is cheaper than RATTLE at any accuracy "
                             f"compared here")
        headline = f"On {sres['system']}: " + "; ".join(parts) + "."
    return headline, table(["integrator", "cost measure", "against RATTLE (study.energy.crossover)"], rows)


def work_precision_section(sres):
    name = sres["system"]
    headline, tab = crossover_block(sres)
    return "\n".join([
        f"### {name}\n",
        f"![work-precision, {name}](work_precision_{name}.png)\n",
        "Stable runs of section 1 only (their commands are in the tables there). Cost curves are the Pareto "
        "fronts of (cost, RMS fluctuation) points, interpolated linearly in log-log. Each integrator is "
        "compared with RATTLE over its own range of errors; where it is more accurate than RATTLE ever was, "
        "RATTLE's cost is extrapolated with the power law fitted to its front (never the candidate's). "
        "A crossing is where the two curves meet.\n",
        f"**Crossover:** {headline}\n", tab])


# ---------------------------------------------------------------- section 3
def order_section(order):
    ref = order["reference"]
    out = [f"Cluster `inputs/cluster8` ({order['atoms']} atoms; {order['note']}), NVE for {order['horizon']:g} ps "
           f"from its `conf.gro`; solver and constraint tolerance {order['tolerance']:g}. Error = largest distance "
           f"between an atom's position at {order['horizon']:g} ps and the reference solution's (positions read "
           f"in full precision with `gmx_d traj -fp`: MDAnalysis reads .trr in single precision). Slope = "
           f"least-squares slope of log(error) vs log(dt) over the three smallest steps whose error is 10x above "
           f"the larger of the reference's own error and the round-off floor of {num(order['error_floor'], 3)} nm "
           f"(below it the errors stop shrinking with dt: round-off and the solve's tolerance; "
           f"study.energy.fit_order).\n"]
    if ref is None:
        out.append("**No reference solution**: no candidate method (rk rk6, vi rk6, rk rk4, rattle) finished; "
                   "errors cannot be computed.\n")
    else:
        out.append(f"Reference: {ref['label']} at dt = {fs(ref['run']['dt'])} fs ({code(ref['run']['command'])}); "
                   f"its error, estimated against the same method at twice the step ({code(ref['check']['command'])}), "
                   f"is {num(ref['error'], 3)} nm.\n")
    out.append("![order study](order_cluster8.png)\n")
    dts = sorted({dt for row in order["rows"] for dt in row["dts"]})
    rows, run_rows = [], []
    for row in order["rows"]:
        first = row["runs"][0]
        if first["status"] == "not available":
            rows.append([row["label"], row["order"], f"**{NOT_AVAILABLE}**: {first['message']}", "-"]
                        + ["-"] * len(dts))
        else:
            errs = dict(zip(row["dts"], row["errors"]))
            slope = num(row["slope"], 3) if row["slope"] is not None else "n/a (errors at the reference's level)"
            fit = ", ".join(fs(d) for d in row["fit_dts"])
            rows.append([row["label"], row["order"], slope, fit or "-"] + [num(errs.get(d), 3) for d in dts])
        for r, e in zip(row["runs"], row["errors"]):
            cmd = code(r["command"]) + ("; then " + code(r["positions_command"]) if r.get("positions_command") else "")
            run_rows.append([row["label"], fs(r["dt"]), status_text(r), num(e, 3), cmd])
    out.append(table(["method", "nominal order", "fitted slope", "fitted over dt (fs)"] +
                     [f"error at {fs(d)} fs (nm)" for d in dts], rows))
    shake = next((row for row in order["rows"] if row["variant"] == "shake"), None)
    if shake and shake["slope"] is not None and shake["slope"] < 1.5:
        out.append(f"SHAKE's slope of {num(shake['slope'], 3)} is not a defect of its update: the leap-frog scheme "
                   "takes the input velocities as v(-dt/2) (as GROMACS's `md` does), while every other method "
                   "takes them as v(0); that half-step shift of the initial condition is an O(dt) error in the "
                   "positions that dominates the second-order local error (compare the `gmx_d` md row).\n")
    out.append(details(f"Order-study runs ({len(run_rows)} commands)",
                       table(["method", "dt (fs)", "status", "error (nm)", "commands"], run_rows)))
    return "\n".join(out)


# ---------------------------------------------------------------- sections 4 and 5
def long_section(long):
    rows = []
    for key, r in long["runs"].items():
        if "stats" in r:
            s = r["stats"]
            change = s["drift_per_atom"] * r["atoms"] * r["ps"]
            ratio = abs(change) / s["rms_fluctuation"] if s["rms_fluctuation"] > 0 else float("inf")
            verdict = "bounded" if ratio < 1 else "drifting"
            rows.append([r["label"], num(r["ps"]), status_text(r), num(s["drift_per_atom"]), num(s["rms_fluctuation"]),
                         num(s["max_excursion"]), num(change), f"{num(ratio, 3)} ({verdict})",
                         num(r["cost"]["wall_per_ps"]), code(r["command"])])
        else:
            stopped = f" (energies up to {num(r['stopped_at'])} ps are in the figure)" if "stopped_at" in r else ""
            rows.append([r["label"], num(r["ps"]), status_text(r) + stopped] + ["-"] * 6 + [code(r.get("command"))])
    return "\n".join([
        f"`inputs/{long['system']}` ({long['atoms']} atoms; {long['note']}), dt = {fs(long['dt'])} fs, "
        f"{long['ps']:g} ps NVE per integrator, frames every {long['frame_ps']:g} ps for section 5.\n",
        "![long runs](long_runs.png)\n",
        "Bounded or drifting: the energy change over the whole run implied by the fitted drift, compared with "
        "the RMS fluctuation about the fit; below 1 the drift is hidden in the fluctuation (bounded), above 1 "
        "it is not (drifting).\n",
        table(["integrator", "length (ps)", "status", "drift (kJ/mol/ps/atom)", "RMS fluct. (kJ/mol)",
               "max abs(E-E0) (kJ/mol)", "fitted change over the run (kJ/mol)", "abs(change) / RMS fluct.",
               "wall s/ps", "command"], rows)])


def mdanalysis_section(md, long):
    res = md["results"]
    if not res:
        return "No long run finished, so there is no trajectory to analyse.\n"
    failed = [f"- {v['label']}: {v['error']}" for v in res.values() if "error" in v]
    ok = {k: v for k, v in res.items() if "error" not in v}
    parts = [f"Trajectories of section 4 (`inputs/{long['system']}`), opened as "
             "`MDAnalysis.Universe(confout.gro, traj.trr)` (GROMACS: its `gmx.gro`, `gmx.trr`) by "
             "validation/study/trajectories.py; all frames.\n"]
    if failed:
        parts.append("\n".join(failed) + "\n")
    parts += ["#### O-O radial distribution function\n", "![O-O RDF](rdf_oo.png)\n",
              table(["trajectory", "frames", "first peak r (nm)", "g(peak)", "RMS difference to GROMACS (r > 0.2 nm)",
                     "command"],
                    [[v["label"], v["frames"], num(v["rdf_peak_r"]), num(v["rdf_peak_g"]),
                      num(v.get("rdf_rms_vs_gromacs")) if "rdf_rms_vs_gromacs" in v else "(reference)",
                      code(v["command"])] for v in ok.values()]),
              "#### Constraint-length deviations\n", "![constraint deviations](constraint_deviations.png)\n",
              f"MDAnalysis holds coordinates in single precision: deviations below about "
              f"{num(md['resolution'], 2)} (relative) are the reader's rounding, not the engine's constraint error; "
              "the right panel shows the engine's own double-precision residual.\n",
              table(["trajectory", "median abs dev (relative, MDAnalysis)", "max abs dev (relative, MDAnalysis)",
                     "max constraint_rms (engine, energy.csv)", "command"],
                    [[v["label"], num(v["dev_median"], 3), num(v["dev_max"], 3),
                      num(v["engine_constraint_rms_max"], 3) if v["engine_constraint_rms_max"] is not None else "-",
                      code(v["command"])] for v in ok.values()]),
              "#### Mean-square displacement and diffusion coefficient\n", "![MSD](msd.png)\n",
              "D = slope / 6 of the oxygens' MSD, fitted between 10 % and 50 % of the trajectory length "
              "(positions unwrapped frame to frame by minimum image). SPC/E's literature value is about "
              "2.5e-5 cm²/s at 300 K with Ewald; reaction field and the small box shift it.\n",
              table(["trajectory", "D (cm²/s)", "fit window (ps)", "command"],
                    [[v["label"], num(v["diffusion"], 3),
                      f"{v['msd_window'][0]:g}-{v['msd_window'][1]:g}" if v["msd_window"] else "-",
                      code(v["command"])] for v in ok.values()]),
              "#### Temperature\n", "![temperature](temperature.png)\n",
              "MDAnalysis: kinetic temperature from the trajectory's velocities with 3N - N_constraints - 3 degrees "
              "of freedom; engine: mean of the temperature column of its energy output (its own degree-of-freedom "
              "count).\n",
              table(["trajectory", "mean T, MDAnalysis (K)", "mean T, engine (K)", "degrees of freedom", "command"],
                    [[v["label"], num(v["temperature_mdanalysis"]), num(v["temperature_engine"]), v["dof"],
                      code(v["command"])] for v in ok.values()])]
    return "\n".join(parts)


# ---------------------------------------------------------------- closing note
def closing_note(scan, reference_dts):
    out = []
    for name, dt in reference_dts.items():
        if name not in scan:
            continue
        sres = scan[name]
        rows = []
        for key, runs in sres["series"].items():
            match = [r for r in runs if abs(r["dt"] - dt) < 1e-12]
            if runs[0]["status"] == "not available":
                rows.append([runs[0]["label"], f"**{NOT_AVAILABLE}**", "-", "-", code(runs[0]["command"])])
            elif not match:
                rows.append([runs[0]["label"], "not run at this step", "-", "-", "-"])
            elif "stats" not in match[0]:
                rows.append([runs[0]["label"], status_text(match[0]), "-", "-", code(match[0].get("command"))])
            else:
                r = match[0]
                rows.append([r["label"], "stable" if r["status"] == "ok" else "**unstable**",
                             num(r["stats"]["drift_per_atom"]), num(r["stats"]["rms_fluctuation"]), code(r["command"])])
        length = min(sres["ps"], sres["max_steps"] * dt)
        out.append(f"**{name}, dt = {fs(dt)} fs, {length:g} ps NVE:**\n")
        out.append(table(["integrator", "status", "drift (kJ/mol/ps/atom)", "RMS fluct. (kJ/mol)", "command"], rows))
        headline, _ = crossover_block(sres)
        out.append(f"**Crossover ({name}):** {headline}\n")
    return "\n".join(out)


def write(path, plan, meta, scan, order, long, md):
    quick_banner = ("> **Quick mode** (`--quick`): a smoke test with runs far too short for conclusions; the "
                    "committed full report is `validation/report/README.md`.\n\n" if plan.quick else "")
    text = [
        "# vimd validation study: RATTLE vs variational integrators, with MDAnalysis and GROMACS\n",
        quick_banner,
        f"Regenerated by `{meta['command']}` on {meta['date']} from git {meta['git']}; vimd binary "
        f"`{meta['vimd']}` ({meta['vimd_state']}); {meta['threads']} OpenMP thread(s) per run. The runs took "
        f"{meta['run_minutes']:.1f} min of wall time"
        + (" when they ran (this invocation reused them: `--reuse`, same configs and binary)" if meta["reuse"]
           else f", the whole study {meta['minutes']:.1f} min")
        + f"; load average {meta['load_before']} before, {meta['load_after']} after (the 2-core machine is "
        "shared, so wall times are noisy).\n",
        "Every number comes from the run whose command is in its table row. Config files (`.toml` for vimd, "
        "`.mdp` for GROMACS) are kept next to this report in `configs/` and name their inputs by relative path; "
        f"run outputs go to `{meta['runs']}` (not in the repository). Derived quantities are computed from those "
        "outputs by the Python package `validation/study` (the function is named where it matters).\n",
        "## Contents\n",
        "0. [Set-up and definitions](#set-up-and-definitions)\n1. [Energy drift and fluctuation vs time step]"
        "(#1-energy-drift-and-fluctuation-vs-time-step)\n2. [Work-precision](#2-work-precision)\n3. [Order study]"
        "(#3-order-study)\n4. [Long runs](#4-long-runs)\n5. [MDAnalysis analyses](#5-mdanalysis-analyses)\n"
        "6. [Closing note](#closing-note)\n",
        "## Set-up and definitions\n",
        "- **Energy drift**: slope of a least-squares line through the total energy of the run, per atom "
        "(kJ/mol/ps/atom). **RMS fluctuation**: root mean square of the total energy about that line (kJ/mol). "
        f"Energies are sampled about every {plan.energy_interval_ps * 1000:g} fs (or every step). Both by "
        "study.energy.energy_statistics, the same code for vimd (its `energy.csv`) and GROMACS (`gmx_d energy`).\n"
        f"- **Stable**: the run finished and abs(E(t) - E(0)) stayed below {plan.stability_fraction:g} x the mean "
        "kinetic energy (about 3 K of temperature at 300 K). A run that stops with an error (non-convergence, "
        "constraint failure) is not stable; an integrator the engine rejects is marked "
        f"\"{NOT_AVAILABLE}\" with the engine's message.\n"
        "- **Cost**: wall time per simulated ps (vimd: `wall_seconds` of its summary.json; GROMACS: wall time in "
        "its log); **force-evaluation equivalents** per ps = (force evaluations + Hessian-vector products per "
        "step, from summary.json, one HVP counted as one force evaluation) / dt; GROMACS: one per step.\n"
        f"- vimd constraint tolerance {plan.constraint_tolerance:g} (relative); the variational integrators' "
        "solver tolerance is the engine's default unless stated.\n",
        "**Integrator availability in this build** (every variant the study asks for; the engine's message "
        "when it rejected one):\n",
        availability(scan, order, long),
        "## 1. Energy drift and fluctuation vs time step\n",
        *[scan_section(s) for s in scan.values()],
        "## 2. Work-precision\n",
        *[work_precision_section(s) for s in scan.values()],
        "## 3. Order study\n",
        order_section(order) if order else "Not run.\n",
        "## 4. Long runs\n",
        long_section(long) if long else "Not run.\n",
        "## 5. MDAnalysis analyses\n",
        mdanalysis_section(md, long) if md else "Not run.\n",
        "## Closing note\n",
        closing_note(scan, meta["closing_dts"]),
    ]
    path.write_text("\n".join(t for t in text if t))
