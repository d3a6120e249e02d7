# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The node's parameters: names, types, ranges and descriptions in one table."""

from dataclasses import fields

import numpy as np

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rcl_interfaces.msg import ParameterType as T

from ..core.fabric import FABRIC_RANGES, Fabric
from ..core.simulation import SOLVERS, STRETCH_LIMITS, SimParams
from ..recording.writer import COMPRESSIONS

# Parameters that map onto SimParams; the rest are the node's own or read at start.
SIM_KEYS = ('sim_rate', 'max_steps_per_input', 'gravity', 'wind', 'wind_gust',
            'wind_gust_period', 'stretch_limit', 'solver', 'substeps', 'quality_tolerance',
            'reset_gap', 'teleport_distance', 'teleport_angle_deg')

# name: (type, default, (lo, hi) or None, read_only, description)
NODE_PARAMETERS = {
    'robot_description': (T.PARAMETER_STRING, '', None, True,
                          'URDF text of the character; empty: the latched /robot_description '
                          'topic, else the character shipped in config/'),
    'robot_description_timeout': (T.PARAMETER_DOUBLE, 1.0, (0.0, 60.0), True,
                                  's to wait for /robot_description before using the shipped '
                                  'character'),
    'rig_file': (T.PARAMETER_STRING, '', None, True, 'rig YAML; empty: config/jacket_rig.yaml'),
    'fabric_file': (T.PARAMETER_STRING, '', None, True, 'fabric presets YAML; empty: shipped'),
    'fabric': (T.PARAMETER_STRING, 'tweed_jacket', None, True,
               'fabric preset (M16); its values seed the fabric.* parameters'),
    'sim_rate': (T.PARAMETER_DOUBLE, 120.0, (30.0, 1000.0), False,
                 'fixed simulation rate in Hz (M7), whatever the input rate'),
    'max_steps_per_input': (T.PARAMETER_INTEGER, 12, (1, 100), False,
                            'cap on steps per JointState so a hitch cannot snowball'),
    'gravity': (T.PARAMETER_DOUBLE, 9.81, (0.0, 50.0), False, 'm/s^2 along -z of the world'),
    'wind': (T.PARAMETER_DOUBLE_ARRAY, [0.0, 0.0, 0.0], None, False,
             'wind acceleration [x, y, z] in m/s^2 in the world frame (M4)'),
    'wind_gust': (T.PARAMETER_DOUBLE, 0.0, (0.0, 1.0), False,
                  'relative amplitude of the wind varying over time (0: steady)'),
    'wind_gust_period': (T.PARAMETER_DOUBLE, 3.0, (0.1, 600.0), False,
                         's, period of the slowest gust'),
    'stretch_limit': (T.PARAMETER_STRING, 'hard_pass', None, False,
                      'what removes vertical stretch: hard_pass (M12, exact rest lengths), '
                      'tethers (long-range attachments) or none'),
    'solver': (T.PARAMETER_STRING, 'gauss_seidel', None, False,
               'constraint solver: gauss_seidel (the article, stiffness per sweep) or xpbd '
               '(compliance, the same softness at any rate and iteration count)'),
    'substeps': (T.PARAMETER_INTEGER, 1, (1, 64), False,
                 'equal substeps per simulation step; with quality_tolerance, the most used'),
    'quality_tolerance': (T.PARAMETER_DOUBLE, 0.0, (0.0, 0.5), False,
                          'm; > 0: automatic quality mode, fewer sweeps and substeps when the '
                          'motion is calm; 0: fabric.iterations and substeps every step'),
    'reset_gap': (T.PARAMETER_DOUBLE, 1.0, (0.05, 60.0), False,
                  'a gap between stamps longer than this (s) resets the cloth'),
    'teleport_distance': (T.PARAMETER_DOUBLE, 1.0, (0.01, 1000.0), False,
                          'world move between two inputs (m) treated as a teleport: reset'),
    'teleport_angle_deg': (T.PARAMETER_DOUBLE, 90.0, (1.0, 180.0), False,
                           'world turn between two inputs (deg) treated as a jump: reset'),
    'world_joint': (T.PARAMETER_STRING, 'world_joint', None, False,
                    'name of the floating virtual joint whose <name>/trans_x..rot_w variables '
                    'in the JointState carry the character pose in the world'),
    'frame_prefix': (T.PARAMETER_STRING, '', None, False, 'prepended to every bone frame id'),
    'markers_rate': (T.PARAMETER_DOUBLE, 30.0, (0.0, 240.0), False,
                     'Hz of ~/markers (by message stamps); 0 turns markers off'),
    'diagnostics_rate': (T.PARAMETER_DOUBLE, 1.0, (0.1, 50.0), False, 'Hz of /diagnostics'),
    'record': (T.PARAMETER_STRING, '', None, False,
               'MCAP path to record the session to; empty: no recording'),
    'record_compression': (T.PARAMETER_STRING, 'lz4', None, False,
                           'MCAP chunk compression of the next recording: lz4 (fast, the '
                           'default), zstd (files about 0.7x the size) or none'),
}


