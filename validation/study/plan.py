"""What the study runs: systems, force fields, integrator variants, time steps and run lengths for
the full study and for --quick. Everything that decides a number in the report is set here."""
import dataclasses
import pathlib
import tomllib

from gmx_common import ROOT

FS = 0.001  # ps


@dataclasses.dataclass(frozen=True)
class System:
    name: str
    forcefield: dict       # the vimd [forcefield] table (nm); GROMACS gets the same settings
    note: str              # what the force field is and why
    system_keys: dict = dataclasses.field(default_factory=dict)  # [system] keys besides the files

    @property
    def directory(self):
        return ROOT / "inputs" / self.name

    @property
    def structure(self):
        return self.directory / "conf.gro"

    @property
    def topology(self):
        return self.directory / "topol.top"

    @property
    def atoms(self):
        return int(self.structure.read_text().splitlines()[1])


def own_forcefield(name):
    """The [forcefield] table of an input's own run file."""
    with open(ROOT / "inputs" / name / "run.toml", "rb") as f:
        return tomllib.load(f)["forcefield"]


# Smooth water: LJ switched to zero between 0.7 and 0.9 nm (C2 potential) and the inputs' own
# reaction field with epsilon_rf = infinity, whose force also vanishes at the cut-off (with
# epsilon_rf = 78 the Coulomb force jumps by ~1.3 % there and the energy error would measure the
# cut-off, not the integrator).
SMOOTH_WATER = dict(cutoff=0.9, vdw_modifier="potential-switch", vdw_switch=0.7,
                    coulomb="reaction-field", epsilon_rf=0.0)
SMOOTH_NOTE = ("LJ potential-switch 0.7-0.9 nm, reaction field eps_rf = infinity (the inputs' own RF "
               "setting; force continuous at the 0.9 nm cut-off)")


def water(name, skin):
    return System(name, SMOOTH_WATER | {"neighbor_skin": skin}, SMOOTH_NOTE + f", neighbour skin {skin} nm")


def switched(system, smoothness):
    """A water system of the study with the reaction field switched to zero over the same 0.7-0.9 nm
    as LJ, and both switches smooth to `smoothness` continuous derivatives of the pair potential at
    both ends (2 = GROMACS's quintic potential-switch)."""
    ff = system.forcefield | {"coulomb_modifier": "potential-switch", "coulomb_switch": system.forcefield["vdw_switch"],
                              "switch_smoothness": smoothness}
    note = (f"LJ and reaction field (eps_rf = infinity) both potential-switched {ff['vdw_switch']:g}-{ff['cutoff']:g} nm, "
            f"pair potential C{smoothness} at both ends of the switch, neighbour skin {ff['neighbor_skin']:g} nm")
    return dataclasses.replace(system, forcefield=ff, note=note)


def pme_water(system, cutoff, switch, skin, pme_order, smoothness):
    """A water system of the study with particle-mesh Ewald (ewald_rtol 1e-5, fourier_spacing 0.12 nm,
    GROMACS's defaults) at `pme_order`, its real space and LJ potential-switched from `switch` to the
    cut-off, both C^smoothness; beta then follows from erfc(beta switch) = ewald_rtol (docs/pme.md)."""
    ff = dict(cutoff=cutoff, vdw_modifier="potential-switch", vdw_switch=switch, coulomb="pme",
              coulomb_modifier="potential-switch", coulomb_switch=switch, switch_smoothness=smoothness,
              ewald_rtol=1e-5, pme_order=pme_order, fourier_spacing=0.12, neighbor_skin=skin)
    note = (f"PME (ewald_rtol 1e-5 at {switch:g} nm, fourier_spacing 0.12 nm, pme_order {pme_order}: mesh energy "
            f"C{pme_order - 2}), its real space and LJ potential-switched {switch:g}-{cutoff:g} nm, "
            f"C{smoothness} at both ends, neighbour skin {skin:g} nm")
    return dataclasses.replace(system, forcefield=ff, note=note)


