"""Trajectory analyses with MDAnalysis (Universe(confout.gro, traj.trr), no hand-written readers):
O-O radial distribution function, constraint-length deviations, mean-square displacement with the
diffusion coefficient, temperature from the velocities. MDAnalysis works in Angstrom; everything
returned here is in nm, ps, K."""
import warnings

import numpy as np

warnings.filterwarnings("ignore", category=DeprecationWarning)
import MDAnalysis as mda  # noqa: E402
from MDAnalysis.analysis.msd import EinsteinMSD  # noqa: E402
from MDAnalysis.analysis.rdf import InterRDF  # noqa: E402
from MDAnalysis.coordinates.memory import MemoryReader  # noqa: E402
from MDAnalysis.lib.distances import calc_bonds  # noqa: E402

BOLTZMANN = 0.0083144626  # kJ/mol/K
# oplsaa.ff/spce.itp: masses of opls_116 / opls_117 and the [ settles ] distances.
SPCE_MASSES = {"OW": 15.9994, "HW1": 1.008, "HW2": 1.008}
SPCE_CONSTRAINTS = (("OW", "HW1", 0.1), ("OW", "HW2", 0.1), ("HW1", "HW2", 0.16330))


def water_universe(structure, trajectory):
    u = mda.Universe(str(structure), str(trajectory))
    u.atoms.masses = [SPCE_MASSES[name] for name in u.atoms.names]
    return u


def frame_times(u):
    return np.array([ts.time for ts in u.trajectory])


def rdf_oo(u, nbins=200):
    """g_OO(r) over all frames up to just below half the box; returns (r nm, g, peak r, peak g)."""
    oxygens = u.select_atoms("name OW")
    rmax = min(12.0, 0.5 * float(u.dimensions[:3].min()) - 0.05)  # Angstrom
    rdf = InterRDF(oxygens, oxygens, nbins=nbins, range=(0.0, rmax), exclusion_block=(1, 1)).run()
    r, g = rdf.results.bins / 10.0, rdf.results.rdf
    k = int(np.argmax(np.where(r < 0.35, g, -np.inf)))
    # parabola through the highest bin and its neighbours: the peak to better than a bin width
    denom = g[k - 1] - 2 * g[k] + g[k + 1]
    shift = 0.5 * (g[k - 1] - g[k + 1]) / denom if denom else 0.0
    width = r[1] - r[0]
    return r, g, float(r[k] + shift * width), float(g[k] - 0.25 * (g[k - 1] - g[k + 1]) * shift)


def constraint_deviations(u):
    """Relative deviations (|r_ij| - d)/d of every SETTLE distance in every frame. MDAnalysis keeps
    coordinates in single precision, so |deviation| below ~1e-6 is rounding of the reader, not the
    engine's constraint error (the engines' own double-precision residual is in their energy output)."""
    groups = {name: u.select_atoms(f"name {name}") for name in SPCE_MASSES}
    out = []
    for ts in u.trajectory:
        for a, b, d in SPCE_CONSTRAINTS:
            lengths = calc_bonds(groups[a].positions, groups[b].positions, box=ts.dimensions) / 10.0
            out.append((lengths - d) / d)
    return np.concatenate(out)


def float32_resolution(u):
    """Relative resolution of a single-precision bond length in this box: half an ulp of the
    largest coordinate, on both atoms, over the shortest constraint."""
    largest = float(u.dimensions[:3].max()) / 10.0
    return float(np.spacing(np.float32(largest))) * 2 ** 0.5 / min(d for *_, d in SPCE_CONSTRAINTS)


def unwrapped_oxygens(u):
    """Oxygen trajectories made continuous across the periodic box (each frame-to-frame step taken
    by minimum image), as an in-memory Universe for MDAnalysis's MSD."""
    oxygens = u.select_atoms("name OW")
    frames, boxes = [], []
    for ts in u.trajectory:
        frames.append(oxygens.positions.astype(np.float64))
        boxes.append(ts.dimensions[:3].astype(np.float64))
    frames, boxes = np.array(frames), np.array(boxes)
    steps = np.diff(frames, axis=0)
    steps -= boxes[1:, None, :] * np.round(steps / boxes[1:, None, :])
    unwrapped = np.concatenate([frames[:1], frames[:1] + np.cumsum(steps, axis=0)])
    merged = mda.Merge(oxygens)
    times = frame_times(u)
    merged.load_new(unwrapped, format=MemoryReader, dt=float(times[1] - times[0]) if len(times) > 1 else 1.0)
    return merged


def _einstein(merged, times, fit_window, start=None, stop=None):
    """MSD (nm^2) against lag (ps) over frames start:stop and D (cm^2/s) fitted between fit_window[0]
    and fit_window[1] of that stretch's length (None with fewer than two lags in the window)."""
    msd = EinsteinMSD(merged, select="all", msd_type="xyz", fft=False).run(start=start, stop=stop)
    span = times[start:stop]
    lags = span[: len(msd.results.timeseries)] - span[0]
    values = msd.results.timeseries / 100.0
    length = lags[-1]
    mask = (lags >= fit_window[0] * length) & (lags <= fit_window[1] * length)
    if mask.sum() < 2:
        return lags, values, None, None
    slope = np.polyfit(lags[mask], values[mask], 1)[0]
    return lags, values, float(slope / 6.0 * 1e-2), (float(lags[mask][0]), float(lags[mask][-1]))


DIFFUSION_BLOCKS = 4  # consecutive blocks of a trajectory for the error of D


def msd_diffusion(u, fit_window=(0.1, 0.5), blocks=DIFFUSION_BLOCKS):
    """O mean-square displacement (nm^2) against lag time (ps) and the diffusion coefficient from the
    Einstein relation D = slope / 6, the slope fitted over lag times between fit_window[0] and
    fit_window[1] of the trajectory length; its error is the standard error of D over `blocks`
    consecutive blocks of the trajectory, each fitted the same way. Returns (lags, msd, D in cm^2/s,
    fit range in ps, error of D in cm^2/s or None)."""
    merged = unwrapped_oxygens(u)
    times = frame_times(u)
    lags, values, diffusion, window = _einstein(merged, times, fit_window)
    edges = np.linspace(0, len(times), blocks + 1).astype(int)
    per_block = [_einstein(merged, times, fit_window, a, b)[2] for a, b in zip(edges, edges[1:]) if b - a >= 3]
    error = (float(np.std(per_block, ddof=1) / np.sqrt(len(per_block)))
             if len(per_block) >= 2 and None not in per_block else None)
    return lags, values, diffusion, window, error


def temperature(u, constraints_per_molecule=3):
    """Kinetic temperature of every frame from the trajectory's velocities, with
    3N - (constraints) - 3 degrees of freedom (centre-of-mass motion removed)."""
    masses = u.atoms.masses
    molecules = len(u.atoms.residues)
    dof = 3 * len(u.atoms) - constraints_per_molecule * molecules - 3
    values = []
    for ts in u.trajectory:
        v = u.atoms.velocities / 10.0  # nm/ps
        values.append(float(np.sum(masses[:, None] * v * v) / (dof * BOLTZMANN)))
    return frame_times(u), np.array(values), dof
