# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The simulation's parameters: each one's default, range and meaning, defined once here.

The node declares a ROS parameter for every field of :class:`SimParams` (ros/parameters.py
adds the node's own), the offline tools take the same ones with ``-p``, and the compiled step
reads them through ``bundles.Tuning`` (built in ``JacketSimulation._tuning``). To add one: a
field here, a field of Tuning and its value in ``_tuning``, then use it in the kernel.
"""

import math
from dataclasses import dataclass, field, fields, replace

import numpy as np

from .config import written
from .physics.cloth import Solver, StretchLimit
from .physics.step import gust_scale

# The automatic teleport distance per metre of the character's height (1 m for a person): a
# threshold in metres would reset a giant's every stride and miss a doll's teleport.
AUTO_TELEPORT_PER_HEIGHT = 0.6


def _param(default, doc, lo=None, hi=None, choices=None):
    """Make a parameter's field: its default, meaning, range (inclusive) or choices."""
    return field(default=default, metadata={'doc': doc, 'range': None if lo is None else (lo, hi),
                                            'choices': choices})


@dataclass(frozen=True)
class SimParams:
    """The simulation's parameters (all change live without a reset)."""

    sim_rate: float = _param(120.0, 'fixed simulation rate in Hz (M7), whatever the input rate',
                             10.0, 4000.0)
    max_steps_per_input: int = _param(
        12, 'cap on steps per JointState so a hitch cannot snowball', 1, 100)
    gravity: float = _param(9.81, "m/s^2 along the rig's -up (the world's -z by default)",
                            0.0, 50.0)
    wind: tuple = _param((0.0, 0.0, 0.0),
                         'wind acceleration [x, y, z] in m/s^2 in the world frame (M4)',
                         -1000.0, 1000.0)
    wind_gust: float = _param(0.0, 'relative amplitude of the wind varying over time '
                              '(0: steady)', 0.0, 1.0)
    wind_gust_period: float = _param(3.0, 's, period of the slowest gust', 0.1, 600.0)
    stretch_limit: str = _param(
        'hard_pass', 'what removes vertical stretch: hard_pass (M12, exact rest lengths), '
        'tethers (long-range attachments) or none', choices=StretchLimit)
    solver: str = _param(
        'gauss_seidel', 'constraint solver: gauss_seidel (the article, stiffness per sweep) or '
        'xpbd (compliance, the same softness at any rate and iteration count)', choices=Solver)
    substeps: int = _param(1, 'equal substeps per simulation step; with quality_tolerance, the '
                           'most used; with M12 a step that overstretches a row runs again in '
                           'twice as many', 1, 64)
    quality_tolerance: float = _param(
        0.0, 'm; > 0: automatic quality mode, fewer sweeps and substeps when the motion is '
        'calm; 0: fabric.iterations and substeps every step', 0.0, 0.5)
    reset_gap: float = _param(1.0, 'a gap between stamps longer than this (s) resets the cloth',
                              0.05, 60.0)
    teleport_distance: float = _param(
        0.0, 'world move between two inputs (m) treated as a teleport: reset; 0: '
        f'{AUTO_TELEPORT_PER_HEIGHT:g} times the character\'s height', 0.0, 1000.0)
    teleport_angle_deg: float = _param(
        90.0, 'world turn between two inputs (deg) treated as a jump: reset', 1.0, 180.0)

    lod_distances: tuple = _param(
        (10.0, 30.0), 'm, level of detail by the viewer\'s distance [near, far]: beyond near '
        'half the sweeps, beyond far only the bone layer and the hood (no viewer: full detail)',
        0.0, 10000.0)
    lod_blend_s: float = _param(0.5, 's over which a change to or from the far level blends',
                                0.01, 5.0)

    def __post_init__(self) -> None:
        for name, value in list(self.__dict__.items()):
            reason = check_sim_value(name, value)
            if reason:
                raise ValueError(f'{name} {reason}')
            kind = SIM_FIELDS[name].type          # 2.0 for an int field is kept as 2
            if kind is tuple:
                value = tuple(float(v) for v in value)
            elif kind in (int, float):
                value = kind(value)
            object.__setattr__(self, name, value)

    def with_values(self, **changes: object) -> 'SimParams':
        """Return a copy with ``changes`` (validated).

        :param changes: new values by field name.
        """
        return replace(self, **changes)

    def wind_at(self, t_ns: int) -> np.ndarray:
        """Wind at a step's time: the set vector, varied by two slow incommensurate gusts.

        A function of the step's stamp only, so a replay sees exactly the live wind.

        :param t_ns: the step's stamp, ns.
        :returns: the wind, (3,) m/s in the world frame.
        """
        return np.asarray(self.wind, dtype=float) * gust_scale(
            int(t_ns), float(self.wind_gust), float(self.wind_gust_period))

    @property
    def stretch_limit_mode(self) -> StretchLimit:
        return StretchLimit.parse(self.stretch_limit, 'stretch_limit')

    @property
    def solver_mode(self) -> Solver:
        return Solver.parse(self.solver, 'solver')


SIM_FIELDS = {f.name: f for f in fields(SimParams)}


def check_sim_value(name: str, value: object) -> str:
    """Why ``value`` is not valid for SimParams field ``name``, or ''.

    :param name: a SimParams field.
    :param value: the value asked for.
    """
    meta = SIM_FIELDS[name].metadata
    if meta['choices'] is not None:
        return '' if str(value).upper() in meta['choices'].__members__ else (
            f'must be one of {", ".join(meta["choices"].names())}, not {written(value)}')
    default = SIM_FIELDS[name].default
    if isinstance(default, tuple):
        try:
            v = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            return f'must be {len(default)} numbers'
        if v.shape != (len(default),) or not np.isfinite(v).all():
            return f'must be {len(default)} finite numbers'
        values = v.tolist()
    elif isinstance(value, bool) or not isinstance(value, (int, float)):
        return f'must be a number, not {written(value)}'
    elif isinstance(default, int) and not float(value).is_integer():
        return f'must be a whole number, not {written(value)}'
    elif not math.isfinite(value):
        return f'must be finite, not {written(value)}'
    else:
        values = [value]
    lo, hi = meta['range']
    if any(not lo <= v <= hi for v in values):
        return f'{written(value)} is outside [{lo}, {hi}]'
    return ''