def pme_standard(system, cutoff, skin):
    """A water system of the study with GROMACS's standard PME: ewald_rtol 1e-5 at the cut-off,
    fourier_spacing 0.12 nm, pme_order 4, real space and LJ potential-shifted (grompp's defaults)."""
    ff = dict(cutoff=cutoff, vdw_modifier="potential-shift", vdw_switch=0.0, coulomb="pme",
              coulomb_modifier="potential-shift", ewald_rtol=1e-5, pme_order=4, fourier_spacing=0.12,
              neighbor_skin=skin)
    note = (f"standard PME (ewald_rtol 1e-5 at {cutoff:g} nm, fourier_spacing 0.12 nm, pme_order 4), real space "
            f"and LJ potential-shifted at {cutoff:g} nm, neighbour skin {skin:g} nm")
    return dataclasses.replace(system, forcefield=ff, note=note)


def alkane_melt(constraints, smoothness):
    """The OPLS-AA n-decane melt (inputs/alkane) with `constraints` (h-bonds | all-bonds), its LJ and
    reaction field (eps_rf = infinity) both potential-switched 0.7-0.9 nm, C^smoothness at both ends."""
    ff = own_forcefield("alkane") | {"vdw_modifier": "potential-switch", "vdw_switch": 0.7,
                                     "coulomb_modifier": "potential-switch", "coulomb_switch": 0.7,
                                     "switch_smoothness": smoothness}
    note = (f"OPLS-AA (dihedrals, 1-4 pairs), constraints = {constraints}, LJ and reaction field (eps_rf = infinity) "
            f"both potential-switched 0.7-{ff['cutoff']:g} nm, C{smoothness} at both ends, neighbour skin "
            f"{ff['neighbor_skin']:g} nm")
    return System("alkane", ff, note, {"constraints": constraints})


SYSTEMS = {
    "water900": water("water900", 0.1),
    # cut-off + skin must stay below half of the 1.864 nm box (inputs/README.md)
    "water216": water("water216", 0.03),
    "polymer": System("polymer", own_forcefield("polymer"),
                      "the input's own run file: WCA (LJ cut at 2^(1/6) sigma, potential-shift, force zero at "
                      "the cut-off), no charges, rigid bonds, weak harmonic angles"),
    "cluster8": System("cluster8", own_forcefield("cluster8"),
                       "the input's own run file: every pair far inside the 1.5 nm cut-off, so LJ "
                       "(potential-shift = constant) + RF (eps_rf = infinity) is analytic along the run"),
}


@dataclasses.dataclass(frozen=True)
class Variant:
    key: str          # file-name-safe identifier
    label: str        # as shown in tables and legends
    integrator: dict  # [integrator] keys besides dt and steps
    order: int        # nominal order of accuracy
    color: str
    linestyle: str = "-"
    marker: str = "o"

    @property
    def family(self):
        return self.integrator["type"]


BIASES = {"b01": ([0.0, 1.0], "[0,1]", "-"), "bsym": ([-0.5, 0.5], "[-1/2,1/2]", "--")}
# Built-in tableaus of the engine (integrators/tableau.cpp) with their orders.
TABLEAU_ORDERS = {"euler": 1, "heun2": 2, "midpoint": 2, "rk3": 3, "rk4": 4, "rk38": 4, "rk6": 6, "rk8": 8}
TABLEAU_COLORS = {"euler": "#8c564b", "heun2": "#1f77b4", "midpoint": "#17becf", "rk3": "#bcbd22",
                  "rk4": "#2ca02c", "rk38": "#98df8a", "rk6": "#d62728", "rk8": "#e377c2"}

