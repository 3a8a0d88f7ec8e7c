"""Markdown for validation/report/README.md from the sections' results. Every table row that shows a
number names the command of the run it comes from; derived numbers name the function that derived
them (in validation/study)."""
import math

from .plan import GMX_VARIANTS, RATTLE, SMOOTH_PME_RATTLE, STANDARD_PME_RATTLE, SWITCHED_RATTLE, fs

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
def crossover_sentence(label, c, cost_name, reference="RATTLE"):
    """One sentence for a candidate's crossover dict against `reference` (RATTLE, or the best peer:
    the cheapest of RATTLE and its compositions); also the error below which the candidate is
    cheaper (or None) and whether that rests on the reference's measured curve or its fit."""
    kind = c.get("kind")
    if kind == "no data":
        if c.get("reference_points", 0) < 2:
            return (f"{label}: {reference}'s stable runs give fewer than two points of a cost curve (a run that is "
                    f"both dearer and less accurate than another is not on it), so there is none to compare.",
                    None, None)
        if not c.get("candidate_points"):
            return f"{label}: no stable runs to compare.", None, None
        return (f"{label} is less accurate at every step than {reference} at its largest stable step: no common "
                f"accuracy.", None, None)
    lo, hi = c["range"]
    r0, r1 = c["ratio_range"]
    below = c.get("extrapolated_below")
    basis = (f" ({reference}'s cost below {num(below, 3)} kJ/mol extrapolated with its power law cost ∝ "
             f"error^-{c['fit_reference'][1]:.2f})" if below else "")
    if kind == "cheaper throughout":
        return (f"{label} is cheaper than {reference} in {cost_name} at every accuracy compared, RMS fluctuation "
                f"{num(lo, 3)}-{num(hi, 3)} kJ/mol ({num(r0, 3)}-{num(r1, 3)}x {reference}'s cost){basis}.",
                hi, "cheaper at every accuracy compared, the least accurate being this")
    if kind == "dearer throughout":
        return (f"{label} costs more than {reference} in {cost_name} at every accuracy compared, RMS fluctuation "
                f"{num(lo, 3)}-{num(hi, 3)} kJ/mol ({num(r0, 3)}-{num(r1, 3)}x {reference}'s cost){basis}.",
                None, None)
    xs = ", ".join(f"{num(x, 3)} kJ/mol ({'measured' if m else reference + ' extrapolated'})"
                   for x, m in c["crossings"])
    if c["cheaper_below"]:
        x, m = c["crossings"][0]
        return (f"{label} is cheaper than {reference} in {cost_name} for RMS fluctuation below {xs}, dearer above "
                f"(compared over {num(lo, 3)}-{num(hi, 3)} kJ/mol){basis}.", x,
                "measured crossing" if m else f"crossing with {reference}'s cost extrapolated")
    return (f"{label} is cheaper than {reference} in {cost_name} only above {xs} (compared over {num(lo, 3)}-"
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
              "2.5e-5 cm²/s at 300 K with Ewald; reaction field and the small box shift it. Its standard error: "
              f"the spread of D fitted the same way on {next(iter(ok.values()))['diffusion_blocks']} consecutive "
              "blocks of the trajectory, over the square root of their number.\n",
              table(["trajectory", "D (cm²/s)", "standard error (cm²/s)", "fit window (ps)", "command"],
                    [[v["label"], num(v["diffusion"], 3), num(v["diffusion_error"], 2),
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


# ---------------------------------------------------------------- section 6
def _labels(level):
    return {key: runs[0]["label"] for key, runs in level["series"].items()}


def _equivalent_text(e, labels):
    who = labels[e["peer"]]
    return f"{who}'s runs interpolated" if e["basis"] == "interpolated" else f"{who}'s power law extrapolated"


# What a run is compared with: its equivalent-cost entry, the level's crossovers, the reference's name.
AGAINST = {"rattle": ("rattle_equivalent", "crossovers", "RATTLE"),
           "peer": ("peer_equivalent", "peer_crossovers", "the best peer")}


def best_equivalent(runs, name, basis=None):
    """The stable run with the largest reference time / its time (only those whose reference cost has
    this basis, if given), or None."""
    ranked = [r for r in runs if r["status"] == "ok" and name in r and basis in (None, r[name]["basis"])]
    return max(ranked, key=lambda r: r[name]["ratio"]) if ranked else None


def level_name(k):
    """A level of section 6 (its smoothness k) or 7 (its name, "p8 C4") as the tables show it."""
    return f"C{k}" if isinstance(k, int) else k


def _ratio_text(t, name):
    run, labels = t["best"] if name == "best" else t["best_interpolated"], t["labels"]
    e = run[t["name"]]
    return (f"**{num(e['ratio'], 3)}x** — {t['label']} at {level_name(t['k'])}, dt = {fs(run['dt'])} fs, reaches an "
            f"RMS fluctuation of {num(run['stats']['rms_fluctuation'], 3)} kJ/mol in "
            f"{num(run['cost']['wall_per_ps'], 3)} s per ps; {labels[e['peer']]} needs {num(e['wall_per_ps'], 3)} s "
            f"per ps for it ({_equivalent_text(e, labels)})")


def _cheapest_peers_text(c, labels):
    segments = c.get("cheapest_reference") or []
    if len(segments) < 2:
        return f" Best peer throughout: {labels[segments[0][0]]}." if segments else ""
    return " Best peer: " + ", ".join(f"{labels[key]} at {num(lo, 3)}-{num(hi, 3)} kJ/mol"
                                       for key, lo, hi in segments) + "."


def smooth_crossover_rows(sm, against):
    """Per (level, integrator): the best wall-time ratio of the reference (against = "rattle": RATTLE,
    for every composition and vi; "peer": the best peer, for every vi) to the integrator, and the
    crossover accuracy."""
    name, crossovers, reference = AGAINST[against]
    rows, summary = [], []
    for k, level in sm["levels"].items():
        labels = _labels(level)
        for key, c in level[crossovers].items():
            runs = level["series"][key]
            label = labels[key]
            sentence, threshold, how = crossover_sentence(label, c, "wall time per ps", reference)
            if against == "peer":
                sentence += _cheapest_peers_text(c, labels)
            best = best_equivalent(runs, name)
            if best is None:
                rows.append([level_name(k), label, "n/a", "-", "-", "-", "-", "-", sentence,
                             code(runs[0].get("command"))])
                continue
            e = best[name]
            rows.append([level_name(k), label, f"**{num(e['ratio'], 3)}**", fs(best["dt"]),
                         num(best["stats"]["rms_fluctuation"], 3), num(best["cost"]["wall_per_ps"], 3),
                         num(e["wall_per_ps"], 3), _equivalent_text(e, labels),
                         (f"{num(threshold, 3)} kJ/mol ({how}). " if threshold is not None else "") + sentence,
                         code(best["command"])])
            if key.startswith("vi-"):
                summary.append({"k": k, "smoothness": level["smoothness"], "label": label, "labels": labels,
                                "name": name, "best": best,
                                "best_interpolated": best_equivalent(runs, name, "interpolated"),
                                "threshold": threshold, "how": how})
    return rows, summary


def smooth_headline(summary, reference):
    """A crossover statement of section 6 or 7 against `reference`, from the data: at smoothness >= 4
    (else at any), the best ratio, the best with the reference's cost interpolated between its runs,
    and the loosest accuracy from which a variational integrator is cheaper."""
    smooth_enough = [t for t in summary if t["smoothness"] >= 4] or summary
    if not smooth_enough:
        return (f"No variational integrator run could be compared with {reference} (the reason per integrator is in "
                "the table), so no crossover can be stated.")
    where = " at smoothness >= 4" if smooth_enough[0]["smoothness"] >= 4 else ""
    name = smooth_enough[0]["name"]
    ratio = lambda run: run[name]["ratio"]  # noqa: E731
    t = max(smooth_enough, key=lambda t: ratio(t["best"]))
    text = [f"Best wall-time ratio {reference} / vi{where}: {_ratio_text(t, 'best')}."]
    inside = [t for t in smooth_enough if t["best_interpolated"]]
    if inside:
        t = max(inside, key=lambda t: ratio(t["best_interpolated"]))
        text.append(f"Best with {reference}'s cost interpolated between measured runs: "
                    f"{_ratio_text(t, 'interpolated')}.")
    else:
        text.append(f"No vi run lies inside {reference}'s measured range of RMS fluctuation, so every ratio rests on "
                    "an extrapolated power law.")
    cheaper = [t for t in smooth_enough if t["threshold"] is not None]
    if cheaper:
        t = max(cheaper, key=lambda t: t["threshold"])
        text.append(f"Crossover accuracy: below an RMS fluctuation of **{num(t['threshold'], 3)} kJ/mol** a "
                    f"variational integrator is cheaper in wall time than {reference} ({t['label']} at "
                    f"{level_name(t['k'])}; {t['how']}).")
    else:
        text.append(f"No variational integrator is cheaper than {reference} at any accuracy compared here.")
    return " ".join(text)


def equal_accuracy_rows(sm):
    """Per level and decade of RMS fluctuation: every integrator's wall time per ps there, the best
    peer and the best vi named, and the peer's time over the vi's (study.energy.equal_accuracy)."""
    keys = list(dict.fromkeys(key for level in sm["levels"].values() for key in level["series"]))
    labels = {key: label for level in sm["levels"].values() for key, label in _labels(level).items()}
    rows = []
    for k, level in sm["levels"].items():
        for row in level.get("equal_accuracy", []):
            costs = row["costs"]
            name = lambda key: labels[key] if key else "-"  # noqa: E731
            rows.append([level_name(k), num(row["error"], 2)] + [num(costs[key], 3) if costs.get(key) else "-"
                                                                 for key in keys]
                        + [name(row["best_peer"]), name(row["best_candidate"]),
                           f"**{num(row['peer_over_candidate'], 3)}**" if row["peer_over_candidate"] else "-"])
    return ["level", "RMS fluct. (kJ/mol)"] + [f"{labels[key]} s/ps" for key in keys] + [
        "best peer", "best vi", "best peer time / best vi time"], rows


def smooth_slopes(sm):
    dts = sorted({r["dt"] for level in sm["levels"].values() for runs in level["series"].values() for r in runs})
    rows, stated = [], []
    for k, level in sm["levels"].items():
        for key, runs in level["series"].items():
            fit = level["fits"][key]
            label = runs[0]["label"]
            rms = {r["dt"]: r["stats"]["rms_fluctuation"] for r in runs if "stats" in r and r["status"] == "ok"}
            stable = [r["dt"] for r in runs if r["status"] == "ok"]
            slope = num(fit["slope"], 3) if fit["slope"] is not None else "n/a (fewer than two points above the floor)"
            rows.append([level_name(k), label, fit["order"], slope, ", ".join(fs(d) for d in fit["fit_dts"]) or "-",
                         ", ".join(f"{x:.2f}" for x in fit["local_slopes"]) or "-",
                         fs(max(stable)) if stable else "none"] + [num(rms.get(d), 3) if d in rms else "-" for d in dts])
            if fit["slope"] is not None:
                stated.append(f"{label} {num(fit['slope'], 3)} ({level_name(k)})")
    return rows, dts, stated


def smooth_section(sm):
    ff = next(iter(sm["levels"].values()))["forcefield"]
    intro = (_runs_text(sm) + "Interactions: LJ "
             f"and reaction field (eps_rf = infinity) both switched to zero between {ff['vdw_switch']:g} and "
             f"{ff['cutoff']:g} nm (`vdw_modifier` and `coulomb_modifier` = \"potential-switch\"), neighbour skin "
             f"{ff['neighbor_skin']:g} nm, the pair potential C^k at both ends of the switch for k = "
             f"{', '.join(str(k) for k in sm['levels'])} (`switch_smoothness`; 2 is GROMACS's quintic "
             f"potential-switch). " + _solver_text(sm))
    return "\n".join([intro] + _levels_body(sm, "smooth") +
                     ["### The price of smoothness\n", price_section(sm["price"]),
                      "### The solver's tolerance\n", tolerance_section(sm["tolerance"])])


def tolerance_section(tol):
    def cell(r):
        if r["status"] != "ok":
            return status_text(r)
        s = r["summary"]
        shown = (f" at {num(s['mean_vi_tolerance'], 2)}" if "mean_vi_tolerance" in s else "")
        return (f"{num(r['stats']['rms_fluctuation'], 3)} ({r['rms_vs_tightest'] * 100:+.1f} %), "
                f"{num(r['cost']['mean_iterations'], 3)} it.{shown}")

    rows = [[c["label"], fs(c["dt"])] + [cell(c["runs"][name]) for name in tol["settings"]] +
            [c["loosest"] or "none", code(c["runs"]["auto"].get("command"))] for c in tol["cases"]]
    return (f"`inputs/{tol['system']}` ({tol['atoms']} atoms), {tol['note']}, {tol['ps']:g} ps NVE per run from its "
            "`conf.gro`: each variational integrator at fixed solver tolerances (nm/ps), at the bias's default "
            "(`solver_tolerance` unset) and at `\"auto\"` (a hundredth of the last step's offset from the "
            "method's own explicit step; its mean tolerance shown). Each cell: RMS fluctuation (kJ/mol), its "
            "difference to the tightest tolerance's, and iterations per step. \"Loosest\": the loosest fixed "
            f"tolerance within {tol['within'] * 100:g} % of the tightest's RMS fluctuation.\n\n" +
            table(["integrator", "dt (fs)"] + [f"tolerance {name}" for name in tol["settings"]] +
                  ["loosest fixed", "command (auto)"], rows))


def pme_section(pm):
    ff = next(iter(pm["levels"].values()))["forcefield"]
    intro = (_runs_text(pm) + "Interactions: particle-mesh Ewald (`coulomb = \"pme\"`, "
             f"ewald_rtol {ff['ewald_rtol']:g}, fourier_spacing {ff['fourier_spacing']:g} nm), its real space and LJ "
             f"switched to zero between {ff['coulomb_switch']:g} and {ff['cutoff']:g} nm with beta chosen so that "
             f"erfc(beta {ff['coulomb_switch']:g} nm) = ewald_rtol (docs/pme.md), neighbour skin "
             f"{ff['neighbor_skin']:g} nm. A level \"pP Ck\" is B-spline order P (`pme_order`: the mesh energy is "
             f"C^(P-2)) with the switch C^k. " + _solver_text(pm))
    return "\n".join([intro] + _levels_body(pm, "pme") + ["### The price of smoothness on PME water\n",
                                                          pme_price_section(pm["price"])])


def polymer_section(pol):
    level = next(iter(pol["levels"].values()))
    intro = (_runs_text(pol) + f"The OPLS-AA n-decane melt: {level['note']}; a level \"h-bonds Ck\" makes the "
             "C-H bonds rigid (GROMACS's `constraints = h-bonds`), \"all-bonds\" every bond; C^k is the switch's "
             "smoothness. " + _solver_text(pol))
    return "\n".join([intro] + _levels_body(pol, "polymer"))


def _runs_text(sm):
    return (f"`inputs/{sm['system']}` ({sm['atoms']} atoms), NVE from its `conf.gro` for {sm['ps']:g} ps per run, "
            f"{sm['threads']} OpenMP threads per run (the crossover is stated at this thread count). ")


def _solver_text(sm):
    solver = sm["solver_tolerance"]
    solver = f"`\"{solver}\"`" if isinstance(solver, str) else f"{solver:g} nm/ps"
    return (f"vi solver tolerance {solver} (max_iterations {sm['max_iterations']}), constraint "
            f"tolerance {sm['constraint_tolerance']:g}; energies every {sm['energy_interval'] * 1000:g} fs in every "
            "run. Each integrator runs its steps in turn until the first that is not stable or does not converge. "
            f"The section's runs took {sm['run_minutes']:.1f} min of wall time.\n")


def _levels_body(sm, figures_prefix):
    """Slopes, RATTLE's equivalent cost, the crossover and every run, for the levels of section 6 or 7."""
    out = [f"![RMS fluctuation vs time step]({figures_prefix}_rms.png)\n"]
    rows, dts, stated = smooth_slopes(sm)
    out.append(f"**Fitted slopes** of log(RMS fluctuation) vs log(dt) (study.energy.fit_order: the three smallest "
               f"stable steps whose RMS fluctuation is above 10 x {num(sm['floor'], 2)} kJ/mol, the round-off and "
               f"solver floor): " + ("; ".join(stated) if stated else "none (too few points)") + ".\n")
    out.append(table(["smoothness", "integrator", "nominal order", "slope of RMS vs dt", "fitted over dt (fs)",
                      "local slopes", "largest stable dt (fs)"] + [f"RMS at {fs(d)} fs (kJ/mol)" for d in dts], rows))
    crossover_rows, summary = smooth_crossover_rows(sm, "rattle")
    peer_rows, peer_summary = smooth_crossover_rows(sm, "peer")
    fits = ", ".join(f"{level_name(k)}: cost ∝ error^-{level['rattle_fit'][1]:.2f}" for k, level in sm["levels"].items()
                     if level["rattle_fit"])
    header, accuracy_rows = equal_accuracy_rows(sm)
    out += [f"![work-precision]({figures_prefix}_work_precision.png)\n",
            "**The peers** are RATTLE and its compositions (`composition`: yoshida4, suzuki4, kahan-li6, "
            "kahan-li8), the constrained methods a variational integrator must beat. **Work-precision at equal "
            "accuracy**: each integrator's wall time per ps at a decade of RMS fluctuation, interpolated in "
            "log-log between its stable runs and shown only inside their range (study.energy.equal_accuracy); "
            "the best peer and the best vi named at each.\n",
            table(header, accuracy_rows),
            "**Equivalent cost** of every stable run: the wall time per ps a reference needs for the same RMS "
            "fluctuation, interpolated in log-log between its stable runs at the same level where the "
            "fluctuation lies in their range, else extrapolated with the power law fitted to them (study.energy."
            f"cheapest_reference; RATTLE's measured laws: {fits or 'none'}; an exact dt² law is error^-0.50). "
            "Against the best peer, the reference at each accuracy is the cheapest of the peers there. "
            "Crossover accuracy: the RMS fluctuation below which the integrator is cheaper than the reference "
            "(study.energy.crossover).\n",
            f"**Crossover:** {smooth_headline(peer_summary, 'the best peer')} Against plain RATTLE: "
            f"{smooth_headline(summary, 'RATTLE')}\n",
            "Against the best peer (the cheapest of RATTLE and its compositions at each accuracy):\n",
            table(["smoothness", "integrator", "best peer time / vi time", "at dt (fs)", "RMS fluct. (kJ/mol)",
                   "vi wall s/ps", "peer wall s/ps for it", "peer's cost", "crossover accuracy", "command"],
                  peer_rows),
            "Against plain RATTLE (compositions and vi):\n",
            table(["smoothness", "integrator", "best RATTLE time / its time", "at dt (fs)", "RMS fluct. (kJ/mol)",
                   "its wall s/ps", "RATTLE wall s/ps for it", "RATTLE's cost", "crossover accuracy", "command"],
                  crossover_rows)]
    for k, level in sm["levels"].items():
        run_rows = []
        labels = _labels(level)
        for runs in level["series"].values():
            for r in runs:
                row, extra = run_row(r), []
                for name in ("rattle_equivalent", "peer_equivalent"):
                    e = r.get(name)
                    extra += ([num(e["wall_per_ps"], 3), _equivalent_text(e, labels), num(e["ratio"], 3)] if e
                              else ["-"] * 3)
                run_rows.append(row[:-1] + extra + row[-1:])
        out.append(details(f"All runs at {level_name(k)} ({len(run_rows)})",
                           table(RUN_HEADER[:-1] + ["RATTLE wall s/ps at this RMS", "RATTLE's cost",
                                                    "RATTLE time / its time", "best peer wall s/ps at this RMS",
                                                    "best peer's cost", "best peer time / vi time", "command"],
                                 run_rows)))
    return out


STRUCTURE_HEADER = ["trajectory", "frames", "first peak r (nm)", "g(peak)", "RMS RDF difference to GROMACS",
                    "D ± error (cm²/s)", "mean T, engine (K)", "command"]


def structure_rows(results):
    rows = []
    for v in results.values():
        if "error" in v:
            rows.append([v["label"], v["error"]] + ["-"] * 6)
            continue
        d = f"{num(v['diffusion'], 3)} ± {num(v['diffusion_error'], 2)}" if v["diffusion"] is not None else "n/a"
        diff = v.get("rdf_rms_vs_gromacs")
        rows.append([v["label"], v["frames"], num(v["rdf_peak_r"]), num(v["rdf_peak_g"]),
                     num(diff, 3) if diff is not None else "(reference)", d, num(v["temperature_engine"]),
                     code(v["command"])])
    return rows


def structure_sentence(what, changed, reference, own):
    """What `what` does to the O-O RDF and D: `changed` against the GROMACS `reference` run, with
    vimd's `own` run on the reference's interactions for scale; "" if a run lacks a result."""
    if not all("error" not in v and v.get("diffusion") is not None for v in (changed, reference)):
        return ""
    sentence = (f"{what} changes the O-O RDF by an RMS difference of {num(changed.get('rdf_rms_vs_gromacs'), 3)} "
                f"against GROMACS's run")
    if own.get("rdf_rms_vs_gromacs") is not None:
        sentence += f" (vimd's own run of GROMACS's interactions against it: {num(own['rdf_rms_vs_gromacs'], 3)})"
    errors = [v["diffusion_error"] for v in (changed, reference)]
    sentence += (f"; D = {num(changed['diffusion'], 3)} ± {num(errors[0], 2)} cm²/s against "
                 f"{num(reference['diffusion'], 3)} ± {num(errors[1], 2)} cm²/s")
    if None not in errors and any(errors):
        sigma = abs(changed["diffusion"] - reference["diffusion"]) / (errors[0] ** 2 + errors[1] ** 2) ** 0.5
        sentence += f", a difference of **{num(sigma, 2)} combined standard errors**"
    return sentence + ".\n"


def price_section(price):
    if "skipped" in price:
        return f"Not measured: {price['skipped']}.\n"
    res = price["results"]
    switched, gromacs, own = (res.get(k, {}) for k in (SWITCHED_RATTLE.key, GMX_VARIANTS[0].key, RATTLE.key))
    kept = price.get("kept_from")
    text = [f"Kept from `{kept['command']}` on {kept['date']} (git {kept['git']}): this invocation did not run section "
            "4, whose GROMACS run it compares with.\n" if kept else "",
            f"`inputs/{price['system']}` ({price['atoms']} atoms): RATTLE with {price['note']} (smoothness "
            f"C{price['smoothness']}), dt = {fs(price['dt'])} fs, {price['ps']:g} ps with the long runs' frames, "
            f"held by a v-rescale thermostat (tau_t = {price['tau_t']:g} ps) at the GROMACS run's mean temperature, "
            f"{price['temperature']:g} K (in NVE from the same start the switched box settles at another "
            "temperature, which would move D by itself), set against the long runs' (section 4) unswitched reaction field: GROMACS's run (the reference) and "
            "vimd's own RATTLE run (which separates the switch from the engine). Analyses and D's standard error as in "
            "section 5.\n",
            "![O-O RDF, switched and unswitched](smooth_rdf_oo.png)\n", "![MSD, switched and unswitched](smooth_msd.png)\n",
            structure_sentence("Switching LJ and the reaction field", switched, gromacs, own),
            table(STRUCTURE_HEADER, structure_rows(res))]
    return "\n".join(t for t in text if t)


def pme_price_section(price):
    res = price["results"]
    smooth, gromacs, own = (res.get(k, {}) for k in (SMOOTH_PME_RATTLE.key, GMX_VARIANTS[0].key,
                                                     STANDARD_PME_RATTLE.key))
    text = [f"`inputs/{price['system']}` ({price['atoms']} atoms), {price['ps']:g} ps NVE from its `conf.gro`, "
            f"dt = {fs(price['dt'])} fs, frames every {price['frame_ps']:g} ps: RATTLE on the smooth level "
            f"{price['level']} ({price['smooth_note']}) against {GMX_VARIANTS[0].label} on {price['standard_note']} "
            "(the reference), and vimd's RATTLE on the same standard PME (which separates the settings from the "
            "engine). The integrator does not change the physics sampled (the Hamiltonian does), so RATTLE stands "
            "for the variational integrators run at these settings. Analyses and D's standard error as in "
            "section 5.\n",
            "![O-O RDF, smooth and standard PME](pme_rdf_oo.png)\n", "![MSD, smooth and standard PME](pme_msd.png)\n",
            structure_sentence(f"Smooth PME ({price['level']})", smooth, gromacs, own),
            table(STRUCTURE_HEADER, structure_rows(res))]
    return "\n".join(text)


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


SECTION_NUMBERS = {"scan": "1-2", "order": "3", "long": "4-5", "smooth": "6", "pme": "7", "polymer": "8"}


def kept_sections_text(meta):
    """Where the sections this invocation did not rerun come from (`--sections` keeps the others)."""
    kept = meta.get("kept") or []
    if not kept:
        return ""
    rows = [[f"{SECTION_NUMBERS[k]} ({k})", code(p["command"]), p["date"], p["git"], p["vimd_state"]]
            for k in kept for p in [meta["provenance"][k]]]
    return ("**Sections kept from earlier invocations** (this one ran only "
            + ", ".join(f"{n} ({k})" for k, n in SECTION_NUMBERS.items() if k in meta["provenance"] and k not in kept)
            + "; the others' data and figures are those of the invocation named here):\n\n"
            + table(["sections", "command", "date", "git", "vimd binary"], rows))


def kept_or_fresh(name, meta, render, data):
    """A section's text; a section kept from an earlier invocation whose data this code cannot read (an older
    format) is named instead of failing the whole report."""
    if name not in (meta.get("kept") or []):
        return render(data)
    try:
        return render(data)
    except (KeyError, TypeError, IndexError) as e:
        p = meta["provenance"][name]
        return (f"Not shown: the data kept from `{p['command']}` ({p['date']}, git {p['git']}) is in an older format "
                f"than this report reads ({type(e).__name__} {e}); rerun the section with `--sections {name}`.\n")


def write(path, plan, meta, scan, order, long, md, smooth, pme, polymer):
    quick_banner = ("> **Quick mode** (`--quick`): a smoke test with runs far too short for conclusions; the "
                    "committed full report is `validation/report/README.md`.\n\n" if plan.quick else "")
    text = [
        "# vimd validation study: RATTLE vs variational integrators, with MDAnalysis and GROMACS\n",
        quick_banner,
        f"Regenerated by `{meta['command']}` on {meta['date']} from git {meta['git']}; vimd binary "
        f"`{meta['vimd']}` ({meta['vimd_state']}); {meta['threads']} OpenMP thread(s) per run"
        + (f" ({(smooth or pme or polymer)['threads']} in sections 6-8)" if smooth or pme or polymer else "")
        + ". The runs took "
        f"{meta['run_minutes']:.1f} min of wall time"
        + (" when they ran (this invocation reused them: `--reuse`, same configs and binary)" if meta["reuse"]
           else f", the whole study {meta['minutes']:.1f} min")
        + f"; load average {meta['load_before']} before, {meta['load_after']} after (the 2-core machine is "
        "shared, so wall times are noisy).\n",
        kept_sections_text(meta),
        "Every number comes from the run whose command is in its table row. Config files (`.toml` for vimd, "
        "`.mdp` for GROMACS) are kept next to this report in `configs/` and name their inputs by relative path; "
        f"run outputs go to `{meta['runs']}` (not in the repository). Derived quantities are computed from those "
        "outputs by the Python package `validation/study` (the function is named where it matters).\n",
        "## Contents\n",
        "0. [Set-up and definitions](#set-up-and-definitions)\n1. [Energy drift and fluctuation vs time step]"
        "(#1-energy-drift-and-fluctuation-vs-time-step)\n2. [Work-precision](#2-work-precision)\n3. [Order study]"
        "(#3-order-study)\n4. [Long runs](#4-long-runs)\n5. [MDAnalysis analyses](#5-mdanalysis-analyses)\n"
        "6. [Smooth interactions](#6-smooth-interactions)\n7. [PME water](#7-pme-water)\n"
        "8. [Real polymers](#8-real-polymers)\n9. [Closing note](#closing-note)\n",
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
        *[kept_or_fresh("scan", meta, scan_section, s) for s in scan.values()],
        "## 2. Work-precision\n",
        *[kept_or_fresh("scan", meta, work_precision_section, s) for s in scan.values()],
        "## 3. Order study\n",
        kept_or_fresh("order", meta, order_section, order) if order else "Not run.\n",
        "## 4. Long runs\n",
        kept_or_fresh("long", meta, long_section, long) if long else "Not run.\n",
        "## 5. MDAnalysis analyses\n",
        kept_or_fresh("long", meta, lambda m: mdanalysis_section(m, long), md) if md else "Not run.\n",
        "## 6. Smooth interactions\n",
        kept_or_fresh("smooth", meta, smooth_section, smooth) if smooth else "Not run.\n",
        "## 7. PME water\n",
        kept_or_fresh("pme", meta, pme_section, pme) if pme else "Not run.\n",
        "## 8. Real polymers\n",
        kept_or_fresh("polymer", meta, polymer_section, polymer) if polymer else "Not run.\n",
        "## Closing note\n",
        closing_note(scan, meta["closing_dts"]),
    ]
    path.write_text("\n".join(t for t in text if t))
