"""The report's figures (matplotlib, PNG). Each function takes results already computed and writes
one file; styles (colour, line, marker) come from the integrator variants in plan.py."""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter  # noqa: E402
from matplotlib.transforms import blended_transform_factory  # noqa: E402

from . import plan  # noqa: E402

STYLES = {v.key: v for v in plan.order_variants(list(plan.TABLEAU_ORDERS), list(plan.COMPOSITION_ORDERS))
          + plan.SCAN_VARIANTS + plan.GMX_VARIANTS
          + [plan.SWITCHED_RATTLE, plan.SMOOTH_PME_RATTLE, plan.STANDARD_PME_RATTLE]}
DPI = 110


def _style(key):
    v = STYLES[key]
    return dict(color=v.color, linestyle=v.linestyle, marker=v.marker)


def _save(fig, path):
    fig.tight_layout()
    fig.savefig(path, dpi=DPI)
    plt.close(fig)


def _log_axes(ax, x=True, y=True):
    """Log scales where there is data to scale; an empty panel says so instead of failing."""
    lim = ax.dataLim
    if not (np.all(np.isfinite(lim.get_points())) and (lim.x0 > 0 or not x) and (lim.y0 > 0 or not y)):
        ax.text(0.5, 0.5, "no data", ha="center", va="center", transform=ax.transAxes, color="0.4")
        return
    if x:
        ax.set_xscale("log")
    if y:
        ax.set_yscale("log")


def _step_ticks(ax, dts_fs):
    """Tick marks at the time steps used, labelled plainly (2, not 2x10^0)."""
    if ax.get_xscale() == "log" and dts_fs:
        ax.xaxis.set_major_locator(FixedLocator(sorted(set(dts_fs))))
        ax.xaxis.set_major_formatter(FuncFormatter(lambda x, _: f"{x:g}"))
        ax.xaxis.set_minor_formatter(NullFormatter())


def _legend(ax, **kw):
    if ax.get_legend_handles_labels()[0]:
        ax.legend(**kw)


def _completed(runs):
    return [r for r in runs if "stats" in r]


def _against_dt(ax, key, runs, metric, label):
    """One integrator's runs: abs(metric) against the time step; unstable runs crossed in red, failed
    runs as red crosses on the top edge, the largest stable step ringed."""
    top = blended_transform_factory(ax.transData, ax.transAxes)
    done = _completed(runs)
    st = _style(key)
    if done:
        ax.plot([r["dt"] / plan.FS for r in done], [abs(r["stats"][metric]) for r in done], label=label,
                markersize=5, **st)
        ok = [r for r in done if r["status"] == "ok"]
        if ok:
            best = max(ok, key=lambda r: r["dt"])
            ax.plot(best["dt"] / plan.FS, abs(best["stats"][metric]), "o", markersize=13, mfc="none",
                    mec=st["color"], mew=1.5)
        for r in done:
            if r["status"] == "unstable":
                ax.plot(r["dt"] / plan.FS, abs(r["stats"][metric]), "x", color="red", markersize=10, mew=2)
    for r in runs:
        if r["status"] == "failed":
            ax.plot(r["dt"] / plan.FS, 0.97, "x", color="red", markersize=9, mew=2, transform=top)
            ax.plot(r["dt"] / plan.FS, 0.97, st["marker"], color=st["color"], markersize=4, transform=top)