RATTLE = Variant("rattle", "rattle", {"type": "rattle"}, 2, "black", "-", "s")
SHAKE = Variant("shake", "shake", {"type": "shake"}, 2, "0.55", "-", "D")
# RATTLE on the switched interactions (section 6's price of smoothness), told apart from RATTLE on the
# long runs' unswitched reaction field in tables and figures.
SWITCHED_RATTLE = Variant("rattle-switched", "rattle, LJ + RF switched", {"type": "rattle"}, 2, "#d62728", "--", "s")
# RATTLE on section 7's smooth PME (its price of smoothness) and on GROMACS's standard PME.
SMOOTH_PME_RATTLE = Variant("rattle-smooth-pme", "rattle, smooth PME", {"type": "rattle"}, 2, "#d62728", "--", "s")
STANDARD_PME_RATTLE = Variant("rattle-standard-pme", "rattle, standard PME", {"type": "rattle"}, 2, "black", "-", "s")


def vi(method, bias_key):
    bias, shown, style = BIASES[bias_key]
    return Variant(f"vi-{method}-{bias_key}", f"vi {method} {shown}",
                   {"type": "vi", "method": method, "bias": bias}, TABLEAU_ORDERS[method],
                   TABLEAU_COLORS[method], style, "o" if bias_key == "b01" else "^")


def rk(method):
    return Variant(f"rk-{method}", f"rk {method} (projected)", {"type": "rk", "method": method},
                   TABLEAU_ORDERS[method], "#9467bd" if method == "rk4" else TABLEAU_COLORS[method], ":", "v")


SCAN_VARIANTS = [RATTLE, SHAKE] + [vi(m, b) for m in ("heun2", "rk4", "rk6") for b in BIASES] + [rk("rk4")]
LONG_VARIANTS = [vi("rk4", "b01"), RATTLE, rk("rk4")]


@dataclasses.dataclass(frozen=True)
class SmoothSeries:
    """One integrator of the smooth-interactions section at one switch smoothness, at these steps."""
    smoothness: int
    variant: Variant
    dts: tuple


@dataclasses.dataclass(frozen=True)
class PmeSeries:
    """One integrator of the PME-water section at one B-spline order and switch smoothness."""
    pme_order: int
    smoothness: int
    variant: Variant
    dts: tuple

    @property
    def level(self):
        return f"p{self.pme_order} C{self.smoothness}"


def _peers(dts):
    """RATTLE, then each composition that has steps in dts, with their steps (fs)."""
    return [("rattle", RATTLE)] + [(c, composed_rattle(c)) for c in COMPOSITION_ORDERS if c in dts]


@dataclasses.dataclass(frozen=True)
class PolymerSeries:
    """One integrator of the real-polymer section at one constraint set and switch smoothness."""
    constraints: str
    smoothness: int
    variant: Variant
    dts: tuple

    @property
    def level(self):
        return f"{self.constraints} C{self.smoothness}"


def polymer_series(constraints, smoothness, methods, dts):
    """RATTLE, the compositions dts names, and vi [0,1] with each method, at their steps (fs)."""
    return tuple(PolymerSeries(constraints, smoothness, v, tuple(x * FS for x in dts[key]))
                 for key, v in _peers(dts) + [(m, vi(m, "b01")) for m in methods])


def pme_series(pme_order, smoothness, methods, dts):
    """RATTLE at dts["rattle"], each composition of RATTLE that dts names at its steps, and vi [0,1]
    with each method at dts[method] (fs)."""
    return tuple(PmeSeries(pme_order, smoothness, v, tuple(x * FS for x in dts[key]))
                 for key, v in _peers(dts) + [(m, vi(m, "b01")) for m in methods])


def smooth_series(smoothness, methods, biases, dts):
    """RATTLE at dts["rattle"], each composition of RATTLE that dts names at its steps, and vi with
    each method and bias at dts[method] (a method's steps may depend on the bias: dts[(method, bias)]
    wins)."""
    out = [SmoothSeries(smoothness, v, tuple(x * FS for x in dts[key])) for key, v in _peers(dts)]
    for m in methods:
        for b in biases:
            out.append(SmoothSeries(smoothness, vi(m, b), tuple(x * FS for x in dts.get((m, b), dts[m]))))
    return tuple(out)


