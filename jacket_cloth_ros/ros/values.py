# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""One character's parameter values, held once: :class:`NodeValues`.

The node's own parameters (ros/parameters.py's NODE_PARAMETERS: names, defaults, ranges and
descriptions) as typed fields, the simulation's as one :class:`SimParams` and the fabric's
(``fabric.*``) as one :class:`Fabric`. The bundle is immutable and checked when made, with the
messages the parameter checks give (``check_value``); a change makes a new one
(:meth:`NodeValues.with_changes`), which the character's pipeline takes whole
(``SessionPipeline.apply``): its simulation runs on the bundle's SimParams and Fabric objects
themselves. Where values are keyed by name (rclpy's parameters, a characters file, ``-p``, the
recording's ``parameters_json``) they are converted at that boundary
(:meth:`NodeValues.with_changes`, :meth:`NodeValues.by_name`).
"""

from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace

from ..core.fabric import Fabric
from ..core.params import SIM_FIELDS, SimParams
from .parameters import NODE_PARAMETERS, RCLPY_REL_TOL, value_and_reason

_FABRIC_FIELDS = tuple(f.name for f in fields(Fabric))


def _default(name):
    """Return a node parameter's default: NODE_PARAMETERS is where it is written."""
    return NODE_PARAMETERS[name][1]


@dataclass(frozen=True, kw_only=True)
class NodeValues:
    """Every parameter value of one character, typed; each field is the parameter it names.

    The fields' meanings, ranges and defaults are NODE_PARAMETERS' (the README's table);
    ``sim`` holds the simulation's parameters (``wind``, ``sim_rate``...: SimParams fields)
    and ``fabric`` the ``fabric.*`` values, the preset ``fabric_preset`` with its overrides.
    A value that the node would refuse raises ValueError with the node's reason; a number
    within rclpy's tolerance of an end of its range (``RCLPY_REL_TOL``) is taken, as the node
    takes it.
    """

    # Read at start (read-only parameters).
    robot_description: str = _default('robot_description')
    robot_description_timeout: float = _default('robot_description_timeout')
    rig_file: str = _default('rig_file')
    fabric_file: str = _default('fabric_file')
    fabric_preset: str = _default('fabric_preset')
    # Changed live.
    world_joint: str = _default('world_joint')
    frame_prefix: str = _default('frame_prefix')
    publish_world_tf: bool = _default('publish_world_tf')
    world_frame: str = _default('world_frame')
    markers_rate: float = _default('markers_rate')
    markers_debug: bool = _default('markers_debug')
    markers_body: str = _default('markers_body')
    diagnostics_rate: float = _default('diagnostics_rate')
    record: str = _default('record')
    record_compression: str = _default('record_compression')
    sim: SimParams = field(default_factory=SimParams)
    fabric: Fabric

    def __post_init__(self) -> None:
        for name in _OWN:
            value, reason = value_and_reason(name, getattr(self, name), _default(name),
                                             rel_tol=RCLPY_REL_TOL)
            if reason:
                raise ValueError(reason if reason.startswith(name) else f'{name}: {reason}')
            object.__setattr__(self, name, value)
        if not isinstance(self.sim, SimParams):
            raise ValueError(f'sim: {self.sim!r} is not a SimParams')
        if not isinstance(self.fabric, Fabric):
            raise ValueError(f'fabric: {self.fabric!r} is not a Fabric')
        typed = {}
        for name in _FABRIC_FIELDS:
            given = getattr(self.fabric, name)
            value, reason = value_and_reason('fabric.' + name, given,
                                             1 if name == 'iterations' else 1.0,
                                             rel_tol=RCLPY_REL_TOL)
            if reason:
                raise ValueError(f'fabric.{name}: {reason}')
            if type(value) is not type(given):         # 2 for a float: 2.0, as rclpy has it
                typed[name] = value
        if typed:
            object.__setattr__(self, 'fabric', replace(self.fabric, **typed))

    def with_changes(self, changes: Mapping[str, object]) -> 'NodeValues':
        """Return a copy with parameters changed by name (``wind``, ``fabric.damping``...).

        Unchanged parts stay the same objects: the simulation's SimParams or Fabric is new only
        when one of its values is given.

        :param changes: new values by parameter name, as rclpy or ``-p`` give them.
        """
        own, sim, fabric = {}, {}, {}
        for name, value in changes.items():
            if name in SIM_FIELDS:
                sim[name] = value
            elif name.startswith('fabric.') and name[len('fabric.'):] in _FABRIC_FIELDS:
                fabric[name[len('fabric.'):]] = value
            elif name in _OWN:
                own[name] = value
            else:
                raise ValueError(f'{name} is not a parameter of a character')
        if sim:
            own['sim'] = self.sim.with_values(**sim)
        if fabric:
            own['fabric'] = self.fabric.with_values(**fabric)
        return replace(self, **own) if own else self

    def by_name(self) -> dict[str, object]:
        """Return every parameter's value by name, arrays as lists: as the node records them.

        The recording's ``parameters_json`` is this, so a replay reads what the node ran.
        """
        out = {}
        for name in NODE_PARAMETERS:        # in VALUE_NAMES' order
            value = getattr(self.sim if name in SIM_FIELDS else self, name)
            out[name] = list(value) if isinstance(value, tuple) else value
        out.update(('fabric.' + name, getattr(self.fabric, name)) for name in _FABRIC_FIELDS)
        return out

    def draws_body(self, has_visuals: bool) -> bool:
        """Tell whether the markers carry the body: ``markers_body``, auto without visuals.

        :param has_visuals: whether the URDF has visuals of its own (RViz's RobotModel).
        """
        if self.markers_body == 'auto':
            return not has_visuals
        return self.markers_body == 'on'


# The node's own parameters, in NODE_PARAMETERS' order (the bundle's typed fields).
_OWN = tuple(name for name in NODE_PARAMETERS if name not in SIM_FIELDS)
# Every parameter name of a character, the order the node declares them.
VALUE_NAMES = tuple(NODE_PARAMETERS) + tuple('fabric.' + name for name in _FABRIC_FIELDS)


def default_values(fabric: Fabric, preset: str = _default('fabric_preset')) -> NodeValues:
    """Return every parameter's default, ``fabric.*`` from the preset ``preset``.

    :param fabric: that preset's values.
    :param preset: its name (``fabric_preset``).
    """
    return NodeValues(fabric=fabric, fabric_preset=preset)