def scan(system, series, path):
    """|drift| and RMS fluctuation against the time step, one line per integrator; unstable runs
    crossed in red, failed runs as red crosses on the top edge, the largest stable step ringed."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    metrics = [("drift_per_atom", "|energy drift| (kJ/mol/ps per atom)"),
               ("rms_fluctuation", "RMS energy fluctuation (kJ/mol)")]
    for ax, (metric, ylabel) in zip(axes, metrics):
        for key, runs in series.items():
            _against_dt(ax, key, runs, metric, runs[0]["label"])
        _log_axes(ax)
        _step_ticks(ax, [r["dt"] / plan.FS for runs in series.values() for r in runs])
        ax.set_xlabel("time step (fs)")
        ax.set_ylabel(ylabel)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_title(f"{system}: energy drift")
    axes[1].set_title(f"{system}: energy fluctuation (about the linear fit)")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(6, max(1, len(labels))), fontsize=8,
               bbox_to_anchor=(0.5, 0.04))
    fig.text(0.5, 0.005, "ringed: largest stable step;  red x: unstable (energy excursion) or, on the top edge, "
             "the run stopped with an error", ha="center", fontsize=8)
    fig.tight_layout(rect=(0, 0.17, 1, 1))
    fig.savefig(path, dpi=DPI)
    plt.close(fig)


def work_precision(system, series, path):
    """Energy error against cost, log-log, stable runs only."""
    fig, axes = plt.subplots(2, 2, figsize=(12, 9))
    errors = [("rms_fluctuation", "RMS energy fluctuation (kJ/mol)"),
              ("drift_per_atom", "|drift| (kJ/mol/ps per atom)")]
    costs = [("wall_per_ps", "wall time per simulated ps (s)"),
             ("evaluations_per_ps", "force-evaluation equivalents per ps")]
    for i, (err, elabel) in enumerate(errors):
        for j, (cost, clabel) in enumerate(costs):
            ax = axes[i, j]
            for key, runs in series.items():
                ok = sorted((r for r in runs if r["status"] == "ok"), key=lambda r: r["dt"])
                if not ok:
                    continue
                ax.plot([r["cost"][cost] for r in ok], [abs(r["stats"][err]) for r in ok], label=ok[0]["label"],
                        markersize=5, **_style(key))
                # each curve's smallest step labelled, so the direction along it is readable
                ax.annotate(f"{plan.fs(ok[0]['dt'])} fs", (ok[0]["cost"][cost], abs(ok[0]["stats"][err])),
                            fontsize=6, xytext=(3, 3), textcoords="offset points", color=_style(key)["color"])
            _log_axes(ax)
            ax.set_xlabel(clabel)
            ax.set_ylabel(elabel)
            ax.grid(True, which="both", alpha=0.3)
    axes[0, 0].set_title(f"{system}: error vs wall time")
    axes[0, 1].set_title(f"{system}: error vs force + HVP evaluations")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(6, max(1, len(labels))), fontsize=8)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    fig.savefig(path, dpi=DPI)
    plt.close(fig)


def _smooth_panels(levels, height=5):
    fig, axes = plt.subplots(1, len(levels), figsize=(6 * len(levels), height), squeeze=False)
    return fig, dict(zip(levels, axes[0]))


def _finish_smooth_panel(ax, smoothness, xlabel, step_ticks=None):
    _log_axes(ax)
    if step_ticks:
        _step_ticks(ax, step_ticks)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("RMS energy fluctuation (kJ/mol)")
    # section 6's levels are smoothness numbers; section 7's are named ("p8 C4": B-spline order, smoothness)
    ax.set_title(f"switch smoothness C{smoothness}" if isinstance(smoothness, int) else smoothness)
    ax.grid(True, which="both", alpha=0.3)
    _legend(ax, fontsize=7)


def smooth_rms(levels, floor, path):
    """Section 6: RMS fluctuation against the step, one panel per switch smoothness, each integrator
    with its fitted slope (the fit drawn dotted over the steps it used)."""
    fig, panels = _smooth_panels(levels)
    for k, ax in panels.items():
        level = levels[k]
        for key, runs in level["series"].items():
            fit = level["fits"][key]
            slope = f"{fit['slope']:.2f}" if fit["slope"] is not None else "n/a"
            _against_dt(ax, key, runs, "rms_fluctuation", f"{runs[0]['label']} (slope {slope})")
            if fit["slope"] is not None:
                used = [r for r in runs if r["dt"] in fit["fit_dts"] and "stats" in r]
                x = np.array([r["dt"] for r in used])
                y0 = np.exp(np.mean(np.log([r["stats"]["rms_fluctuation"] for r in used]) -
                                    fit["slope"] * np.log(x)))
                ax.plot(x / plan.FS, y0 * x ** fit["slope"], color="0.3", linestyle=":", linewidth=1)
        ax.axhline(10 * floor, color="0.6", linewidth=0.8, linestyle="--")
        ax.text(0.02, 10 * floor, " fits use points above this", fontsize=7, color="0.4", va="bottom",
                transform=blended_transform_factory(ax.transAxes, ax.transData))
        _finish_smooth_panel(ax, k, "time step (fs)",
                             [r["dt"] / plan.FS for runs in level["series"].values() for r in runs])
    _save(fig, path)


def smooth_work_precision(levels, path):
    """Section 6: RMS fluctuation against wall time per ps, one panel per smoothness, with RATTLE's
    fitted power law (dashed) where its cost is extrapolated for the crossover."""
    fig, panels = _smooth_panels(levels)
    for k, ax in panels.items():
        level = levels[k]
        errors = []
        for key, runs in level["series"].items():
            ok = sorted((r for r in runs if r["status"] == "ok"), key=lambda r: r["dt"])
            if not ok:
                continue
            errors += [r["stats"]["rms_fluctuation"] for r in ok]
            ax.plot([r["cost"]["wall_per_ps"] for r in ok], [r["stats"]["rms_fluctuation"] for r in ok],
                    label=ok[0]["label"], markersize=5, **_style(key))
            ax.annotate(f"{plan.fs(ok[0]['dt'])} fs", (ok[0]["cost"]["wall_per_ps"], ok[0]["stats"]["rms_fluctuation"]),
                        fontsize=6, xytext=(3, 3), textcoords="offset points", color=_style(key)["color"])
        if level["rattle_fit"] and errors and min(errors) > 0:
            a, k_fit = level["rattle_fit"]
            e = np.logspace(np.log10(min(errors)), np.log10(max(errors)), 50)
            ax.plot(a * e ** -k_fit, e, color="black", linestyle="--", linewidth=0.8,
                    label=f"RATTLE's fit: cost ∝ error^-{k_fit:.2f}")
        _finish_smooth_panel(ax, k, "wall time per simulated ps (s)")
    _save(fig, path)


def order(rows, reference_error, path):
    """Global position error at the final time against the step, in three panels."""
    groups = [("RATTLE, SHAKE, GROMACS and projected RK", lambda k: not k.startswith("vi-")),
              ("vi, bias [0,1]", lambda k: k.startswith("vi-") and k.endswith("b01")),
              ("vi, bias [-1/2,1/2]", lambda k: k.startswith("vi-") and k.endswith("bsym"))]
    fig, axes = plt.subplots(1, 3, figsize=(15, 5), sharey=True)
    for ax, (title, member) in zip(axes, groups):
        for row in rows:
            if not member(row["variant"]):
                continue
            pts = [(dt, e) for dt, e in zip(row["dts"], row["errors"]) if e is not None and e > 0]
            if not pts:
                continue
            slope = f"{row['slope']:.2f}" if row["slope"] is not None else "n/a"
            ax.plot([p[0] / plan.FS for p in pts], [p[1] for p in pts], label=f"{row['label']} (slope {slope})",
                    markersize=5, **_style(row["variant"]))
        if reference_error:
            ax.axhline(reference_error, color="0.5", linewidth=0.8, linestyle=":")
            ax.text(0.02, reference_error, " reference's own error", fontsize=7, color="0.4", va="bottom",
                    transform=blended_transform_factory(ax.transAxes, ax.transData))
        _log_axes(ax)
        _step_ticks(ax, [dt / plan.FS for row in rows for dt in row["dts"]])
        ax.set_xlabel("time step (fs)")
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
        _legend(ax, fontsize=7)
    axes[0].set_ylabel("max |x(T) - x_ref(T)| over atoms (nm)")
    _save(fig, path)


def long_runs(series, path, window_ps=1.0):
    """E(t) - E(0) of the long runs: raw (top) and a running mean over window_ps (bottom)."""
    fig, axes = plt.subplots(2, 1, figsize=(11, 8), sharex=True)
    extents = {}
    for key, (label, t, e) in series.items():
        de = e - e[0]
        axes[0].plot(t, de, label=label, linewidth=0.6, color=_style(key)["color"])
        n = max(1, int(round(window_ps / (t[1] - t[0])))) if len(t) > 1 else 1
        if len(de) >= n:
            smooth = np.convolve(de, np.ones(n) / n, mode="valid")
            axes[1].plot(t[n - 1:], smooth, label=label, linewidth=1.5, color=_style(key)["color"],
                         linestyle=_style(key)["linestyle"])
            extents[label] = float(np.max(np.abs(smooth)))
    # Zoom the lower panel onto the bounded runs when one run's drift dwarfs them.
    ranked = sorted(extents.items(), key=lambda kv: kv[1], reverse=True)
    zoom = ""
    if len(ranked) >= 2 and ranked[1][1] > 0 and ranked[0][1] > 10 * ranked[1][1]:
        limit = 1.5 * ranked[1][1]
        axes[1].set_ylim(-limit, limit)
        zoom = f" (zoomed; {ranked[0][0]} leaves the range)"
    axes[0].set_ylabel("E_total(t) - E_total(0) (kJ/mol)")
    axes[1].set_ylabel(f"running mean over {window_ps:g} ps (kJ/mol)")
    axes[1].set_title(f"Running mean over {window_ps:g} ps{zoom}", fontsize=10)
    axes[1].set_xlabel("time (ps)")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        _legend(ax, fontsize=8)
    axes[0].set_title("Long NVE runs: total energy")
    _save(fig, path)


def rdf(curves, reference_key, path):
    fig, axes = plt.subplots(2, 1, figsize=(9, 7), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    ref = curves.get(reference_key)
    for key, (label, r, g) in curves.items():
        axes[0].plot(r, g, label=label, color=_style(key)["color"], linestyle=_style(key)["linestyle"])
        if ref is not None and key != reference_key and len(g) == len(ref[2]):
            axes[1].plot(r, g - ref[2], color=_style(key)["color"], linestyle=_style(key)["linestyle"])
    axes[0].set_ylabel("g_OO(r)")
    axes[0].set_title("O-O radial distribution function (MDAnalysis InterRDF)")
    _legend(axes[0], fontsize=8)
    axes[1].set_ylabel("minus GROMACS")
    axes[1].set_xlabel("r (nm)")
    for ax in axes:
        ax.grid(True, alpha=0.3)
    _save(fig, path)


def constraints(deviations, resolution, rms_series, path):
    fig, axes = plt.subplots(1, 2, figsize=(13, 5))
    bins = np.logspace(-10, -3, 71)
    for key, (label, dev) in deviations.items():
        axes[0].hist(np.maximum(np.abs(dev), 1.01e-10), bins=bins, histtype="step", label=label, linewidth=1.4,
                     color=_style(key)["color"], linestyle=_style(key)["linestyle"])
    if resolution:
        axes[0].axvline(resolution, color="0.4", linestyle=":")
        axes[0].text(resolution, 0.95, " single-precision\n resolution", transform=blended_transform_factory(
            axes[0].transData, axes[0].transAxes), fontsize=7, va="top")
    _log_axes(axes[0], y=False)
    axes[0].set_xlabel("|r_ij - d| / d of every SETTLE distance in every frame (MDAnalysis)")
    axes[0].set_ylabel("count")
    axes[0].set_title("Constraint-length deviations from the trajectories")
    _legend(axes[0], fontsize=8, loc="upper left")
    for key, (label, t, rms) in rms_series.items():
        axes[1].plot(t, np.maximum(rms, 1e-18), label=label, color=_style(key)["color"], linewidth=0.8)
    _log_axes(axes[1], x=False)
    axes[1].set_xlabel("time (ps)")
    axes[1].set_ylabel("constraint_rms from energy.csv (double precision)")
    axes[1].set_title("The engine's own constraint residual")
    _legend(axes[1], fontsize=8)
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    _save(fig, path)


def msd(curves, path):
    fig, ax = plt.subplots(figsize=(9, 6))
    for key, (label, lags, values, d, window) in curves.items():
        st = _style(key)
        text = f"{label}: D = {d:.3g} cm²/s" if d is not None else f"{label}: D n/a"
        ax.plot(lags, values, label=text, color=st["color"], linestyle=st["linestyle"])
        if d is not None:
            span = np.linspace(window[0], window[1], 20)
            mask = (lags >= window[0]) & (lags <= window[1])
            intercept = np.mean(values[mask] - 6 * d * 1e2 * lags[mask])
            ax.plot(span, intercept + 6 * d * 1e2 * span, color="k", linewidth=0.8, linestyle=":")
    ax.set_xlabel("lag time (ps)")
    ax.set_ylabel("O mean-square displacement (nm²)")
    ax.set_title("MSD of the oxygens (MDAnalysis EinsteinMSD); dotted: Einstein fits")
    ax.grid(True, alpha=0.3)
    _legend(ax, fontsize=8)
    _save(fig, path)


def temperature(curves, path):
    fig, ax = plt.subplots(figsize=(10, 5))
    for key, (label, t, temp, t_engine, temp_engine) in curves.items():
        st = _style(key)
        ax.plot(t, temp, label=f"{label} (MDAnalysis, from velocities)", color=st["color"], marker=".",
                linestyle="none", markersize=4)
        if t_engine is not None:
            ax.plot(t_engine, temp_engine, color=st["color"], linewidth=0.5, alpha=0.6,
                    label=f"{label} (engine's energy output)")
    ax.set_xlabel("time (ps)")
    ax.set_ylabel("temperature (K)")
    ax.set_title("Kinetic temperature")
    ax.grid(True, alpha=0.3)
    _legend(ax, fontsize=7, ncol=2)
    _save(fig, path)