# RATTLE's symmetric compositions (integrators/composition.cpp) with their orders.
COMPOSITION_ORDERS = {"yoshida4": 4, "suzuki4": 4, "kahan-li6": 6, "kahan-li8": 8}
COMPOSITION_COLORS = {"yoshida4": "#7f7f7f", "suzuki4": "#bcbd22", "kahan-li6": "#17becf", "kahan-li8": "#ff7f0e"}


def composed_rattle(composition):
    return Variant(f"rattle-{composition}", f"rattle {composition}", {"type": "rattle", "composition": composition},
                   COMPOSITION_ORDERS[composition], COMPOSITION_COLORS[composition], "-.", "s")


def order_variants(tableaus, compositions=()):
    return ([RATTLE, SHAKE] + [composed_rattle(c) for c in compositions] + [vi(m, b) for m in tableaus for b in BIASES]
            + [rk(m) for m in tableaus])


@dataclasses.dataclass(frozen=True)
class GromacsVariant:
    key: str
    label: str
    integrator: str   # GROMACS integrator
    color: str
    linestyle: str
    marker: str


GMX_VARIANTS = [GromacsVariant("gmx-md-vv", "gmx_d md-vv + SETTLE", "md-vv", "#ff7f0e", "-.", "P"),
                GromacsVariant("gmx-md", "gmx_d md (leap-frog) + SETTLE", "md", "#e6a157", "-.", "X")]


@dataclasses.dataclass(frozen=True)
class Plan:
    """Everything that sets the size of the study."""
    quick: bool
    scan_systems: tuple          # systems of the time-step scan (section 1-2)
    scan_dts: dict               # system -> time steps (ps), tried in order until unstable
    scan_ps: dict                # system -> simulated time per scan run (ps) ...
    scan_max_steps: dict         # ... but at most this many steps (small steps cost the most)
    gromacs_system: str          # where the GROMACS reference points are computed
    constraint_tolerance: float
    order_system: str
    order_tableaus: tuple
    order_dts: tuple
    # RATTLE's compositions, each at its own steps (ps; each dividing order_ps): their errors fall
    # so fast that the tableaus' steps would leave the high orders at the round-off floor
    order_compositions: dict
    order_ps: float
    order_reference_dt: float
    order_tolerance: float       # solver and constraint tolerance of the order study
    # Errors below this are round-off and the solve's tolerance, not truncation: at tolerance 1e-12
    # the most accurate vi runs on cluster8 level off at 1-2e-12 nm whatever the step.
    order_error_floor: float
    long_system: str
    long_dt: float
    long_ps: float
    long_frame_ps: float         # trajectory frame interval of the long runs (MDAnalysis)
    gromacs_traj_ps: float       # length of GROMACS's trajectory for the MDAnalysis comparison
    energy_interval_ps: float    # energy sampling interval of the scans (ps; at least every step)
    smooth_system: str           # section 6: smooth interactions (LJ and RF switched to smoothness k)
    smooth_series: tuple         # SmoothSeries: (smoothness, integrator, time steps)
    smooth_ps: float             # simulated time per run
    smooth_energy_interval_ps: float   # the same for every run: a multiple of every step
    smooth_solver_tolerance: object    # vi: "auto" (section 6's tolerance study), or nm/ps
    smooth_max_iterations: int
    smooth_floor: float          # kJ/mol: RMS fluctuation of round-off and solve; slopes fit points 10x above
    smooth_threads: int          # OpenMP threads per run of section 6 (the crossover is stated at 2)
    price_smoothness: int        # the switched run set against GROMACS's unswitched long run
    # vi's solver tolerance (section 6): each (method, dt) case on the switched water at
    # price_smoothness, at each fixed tolerance, the bias's default and "auto"
    tolerance_system: str
    tolerance_cases: tuple       # (method, dt in ps)
    tolerance_values: tuple      # fixed tolerances (nm/ps), tightest last: the reference
    tolerance_ps: float
    # Section 7: PME water, the smooth-interactions comparison with PME's real space switched
    pme_system: str
    pme_cutoff: float            # nm
    pme_switch: float            # nm: where LJ and PME's real space start to be switched off
    pme_skin: float              # nm
    pme_series: tuple            # PmeSeries: (pme_order, smoothness, integrator, time steps)
    pme_ps: float
    # The price of smoothness on PME water: the level whose settings vi is recommended at (pme_order,
    # smoothness) run this long with RATTLE, against gmx_d's and vimd's standard PME runs of the box.
    pme_price_level: tuple
    pme_price_ps: float
    # Section 8 on the OPLS-AA alkane melt (inputs/alkane), at each constraint set and smoothness
    polymer_series: tuple        # PolymerSeries
    polymer_ps: float
    polymer_energy_interval_ps: float
    pme_energy_interval_ps: float
    stability_fraction: float = 0.01   # max |E(t) - E(0)| allowed, as a fraction of <E_kin>


