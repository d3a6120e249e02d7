# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""References and metrics: how far a method is from the cloth model it approximates.

Two references, so that neither solver is judged by its own model only:

- ``REFERENCE`` (XPBD's model): the rig's cloth with inextensible stretch edges, compliant
  shear/bend edges (the fabric's softness as an XPBD compliance, see
  ``simulation.xpbd_compliance``), collisions (M10) and the maximum distance (M11), converged:
  XPBD in float64 with steps of 1/``REFERENCE_RATE`` s with ``REFERENCE_ITERATIONS`` sweeps
  each; running it again at half the step (Richardson) says how far it still is from converged.
- ``GS_REFERENCE`` (the article's model): Verlet and sequential Gauss-Seidel sweeps with the
  fabric's stiffness per sweep (M4, M5), run with as many sweeps and as small steps; its check
  doubles both. The article's relaxation corrects 1 - (1 - k)^n of an error in n sweeps, so its
  converged limit holds every constraint (shear and bend too) at its rest length: the fabric's
  softness belongs to its budget, not to its model.

Cheap exact references need no reference run: the hood pendulum's large-amplitude period
(``pendulum``) and a hanging chain's equilibrium, a column of the cloth straight down at its
rest length (``hanging_chain``).

Every run goes through ``JacketSimulation.process``, the node's own door, with 60 Hz
JointState of a motion clip.
"""

import math
import time
from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np

from jacket_cloth_ros.core.physics import cloth as cloth_physics
from jacket_cloth_ros.core.physics.cloth import Solver, StretchLimit
from jacket_cloth_ros.core.measures import collider_labels, depth_inside
from jacket_cloth_ros.core.bundles import (
    ClothModel, ClothState, ColliderModel, Posed, StepControl, Tuning)
from jacket_cloth_ros.core.fabric import Fabric
from jacket_cloth_ros.core.rig import Rig
from jacket_cloth_ros.core.skeleton import Skeleton
from jacket_cloth_ros.core.simulation import (
    AUTO_SWEEP_SHARE, DESIGN_RATE, JacketSimulation, SimParams, per_step,
    xpbd_compliance)
from jacket_cloth_ros.motion.clips import joint_state_content

CLIP_RATE = 60.0                 # Hz of the lab's JointState
HEM_SAMPLES = 33                 # points along the hem curve, so grids of any width compare
REFERENCE_RATE = 1920.0          # Hz: a step 16 times shorter than the default's
REFERENCE_ITERATIONS = 48

# One JointState as the lab feeds it: (stamp ns, names, positions).
Input = tuple[int, list[str], list[float]]


@dataclass(frozen=True)
class Method:
    """One point of the sweep: solver, stretch limit and budget."""

    solver: str = 'gauss_seidel'
    stretch_limit: str = 'hard_pass'
    iterations: int = 8
    substeps: int = 1
    sim_rate: float = 120.0
    tolerance: float = 0.0           # m, the automatic quality mode (0: off)

    @property
    def family(self) -> str:
        """The method without its budget: what the charts colour by."""
        name = 'GS' if self.solver == 'gauss_seidel' else 'XPBD'
        return name if self.stretch_limit == 'none' else f'{name}+{self.stretch_limit}'

    @property
    def label(self) -> str:
        """The method as the tables and charts name it."""
        auto = f' auto {self.tolerance * 1e3:g} mm' if self.tolerance else ''
        return (f'{self.family} it{self.iterations} sub{self.substeps} '
                f'{self.sim_rate:g} Hz{auto}')

    def params(self, **base: object) -> SimParams:
        """Return the simulation's parameters for this method.

        Every step a clip asks for runs, however fine the step (the reference's are).

        :param base: other SimParams fields by name.
        """
        steps = int(math.ceil(self.sim_rate / CLIP_RATE)) + 4
        return SimParams(sim_rate=self.sim_rate, stretch_limit=self.stretch_limit,
                         solver=self.solver, substeps=self.substeps,
                         quality_tolerance=self.tolerance,
                         max_steps_per_input=max(steps, 12), **base)


SHIPPED = Method()               # what the node runs with its default parameters
# The hood steps once per step, so the reference shortens the step itself, not substeps.
REFERENCE = Method('xpbd', 'none', REFERENCE_ITERATIONS, 1, REFERENCE_RATE)
GS_REFERENCE = Method('gauss_seidel', 'none', REFERENCE_ITERATIONS, 1, REFERENCE_RATE)


def clip_inputs(skeleton: Skeleton, clip: str, seconds: float,
                start_s: float = 10.0) -> list[Input]:
    """(stamp_ns, names, positions) of ``clip`` at CLIP_RATE for ``seconds``.

    :param skeleton: the character whose joints the inputs name.
    :param clip: a name of ``clips.ALL_CLIPS``.
    :param seconds: how long.
    :param start_s: the first stamp, seconds.
    """
    out = []
    for k in range(int(round(seconds * CLIP_RATE))):
        t = k / CLIP_RATE
        names, pos = joint_state_content(skeleton.joint_names, clip, t)
        out.append((int(round((start_s + t) * 1e9)), names, pos))
    return out


@dataclass
class Trace:
    """What one run did, input by input (the first input, the reset, is left out)."""

    method: Method
    hem: np.ndarray                  # (T, HEM_SAMPLES, 3) the hem curve, simulation frame
    cloth: np.ndarray                # (T, N, 3) every vertex
    hood: np.ndarray                 # (T, 3) the hood particle
    strain: dict                     # {'vertical'|'horizontal'|'shear': (T,) worst |l/L - 1|}
    strain_mean: dict                # the same, mean over the edges
    inside: np.ndarray               # (T,) deepest vertex inside a collider (m)
    kinetic: np.ndarray              # (T,) kinetic energy of the cloth, unit vertex masses
    step_ns: np.ndarray              # (T,) process() CPU time per input
    sweeps: int                      # relaxation sweeps run
    steps: int                       # simulation steps run

    @property
    def cost_ms_per_s(self) -> float:
        """Measured cost per simulated second: the median input's CPU time at the input rate."""
        return float(np.median(self.step_ns)) * 1e-6 * CLIP_RATE


def edge_classes(rig: Rig) -> dict[str, np.ndarray]:
    """Constraint indices of the simulated vertical, horizontal and shear edges.

    :param rig: the rig whose constraints are sorted.
    """
    C = rig.cols
    ra, ca = np.divmod(rig.con_a, C)
    rb, cb = np.divmod(rig.con_b, C)
    dr, dc = np.abs(rb - ra), np.abs(cb - ca)
    simulated = rig.free[rig.con_a] | rig.free[rig.con_b]
    return {'vertical': np.nonzero((dr == 1) & (dc == 0) & simulated)[0],
            'horizontal': np.nonzero((dr == 0) & (dc == 1) & simulated)[0],
            'shear': np.nonzero((dr == 1) & (dc == 1) & simulated)[0]}


def hem_curve(rig: Rig, x: np.ndarray) -> np.ndarray:
    """Return the bottom row as HEM_SAMPLES points evenly spaced in column parameter.

    :param rig: the rig (its grid's rows and columns).
    :param x: (N, 3) the cloth's vertices, simulation frame.
    """
    hem = x[(rig.rows - 1) * rig.cols:]
    u = np.linspace(0.0, rig.cols - 1, HEM_SAMPLES)
    i = np.minimum(u.astype(int), rig.cols - 2)
    w = (u - i)[:, None]
    return (1.0 - w) * hem[i] + w * hem[i + 1]


def deepest_inside(sim: JacketSimulation) -> float:
    """Return the deepest free vertex's depth inside any collider (m), as analyze reports it.

    :param sim: the simulation, after a step.
    """
    return depth_inside(sim.x, sim.rig.free, sim.collider_frames(sim.links),
                        collider_labels(sim.rig)).value


def _simulation(skeleton, rig, fabric, method):
    """Return a fresh simulation of ``method``: its sweeps on the fabric, its parameters."""
    return JacketSimulation(skeleton, rig, fabric.with_values(iterations=method.iterations),
                            method.params())


def run(skeleton: Skeleton, rig: Rig, fabric: Fabric, method: Method,
        inputs: Sequence[Input]) -> Trace:
    """Feed ``inputs`` to a fresh simulation with ``method``; the Trace of what it did.

    :param skeleton: the character.
    :param rig: its rig.
    :param fabric: the fabric preset; its sweeps are the method's.
    :param method: solver, stretch limit and budget.
    :param inputs: the JointStates fed, the first a reset.
    """
    sim = _simulation(skeleton, rig, fabric, method)
    edges = edge_classes(rig)
    hem, cloth, hood, inside, kinetic, step_ns = [], [], [], [], [], []
    strain = {k: [] for k in edges}
    strain_mean = {k: [] for k in edges}
    sweeps = steps = 0
    for k, (stamp, names, pos) in enumerate(inputs):
        t0 = time.thread_time_ns()        # CPU time: what the shared computer pays
        report = sim.process(stamp, names, pos)
        spent = time.thread_time_ns() - t0
        if k == 0:
            continue
        step_ns.append(spent)
        sweeps += report.sweeps
        steps += report.steps
        x = sim.x
        hem.append(hem_curve(rig, x))
        cloth.append(x.copy())
        hood.append(sim.hood_p.copy())
        length = np.linalg.norm(x[rig.con_a] - x[rig.con_b], axis=1)
        s = np.abs(length / rig.con_rest - 1.0)
        for name, idx in edges.items():
            strain[name].append(s[idx].max())
            strain_mean[name].append(s[idx].mean())
        inside.append(deepest_inside(sim))
        # A step run again in twice the substeps counts them too (step.RETRIED).
        runs = report.steps + 2 * report.retried_steps
        h = sim.dt_ns * 1e-9 / max(report.substeps // max(runs, 1), 1)
        v = (x - sim.xp)[rig.free] / h     # xp is the last substep's
        kinetic.append(0.5 * float((v * v).sum()))
    return Trace(method, np.array(hem), np.array(cloth), np.array(hood),
                 {k: np.array(v) for k, v in strain.items()},
                 {k: np.array(v) for k, v in strain_mean.items()}, np.array(inside),
                 np.array(kinetic), np.array(step_ns), sweeps, steps)


def timed_cost(skeleton: Skeleton, rig: Rig, fabric: Fabric, method: Method,
               inputs: Sequence[Input]) -> float:
    """Return a run's cost as :attr:`Trace.cost_ms_per_s` measures it, and nothing else.

    The same runs as :func:`run` (the same simulation and inputs, so the same work) without
    the figures taken between inputs, for timing a method again.

    :param skeleton: the character.
    :param rig: its rig.
    :param fabric: the fabric preset; its sweeps are the method's.
    :param method: solver, stretch limit and budget.
    :param inputs: the JointStates fed, the first a reset.
    :returns: the median input's CPU time at the input rate, ms per simulated second.
    """
    sim = _simulation(skeleton, rig, fabric, method)
    step_ns = []
    for k, (stamp, names, pos) in enumerate(inputs):
        t0 = time.thread_time_ns()
        sim.process(stamp, names, pos)
        if k:
            step_ns.append(time.thread_time_ns() - t0)
    return float(np.median(step_ns)) * 1e-6 * CLIP_RATE


def finer(method: Method) -> Method:
    """Return the run that checks a reference: half the step (Gauss-Seidel: twice the sweeps too).

    Gauss-Seidel's stiffness is per sweep, so its converged model is reached by more sweeps as
    well as by smaller steps; XPBD's compliance makes the sweeps only a solver budget.

    :param method: the reference's method.
    """
    sweeps = 2 if method.solver == 'gauss_seidel' else 1
    return replace(method, sim_rate=method.sim_rate * 2, iterations=method.iterations * sweeps)


def reference(skeleton: Skeleton, rig: Rig, fabric: Fabric, inputs: Sequence[Input],
              method: Method = REFERENCE, keep_check: bool = False) -> tuple:
    """Run the converged reference; return (trace, Richardson figures) with its error estimate.

    The estimate compares the reference with its ``finer`` run (Richardson).

    :param skeleton: the character.
    :param rig: its rig.
    :param fabric: the fabric preset.
    :param inputs: the JointStates fed, the first a reset.
    :param method: the reference's method.
    :param keep_check: whether the finer run's trace is returned too, third.
    """
    ref = run(skeleton, rig, fabric, method, inputs)
    check = run(skeleton, rig, fabric, finer(method), inputs)
    return (ref, compare(ref, check)) + ((check,) if keep_check else ())


def convergence(skeleton: Skeleton, rig: Rig, fabric: Fabric, inputs: Sequence[Input],
                method: Method, sweeps: Sequence[int] = (6, 12, 24, 48),
                rates: Sequence[float] = (240.0, 480.0, 960.0, 1920.0),
                best: Trace | None = None) -> dict:
    """Error of ``method`` against its ``finer`` run, sweeps then rates varied.

    What shows a reference converged: the error flattening as either grows.

    :param skeleton: the character.
    :param rig: its rig.
    :param fabric: the fabric preset.
    :param inputs: the JointStates fed, the first a reset.
    :param method: the method whose sweeps and rate are varied.
    :param sweeps: the sweeps per step tried, at the method's rate.
    :param rates: the simulation rates tried (Hz), at the method's sweeps.
    :param best: the run compared against; None: the finer run, run here.
    """
    if best is None:
        best = run(skeleton, rig, fabric, finer(method), inputs)
    out = {'against': finer(method).label, 'sweeps': [], 'rates': []}
    for it in sweeps:
        row = compare(run(skeleton, rig, fabric, replace(method, iterations=it), inputs), best)
        out['sweeps'].append({'iterations': it, **row})
    for rate in rates:
        row = compare(run(skeleton, rig, fabric, replace(method, sim_rate=rate), inputs), best)
        out['rates'].append({'sim_rate': rate, **row})
    return out


def compare(trace: Trace, ref: Trace) -> dict[str, float]:
    """Position error of ``trace`` against ``ref`` (m): hem, hood and every vertex, RMS and max.

    :param trace: the run measured.
    :param ref: the run it is measured against.
    """
    hem = np.linalg.norm(trace.hem - ref.hem, axis=2)
    hood = np.linalg.norm(trace.hood - ref.hood, axis=1)
    out = {'hem_rms_m': float(np.sqrt((hem ** 2).mean())), 'hem_max_m': float(hem.max()),
           'hood_rms_m': float(np.sqrt((hood ** 2).mean())), 'hood_max_m': float(hood.max())}
    if trace.cloth.shape == ref.cloth.shape:       # grids of other sizes compare by the hem
        cloth = np.linalg.norm(trace.cloth - ref.cloth, axis=2)
        out.update(cloth_rms_m=float(np.sqrt((cloth ** 2).mean())),
                   cloth_max_m=float(cloth.max()))
    return out


def metrics(trace: Trace, ref: Trace, gs_ref: Trace | None = None) -> dict:
    """Every figure of one run against the reference, for tables.

    :param trace: the run.
    :param ref: the reference it is measured against.
    :param gs_ref: the article's reference; its errors go under ``vs_gs``.
    """
    out = {'method': trace.method.family, 'label': trace.method.label,
           'solver': trace.method.solver, 'stretch_limit': trace.method.stretch_limit,
           'iterations': trace.method.iterations, 'substeps': trace.method.substeps,
           'sim_rate': trace.method.sim_rate, 'tolerance_m': trace.method.tolerance,
           'cost_ms_per_s': trace.cost_ms_per_s,
           'sweeps_per_step': trace.sweeps / max(trace.steps, 1)}
    out.update(compare(trace, ref))
    if gs_ref is not None:
        out['vs_gs'] = compare(trace, gs_ref)
    for name in trace.strain:
        out[f'{name}_strain_max'] = float(trace.strain[name].max())
        out[f'{name}_strain_mean'] = float(trace.strain_mean[name].mean())
    out['inside_max_m'] = float(trace.inside.max())
    # Numerical damping shows as kinetic energy lost against the model: < 1 is too damped.
    out['energy_ratio'] = float(trace.kinetic.mean() / max(ref.kinetic.mean(), 1e-12))
    return out


# -- exact references -----------------------------------------------------------------------------

def elliptic_k(k: float) -> float:
    """Complete elliptic integral of the first kind K(k), by the arithmetic-geometric mean.

    :param k: the modulus, 0 <= k < 1.
    """
    a, b = 1.0, math.sqrt(1.0 - k * k)
    while abs(a - b) > 1e-15 * a:
        a, b = (a + b) / 2.0, math.sqrt(a * b)
    return math.pi / (2.0 * a)


def pendulum_period_exact(length: float, gravity: float, theta0: float) -> float:
    """T = 4 sqrt(L/g) K(sin(theta0 / 2)): the large-amplitude pendulum.

    :param length: the rod, metres.
    :param gravity: m/s^2.
    :param theta0: the amplitude, radians.
    """
    return 4.0 * math.sqrt(length / gravity) * elliptic_k(math.sin(theta0 / 2.0))


def pendulum(skeleton: Skeleton, rig: Rig, fabric: Fabric, sim_rate: float, theta0_deg: float,
             periods: int = 4) -> dict[str, float]:
    """Release the M8 hood from ``theta0_deg`` with no damping, the skeleton still.

    Verlet with a projection onto the rod loses energy each step (first order in the step), so
    the amplitude falls from cycle to cycle; each cycle's period is compared with the exact
    period at that cycle's own amplitude, which separates the phase error from that loss.

    :param skeleton: the character.
    :param rig: its rig (its hood).
    :param fabric: the fabric preset; its hood damping is set to 0.
    :param sim_rate: the simulation rate, Hz.
    :param theta0_deg: the release angle from the vertical, degrees.
    :param periods: how many exact periods to run.
    :returns: the first cycle's figures and the amplitude lost per cycle.
    """
    sim = JacketSimulation(skeleton, rig, fabric.with_values(hood_damping=0.0),
                           SimParams(sim_rate=sim_rate))
    links = sim.links
    anchor, _ = sim.hood_anchor(links)
    L, g = rig.hood.length, sim.params.gravity
    th = math.radians(theta0_deg)
    sim.hood_p = anchor + L * np.array([math.sin(th), 0.0, -math.cos(th)])
    sim.hood_pp = sim.hood_p.copy()
    dt = sim.dt_ns * 1e-9
    n = int(math.ceil(periods * pendulum_period_exact(L, g, th) / dt)) + 2
    angle, rod = np.empty(n + 1), np.empty(n + 1)
    angle[0], rod[0] = th, L
    for k in range(1, n + 1):
        sim.hood_step(links, np.array([0.0, 0.0, -g]), dt, 0.0)
        d = sim.hood_p - anchor
        angle[k], rod[k] = math.atan2(d[0], -d[2]), np.linalg.norm(d)
    # Crossings of the vertical in the same direction, linearly interpolated, bound the cycles.
    k = np.nonzero((angle[:-1] > 0.0) & (angle[1:] <= 0.0))[0]
    crossings = (k + angle[k] / (angle[k] - angle[k + 1])) * dt
    amplitude = np.array([np.abs(angle[a:b + 1]).max() for a, b in zip(k[:-1], k[1:])])
    periods_s = np.diff(crossings)
    exact = np.array([pendulum_period_exact(L, g, a) for a in amplitude])
    loss = 1.0 - (amplitude[-1] / th) ** (1.0 / (len(amplitude) + 0.5))
    return {'theta0_deg': theta0_deg, 'sim_rate': sim_rate, 'period_s': float(periods_s[0]),
            'exact_s': float(exact[0]), 'amplitude_deg': float(np.degrees(amplitude[0])),
            'period_error': float(periods_s[0] / exact[0] - 1.0),
            'amplitude_loss_per_cycle': float(loss), 'rod_error_m': float(np.abs(rod - L).max())}


def hanging_chain(fabric: Fabric, method: Method, rows: int = 12, spacing: float = 0.06,
                  seconds: float = 4.0, gravity: float = 9.81) -> dict:
    """Release a column of the cloth, pinned at the top, from horizontal through the kernel.

    Its exact equilibrium hangs straight down at its rest length.

    :param fabric: the fabric preset (stiffness, damping, sweeps).
    :param method: solver, stretch limit, rate and substeps.
    :param rows: the column's vertices.
    :param spacing: their rest distance, metres.
    :param seconds: how long to run.
    :param gravity: m/s^2.
    :returns: the stretch of the whole column and of its worst link at the end, how far the
        bottom is from the exact equilibrium, and the settling time (the bottom stays within
        1 cm of it from then on).
    """
    n = rows
    x = np.zeros((n, 3))
    x[:, 0] = np.arange(n) * spacing
    xp = x.copy()
    free = np.ones(n, dtype=np.bool_)
    free[0] = False
    ca = np.concatenate([np.arange(n - 1), np.arange(n - 2)])       # stretch, then bend
    cb = np.concatenate([np.arange(1, n), np.arange(2, n)])
    rest = np.concatenate([np.full(n - 1, spacing), np.full(n - 2, 2 * spacing)])
    stiffness = np.concatenate([np.full(n - 1, fabric.stretch_stiffness),
                                np.full(n - 2, fabric.shear_bend_stiffness)])
    compliance = xpbd_compliance(stiffness, fabric.iterations)
    dt = 1.0 / method.sim_rate
    damping = per_step(np.full(n, fabric.damping), DESIGN_RATE / (method.sim_rate
                                                                  * method.substeps))
    acc = np.tile([0.0, 0.0, -gravity], (n, 1))
    none3 = np.zeros((0, 3))
    total = (n - 1) * spacing
    exact_bottom = np.array([0.0, 0.0, -total])
    settled_at, steps = None, int(round(seconds / dt))
    far = x.copy()                       # no M11: references anywhere, bound of a kilometre
    ints = np.zeros(0, dtype=np.int64)
    cloth = ClothModel(0, x[:1].copy(), ints, none3, ints, none3, np.zeros(0), free, ca, cb,
                       rest, np.arange(n - 1), np.arange(1, n), np.full(n - 1, spacing),
                       ints, ints, np.zeros(0), ints, np.zeros(0),
                       np.zeros(n, dtype=np.int64), np.arange(n) * spacing, 0, np.zeros(3), 0.0,
                       np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0]))
    colliders = ColliderModel(ints, none3, np.zeros((0, 3, 3)), none3, ints,
                              np.zeros((0, 2, 3)), np.zeros(0), ints, none3, none3)
    tuning = Tuning(stiffness, method.iterations, compliance, np.full(n, 1e3),
                    int(StretchLimit.parse(method.stretch_limit, 'stretch_limit')), -1.0,
                    int(Solver.parse(method.solver, 'solver')),
                    method.substeps, 0.0, method.tolerance * AUTO_SWEEP_SHARE, np.zeros(n), 0.0,
                    0.0, 1.0, np.zeros(n), 0.0, np.zeros(n), 0.0, gravity, np.zeros(3), 0.0, 1.0)
    state = ClothState(x, xp, np.zeros(n, dtype=np.bool_), np.zeros(3), np.zeros(3), np.eye(4),
                       np.zeros(len(ca)), np.ones(1, dtype=np.bool_))
    control = StepControl(acc, damping, 0.0, dt, method.substeps, x.copy())  # top never moves
    posed = Posed(none3, np.zeros((0, 3, 3)), none3, none3, none3, none3, far)
    for k in range(steps):
        cloth_physics.cloth_step(cloth, colliders, tuning, state, control, posed, posed)
        off = np.linalg.norm(x[-1] - exact_bottom)
        if off > 0.01:
            settled_at = None
        elif settled_at is None:
            settled_at = (k + 1) * dt
    links = np.linalg.norm(np.diff(x, axis=0), axis=1)
    return {'method': method.label, 'stretch': float(np.linalg.norm(x[-1] - x[0]) / total - 1),
            'worst_link_strain': float(np.abs(links / spacing - 1).max()),
            'bottom_error_m': float(np.linalg.norm(x[-1] - exact_bottom)),
            'settle_s': settled_at}