def descriptor(name, kind, rng, read_only, text):
    d = ParameterDescriptor(name=name, type=kind, description=text, read_only=read_only)
    if rng is not None and kind == T.PARAMETER_DOUBLE:
        d.floating_point_range = [FloatingPointRange(from_value=float(rng[0]),
                                                     to_value=float(rng[1]))]
    elif rng is not None and kind == T.PARAMETER_INTEGER:
        d.integer_range = [IntegerRange(from_value=int(rng[0]), to_value=int(rng[1]), step=1)]
    return d


def fabric_parameters(fabric):
    """``fabric.<field>`` parameters, seeded from a preset; all of them change live."""
    out = {}
    for f in fields(Fabric):
        lo, hi = FABRIC_RANGES[f.name]
        kind = T.PARAMETER_INTEGER if f.name == 'iterations' else T.PARAMETER_DOUBLE
        value = getattr(fabric, f.name)
        out['fabric.' + f.name] = (kind, int(value) if kind == T.PARAMETER_INTEGER
                                   else float(value), (lo, hi), False, f'fabric: {f.name}')
    return out


def default_values(fabric):
    """Every parameter's default, with ``fabric.*`` seeded from the preset ``fabric``."""
    values = {name: spec[1] for name, spec in NODE_PARAMETERS.items()}
    values.update({name: spec[1] for name, spec in fabric_parameters(fabric).items()})
    return values


def check_value(name, value):
    """Why ``value`` is not valid for parameter ``name`` (beyond type and range), or ''."""
    if name == 'wind':
        v = list(value) if hasattr(value, '__len__') and not isinstance(value, str) else None
        if (v is None or len(v) != 3 or any(isinstance(e, bool) for e in v)
                or not all(isinstance(e, (int, float)) for e in v) or not np.isfinite(v).all()):
            return 'wind must be 3 finite numbers [x, y, z]'
    if name == 'stretch_limit' and value not in STRETCH_LIMITS:
        return f'stretch_limit must be one of {", ".join(STRETCH_LIMITS)}'
    if name == 'solver' and value not in SOLVERS:
        return f'solver must be one of {", ".join(SOLVERS)}'
    if name == 'record_compression' and value not in COMPRESSIONS:
        return f'record_compression must be one of {", ".join(COMPRESSIONS)}'
    if name == 'frame_prefix' and value.startswith('/'):
        return 'frame ids must not start with "/"'
    if name == 'world_joint' and not value:
        return 'world_joint is empty'
    return ''


def sim_params_from(values):
    sim = {k: values[k] for k in SIM_KEYS}
    sim['wind'] = tuple(float(w) for w in sim['wind'])
    return SimParams(**sim)


def fabric_from(preset, values):
    """The preset with every ``fabric.<field>`` value applied."""
    return preset.with_values(**{f: values['fabric.' + f] for f in preset.__dataclass_fields__})


def parse_override(text, known):
    """``name:=value`` (as ``--ros-args -p`` takes it) to (name, typed value), validated.

    ``known`` maps parameter names to their current values (their types come from there).
    """
    import yaml
    name, sep, raw = text.partition(':=')
    if not sep:
        raise ValueError(f'-p {text!r}: expected name:=value')
    if name not in known:
        raise ValueError(f'-p {name}: not a parameter (see README)')
    try:
        value = yaml.safe_load(raw) if raw else ''
    except yaml.YAMLError:
        value = raw
    current = known[name]
    if isinstance(current, bool):
        ok = isinstance(value, bool)
    elif isinstance(current, int):
        ok = isinstance(value, int) and not isinstance(value, bool)
    elif isinstance(current, float):
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
        value = float(value) if ok else value
    elif isinstance(current, str):
        value, ok = raw, True
    else:
        ok = isinstance(value, list)
        value = [float(v) for v in value] if ok and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value) else value
    if not ok:
        raise ValueError(f'-p {name}: {raw!r} is not a {type(current).__name__}')
    spec = NODE_PARAMETERS.get(name)
    rng = spec[2] if spec else FABRIC_RANGES.get(name[len('fabric.'):])
    if rng is not None and not isinstance(value, (list, str)) and not rng[0] <= value <= rng[1]:
        raise ValueError(f'-p {name}: {value} is outside [{rng[0]}, {rng[1]}]')
    reason = check_value(name, value)
    if reason:
        raise ValueError(f'-p {name}: {reason}')
    return name, value