# RATTLE's compositions in sections 6 and 7 (fs): each up to where its largest sub-step (|weight| x dt)
# passes RATTLE's own stability limit on water; a sweep stops at the first unstable step anyway.
PEER_DTS = {"yoshida4": (0.5, 1, 2), "suzuki4": (1, 2, 3), "kahan-li6": (1, 2, 3, 4), "kahan-li8": (2, 3, 4, 6)}

FULL = Plan(
    quick=False,
    scan_systems=("water900", "polymer"),
    scan_dts={"water900": tuple(x * FS for x in (0.5, 1, 2, 3, 4, 5, 6, 7, 8)),
              # the melt's own step is 10 fs (inputs/README.md); GROMACS drifts strongly at 20 fs
              "polymer": tuple(x * FS for x in (2.5, 5, 10, 15, 20, 30, 40))},
    # The variational integrators cost 5-40x RATTLE per step; these lengths keep sections 1-5 within
    # about an hour on an idle machine.
    scan_ps={"water900": 0.5, "polymer": 2.0},
    scan_max_steps={"water900": 250, "polymer": 200},
    gromacs_system="water900",
    constraint_tolerance=1e-10,
    order_system="cluster8",
    order_tableaus=tuple(TABLEAU_ORDERS),
    order_dts=tuple(x * FS for x in (0.25, 0.5, 1, 2, 4)),
    order_compositions={"yoshida4": tuple(x * FS for x in (0.25, 0.5, 1, 2)),
                        "suzuki4": tuple(x * FS for x in (0.5, 1, 2, 4)),
                        "kahan-li6": tuple(x * FS for x in (1, 2, 2.5, 4)),
                        "kahan-li8": tuple(x * FS for x in (2, 2.5, 3.125, 4, 5))},
    order_ps=0.2,
    order_reference_dt=0.05 * FS,
    order_tolerance=1e-12,
    order_error_floor=1e-12,
    long_system="water216",
    long_dt=2 * FS,
    long_ps=100.0,
    long_frame_ps=0.5,
    gromacs_traj_ps=100.0,
    energy_interval_ps=0.002,
    # Section 6 takes about an hour at 2 threads on an idle 2-core machine (AMD EPYC, measured
    # 2026-11-23). At tolerance 1e-10 a force or Hessian-vector evaluation on the switched water900
    # costs ~2.6 ms with the step's other work, and the iterations per step grow fast with dt (vi rk4
    # [0,1]: 3.4 at 1 fs, 6.3 at 2, 15 at 4, 35 at 6), so the large steps and bias [-1/2,1/2]
    # (2-3x the evaluations) cost the most. Smoothness 2 (GROMACS's switch, where the order should
    # stall): RATTLE, rk4, rk6, rk8 at [0,1], 20 min. Smoothness 4 (the slopes and the crossover):
    # RATTLE, rk4, rk6, rk8 at [0,1], and rk8 at [-1/2,1/2], the most accurate per cost in the quick
    # study, ~25 min; rk4 and rk6 at [-1/2,1/2] (another ~20 min) are left out. Smoothness 6 (does
    # the order climb further?): RATTLE, rk6 and rk8 at [0,1], ~8 min. A sweep stops at the first
    # unstable or unconverged step.
    smooth_system="water900",
    smooth_series=(
        smooth_series(4, ("rk4", "rk6", "rk8"), ("b01",),
                      {"rattle": (0.25, 0.5, 1, 2), "rk4": (1, 2, 3, 4, 6), "rk6": (1.5, 2, 3, 4), "rk8": (2, 3, 4)}
                      | PEER_DTS)
        + (SmoothSeries(4, vi("rk8", "bsym"), tuple(x * FS for x in (2, 3, 4))),)
        + smooth_series(6, ("rk6", "rk8"), ("b01",), {"rattle": (0.25, 0.5, 1, 2), "rk6": (2, 3, 4),
                                                       "rk8": (2, 3, 4)} | PEER_DTS)
        + smooth_series(2, ("rk4", "rk6", "rk8"), ("b01",), {"rattle": (0.25, 0.5, 1, 2), "rk4": (2, 3, 4, 6),
                                                              "rk6": (2, 3, 4, 6), "rk8": (3, 4, 6)})),
    smooth_ps=1.0,
    smooth_energy_interval_ps=0.012,   # a multiple of every step above
    # "auto" keeps the RMS fluctuation of a 1e-10 solve in fewer iterations (the tolerance study below);
    # 200 iterations leave room for the slowest steps
    smooth_solver_tolerance="auto",
    smooth_max_iterations=200,
    # Round-off and the solve: a quick-study run (vi rk8 [-1/2,1/2], water216, 2 fs, solved to 1e-10)
    # fluctuated by only 2e-9 kJ/mol, so they stay below that; slopes use points above 1e-8.
    smooth_floor=1e-9,
    smooth_threads=2,
    price_smoothness=4,
    # every method the study runs, at the steps where its tolerance matters
    tolerance_system="water216",
    tolerance_cases=tuple((m, x * FS) for m in ("rk4", "rk6", "rk8") for x in (2, 4)),
    tolerance_values=(1e-4, 1e-6, 1e-8, 1e-10),
    tolerance_ps=0.24,
    # Section 7 runs the smooth-interactions comparison on PME water: the mesh's order caps the
    # smoothness (its energy is C^(p-2)), so order 4 with rk4, 8 with rk4-rk8, 12 at C6 with rk6-rk8;
    # the compositions at every level, so that every crossover is against the best peer there.
    pme_system="water900",
    pme_cutoff=1.0,
    pme_switch=0.8,
    pme_skin=0.1,
    pme_series=(pme_series(4, 4, ("rk4",), {"rattle": (0.25, 0.5, 1, 2), "rk4": (1, 2, 3, 4)} | PEER_DTS)
                + pme_series(8, 4, ("rk4", "rk6", "rk8"), {"rattle": (0.25, 0.5, 1, 2), "rk4": (1, 2, 3, 4),
                                                            "rk6": (2, 3, 4), "rk8": (2, 3, 4)} | PEER_DTS)
                + pme_series(12, 6, ("rk6", "rk8"), {"rattle": (0.25, 0.5, 1, 2), "rk6": (2, 3, 4),
                                                      "rk8": (2, 3, 4)} | PEER_DTS)),
    pme_ps=1.0,
    # the study's smooth PME level recommended for vi (docs/pme.md, inputs/water900/run_vi_pme.toml); 100 ps as
    # section 4's long runs, long enough for D to within a few per cent
    pme_price_level=(8, 4),
    pme_price_ps=100.0,
    # C-H bonds rigid (the usual setting) and every bond rigid (then the fastest motion is an angle's
    # bending, and larger steps are stable); 0.5 ps per run: the melt has 3200 atoms
    polymer_series=(polymer_series("h-bonds", 4, ("rk4", "rk6", "rk8"),
                                   {"rattle": (0.25, 0.5, 1, 2), "rk4": (1, 2, 3, 4), "rk6": (1, 2, 3, 4),
                                    "rk8": (2, 3, 4)} | PEER_DTS)
                    + polymer_series("all-bonds", 4, ("rk4", "rk6", "rk8"),
                                     {"rattle": (0.5, 1, 2, 3), "rk4": (2, 3, 4, 6), "rk6": (2, 3, 4, 6),
                                      "rk8": (3, 4, 6)} | PEER_DTS)),
    polymer_ps=0.5,
    polymer_energy_interval_ps=0.012,
    pme_energy_interval_ps=0.012,
)

QUICK = Plan(
    quick=True,
    scan_systems=("water900", "polymer"),
    scan_dts={"water900": tuple(x * FS for x in (1, 2, 4)), "polymer": tuple(x * FS for x in (5, 10, 20))},
    scan_ps={"water900": 0.04, "polymer": 0.2},
    scan_max_steps={"water900": 20, "polymer": 20},
    gromacs_system="water900",
    constraint_tolerance=1e-10,
    order_system="cluster8",
    order_tableaus=("heun2", "rk4", "rk6"),
    order_dts=tuple(x * FS for x in (0.5, 1, 2)),
    order_compositions={"yoshida4": tuple(x * FS for x in (0.5, 1, 2))},
    order_ps=0.05,
    order_reference_dt=0.1 * FS,
    order_tolerance=1e-12,
    order_error_floor=1e-12,
    long_system="water216",
    long_dt=2 * FS,
    long_ps=1.0,
    long_frame_ps=0.05,
    gromacs_traj_ps=1.0,
    energy_interval_ps=0.002,
    smooth_system="water216",
    # RATTLE's steps 4x apart: its cost per ps must fall with dt although start-up dominates such short runs
    # one bias: the smoke test needs every code path of the section, not both biases' figures
    smooth_series=smooth_series(4, ("rk4", "rk8"), ("b01",), {"rattle": (0.5, 2), "rk4": (2, 4), "rk8": (2, 4),
                                                             "kahan-li6": (2, 4)}),
    smooth_ps=0.048,
    smooth_energy_interval_ps=0.004,
    smooth_solver_tolerance="auto",
    smooth_max_iterations=200,
    smooth_floor=1e-9,
    smooth_threads=2,
    price_smoothness=4,
    tolerance_system="water216",
    tolerance_cases=(("rk4", 2 * FS),),
    tolerance_values=(1e-6, 1e-10),
    tolerance_ps=0.024,
    pme_system="water216",
    pme_cutoff=0.9,   # water216's box allows at most 0.932 nm with the skin
    pme_switch=0.7,
    pme_skin=0.03,
    pme_series=pme_series(8, 4, ("rk4",), {"rattle": (0.5, 2), "rk4": (2, 4)}),
    pme_ps=0.048,
    pme_price_level=(8, 4),
    pme_price_ps=1.0,
    polymer_series=polymer_series("h-bonds", 4, ("rk4",), {"rattle": (0.5, 2), "rk4": (2, 4)}),
    polymer_ps=0.06,   # a few periods of the fastest bending: shorter runs fluctuate by their start
    polymer_energy_interval_ps=0.004,
    pme_energy_interval_ps=0.004,
)


def fs(dt):
    """A time step in fs as text: 0.5, 2, 2.5."""
    return f"{dt / FS:g}"


def relative(path):
    """A path as the report shows it: relative to the repository when inside it."""
    path = pathlib.Path(path).resolve()
    try:
        return str(path.relative_to(ROOT))
    except ValueError:
        return str(path)


def scan_length(plan, system, dt):
    """Simulated time of one scan run (ps)."""
    return min(plan.scan_ps[system], plan.scan_max_steps[system] * dt)
