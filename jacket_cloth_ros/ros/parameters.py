# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The node's parameters: names, types, ranges and descriptions in one table."""

import math
import os
import sys
from dataclasses import fields

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rcl_interfaces.msg import ParameterType as T

from ..core.config import control_character
from ..core.fabric import FABRIC_RANGES, Fabric
from ..core.params import SIM_FIELDS, check_sim_value
from ..recording.writer import Compression

# The ROS parameter type of each SimParams field's Python type.
_ROS_TYPES = {float: T.PARAMETER_DOUBLE, int: T.PARAMETER_INTEGER, str: T.PARAMETER_STRING,
              tuple: T.PARAMETER_DOUBLE_ARRAY}


def _sim_parameters():
    """Return every SimParams field as a parameter.

    The simulation's table (core.params) is the one source of their defaults, ranges and
    descriptions.
    """
    out = {}
    for name, f in SIM_FIELDS.items():
        kind = _ROS_TYPES[f.type]
        default = list(f.default) if isinstance(f.default, tuple) else f.default
        rng = f.metadata['range'] if kind != T.PARAMETER_DOUBLE_ARRAY else None
        out[name] = (kind, default, rng, False, f.metadata['doc'])
    return out


# name: (type, default, (lo, hi) or None, read_only, description)
NODE_PARAMETERS = {
    'robot_description': (T.PARAMETER_STRING, '', None, True,
                          'URDF text of the character; empty: the latched /robot_description '
                          'topic, else the character shipped in config/'),
    'robot_description_timeout': (T.PARAMETER_DOUBLE, 1.0, (0.0, 60.0), True,
                                  's (wall time) to wait for /robot_description before using '
                                  'the shipped character'),
    'rig_file': (T.PARAMETER_STRING, '', None, True, 'rig YAML; empty: config/jacket_rig.yaml'),
    'fabric_file': (T.PARAMETER_STRING, '', None, True, 'fabric presets YAML; empty: shipped'),
    'fabric_preset': (T.PARAMETER_STRING, 'tweed_jacket', None, True,
                      'fabric preset (M16); its values seed the fabric.* parameters'),
    **_sim_parameters(),
    'world_joint': (T.PARAMETER_STRING, 'world_joint', None, False,
                    'name of the floating virtual joint whose <name>/trans_x..rot_w variables '
                    'in the JointState carry the character pose in the world'),
    'frame_prefix': (T.PARAMETER_STRING, '', None, False, 'prepended to every bone frame id'),
    'publish_world_tf': (T.PARAMETER_BOOL, False, None, False,
                         'also publish world_frame -> the URDF root on /tf, from the '
                         'world_joint variables (without them, standing on the rig\'s floor), '
                         'so a world fixed frame works in a viewer'),
    'world_frame': (T.PARAMETER_STRING, 'world', None, False,
                    'the parent frame of that transform'),
    'markers_rate': (T.PARAMETER_DOUBLE, 30.0, (0.0, 240.0), False,
                     'Hz of ~/markers (by message stamps); 0 turns markers off'),
    'markers_debug': (T.PARAMETER_BOOL, False, None, False,
                      'also draw the method on ~/markers: the cloth grid, colliders, hood '
                      'pendulum and jacket bones'),
    'markers_body': (T.PARAMETER_STRING, 'auto', None, False,
                     'draw a simple body under the jacket on ~/markers: on, off, or auto (on '
                     'when the URDF has no <visual> for RViz\'s RobotModel to show)'),
    'diagnostics_rate': (T.PARAMETER_DOUBLE, 1.0, (0.1, 50.0), False,
                         'Hz of /diagnostics: by the inputs\' stamps, by wall time when none '
                         'bring them'),
    'record': (T.PARAMETER_STRING, '', None, False,
               'where to record the session: an MCAP file (.mcap), else a rosbag2 bag '
               'folder; empty: no recording'),
    'record_compression': (T.PARAMETER_STRING, 'lz4', None, False,
                           'MCAP chunk compression of the next recording: lz4 (fast, the '
                           'default), zstd (smaller files) or none'),
}


MIN_MARKERS_RATE = 0.01
# rclpy's Node.PARAM_REL_TOL: a double parameter this close to an end of its range is in it.
RCLPY_REL_TOL = 1e-6
BODY_CHOICES = ('auto', 'on', 'off')
# The longest frame_prefix, world_frame or world_joint taken.
MAX_NAME = 256
_NAMES = ('frame_prefix', 'world_frame', 'world_joint')
_TEXTS = _NAMES + ('record',)     # names and paths: no control characters

# Old names: refused with a hint, never taken for another parameter. ``fabric`` was the preset
# and also the prefix of ``fabric.*``, which ros2 param dump cannot write.
RENAMED = {'fabric': 'fabric_preset'}
# Parameters rclpy declares on every node, or on request (QoS overrides).
ROS_OWN = ('use_sim_time', 'start_type_description_service', 'start_parameter_services')
ROS_OWN_PREFIXES = ('qos_overrides.',)


# jacket_cloth_crowd's own; its characters' parameters come from its characters file.
CROWD_PARAMETERS = {
    'characters': (T.PARAMETER_STRING, '', None, True,
                   'the characters file (YAML, see config/crowd.yaml)'),
    'slice_index': (T.PARAMETER_INTEGER, 0, (0, 4095), True,
                    'which slice of the characters this process runs (0 .. slice_count-1)'),
    'slice_count': (T.PARAMETER_INTEGER, 1, (1, 4096), True,
                    'into how many processes the characters are split'),
    'threads': (T.PARAMETER_INTEGER, 0, (0, 256), True,
                'threads for the characters\' steps; 0: one per core (NUMBA_NUM_THREADS)'),
    'record': (T.PARAMETER_STRING, '', None, True,
               'record the whole crowd to this MCAP file (.mcap) or bag folder; empty: off'),
    'record_compression': (T.PARAMETER_STRING, 'lz4', None, True,
                           'MCAP chunk compression: lz4, zstd or none'),
}


def descriptor(name: str, kind: int, rng: tuple | None, read_only: bool,
               text: str) -> ParameterDescriptor:
    """Return a parameter's descriptor, its range set for a number.

    :param name: the parameter's name.
    :param kind: its ParameterType.
    :param rng: its (lowest, highest) value; None: unbounded.
    :param read_only: whether it is set only at start.
    :param text: its description.
    """
    d = ParameterDescriptor(name=name, type=kind, description=text, read_only=read_only)
    if rng is not None and kind == T.PARAMETER_DOUBLE:
        d.floating_point_range = [FloatingPointRange(from_value=float(rng[0]),
                                                     to_value=float(rng[1]))]
    elif rng is not None and kind == T.PARAMETER_INTEGER:
        d.integer_range = [IntegerRange(from_value=int(rng[0]), to_value=int(rng[1]), step=1)]
    return d


def fabric_parameters(fabric: Fabric) -> dict[str, tuple]:
    """``fabric.<field>`` parameters, seeded from a preset; all of them change live.

    :param fabric: the preset whose values are the defaults.
    """
    out = {}
    for f in fields(Fabric):
        lo, hi = FABRIC_RANGES[f.name]
        kind = T.PARAMETER_INTEGER if f.name == 'iterations' else T.PARAMETER_DOUBLE
        value = getattr(fabric, f.name)
        out['fabric.' + f.name] = (kind, int(value) if kind == T.PARAMETER_INTEGER
                                   else float(value), (lo, hi), False, f'fabric: {f.name}')
    return out


def check_value(name: str, value: object) -> str:
    """Why ``value`` is not valid for parameter ``name`` (beyond type and range), or ''.

    :param name: the parameter's name.
    :param value: its value, typed.
    """
    if name in SIM_FIELDS:
        reason = check_sim_value(name, value)
        return f'{name} {reason}' if reason else ''
    if name == 'record_compression' and str(value).upper() not in Compression.__members__:
        return f'record_compression must be one of {", ".join(Compression.names())}'
    if name == 'markers_body' and value not in BODY_CHOICES:
        return f'markers_body must be one of {", ".join(BODY_CHOICES)}'
    if name == 'markers_rate' and 0 < value < MIN_MARKERS_RATE:
        # Its period must be a number of nanoseconds: 1e-300 Hz made it infinite.
        return f'markers_rate must be 0 (off) or at least {MIN_MARKERS_RATE} Hz'
    if name in _TEXTS and control_character(value):
        # Refused, not cleaned: a name that is not what was written would be silently changed.
        return (f'{name} holds a control character ({control_character(value)}), which a '
                'log line, a terminal or a viewer shows as another name')
    if name in _NAMES and len(value) > MAX_NAME:
        # Each /tf carries the prefix once per bone: a megabyte one made each message 68 MB.
        return f'{name} is {len(value)} characters long (at most {MAX_NAME})'
    if name == 'frame_prefix' and value.startswith('/'):
        return 'frame ids must not start with "/"'
    if name in ('world_joint', 'world_frame') and not value:
        return f'{name} is empty'
    if name == 'world_frame' and value.startswith('/'):
        return 'frame ids must not start with "/"'
    return ''


def unknown_reason(name: str, known: object, node: str) -> str:
    """Why a parameter given to ``node`` is not taken: a hint for an old name, else unknown.

    :param name: the parameter given.
    :param known: the node's parameter names.
    :param node: the node's name.
    """
    if name in RENAMED:
        return f'parameter {name}: renamed {RENAMED[name]} (set {RENAMED[name]} instead)'
    if '.' in name and name.partition('.')[0] in known:
        return f'parameter {name}: {name.partition(".")[0]} is not a group of parameters'
    import difflib
    near = difflib.get_close_matches(name, sorted(known), n=1)
    hint = f'did you mean {near[0]}? ' if near else ''
    return f'parameter {name}: not a parameter of {node} ({hint}the README lists them)'


def from_recording(values: dict) -> dict:
    """Return a recording's parameter values under today's names (older files say ``fabric``).

    :param values: the recorded values, by name.
    """
    out = dict(values)
    for old, new in RENAMED.items():
        if old in out and not isinstance(out[old], dict):
            out.setdefault(new, out.pop(old))
    return out


def params_file_problem(argv: list[str]) -> str:
    """Say what is wrong with a ``--params-file`` in ``argv`` that rcl takes silently, or ''.

    A key given twice in one mapping (the second wins in rcl's reader: ``fabric: {...}`` after
    a ``fabric: name``) is refused; a file rcl cannot read is left to rcl's own message.

    :param argv: the command line with its ROS arguments.
    """
    import yaml

    class Strict(yaml.SafeLoader):
        pass

    def mapping(loader, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            key = loader.construct_object(key_node, deep=deep)
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f'{key!r} is given twice', key_node.start_mark)
            seen.add(key)
        return yaml.SafeLoader.construct_mapping(loader, node, deep)
    Strict.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, mapping)
    for path in _params_files(argv):
        try:
            with open(path, encoding='utf-8') as f:
                yaml.load(f, Loader=Strict)
        except yaml.constructor.ConstructorError as e:
            return (f'--params-file {path}, line {e.problem_mark.line + 1}: {e.problem} (rcl '
                    'would keep the last one only)')
        except (OSError, yaml.YAMLError):
            continue
    return ''


def _params_files(argv):
    """Return the paths of the ``--params-file`` arguments in ``argv``'s ROS arguments."""
    ros = argv[argv.index('--ros-args'):] if '--ros-args' in argv else []
    return [path for flag, path in zip(ros, ros[1:]) if flag == '--params-file']


def params_file_for_another_node(argv: list[str], node: str) -> str:
    """Say which ``--params-file`` in ``argv`` holds nothing for ``node`` (its full name), or ''.

    rcl applies a file's sections whose node name (wildcards ``*`` and ``**``) matches, and
    skips the rest without a word: a file written for another node set nothing.

    :param argv: the process's arguments.
    :param node: the node's full name (``/namespace/name``).
    """
    import re
    import yaml
    for path in _params_files(argv):
        try:
            with open(path, encoding='utf-8') as f:
                data = yaml.safe_load(f)
        except (OSError, yaml.YAMLError):
            continue            # rcl has said what it cannot read
        keys = [str(k) for k in data] if isinstance(data, dict) else []
        for key in keys:
            tokens = [t for t in key.split('/') if t]
            pattern = ''.join('(/[^/]+)*' if t == '**' else '/[^/]+' if t == '*' else
                              '/' + re.escape(t) for t in tokens)
            if re.fullmatch(pattern, node):
                break
        else:
            listed = ', '.join(k[:80] for k in keys[:5]) or 'none'
            return (f'--params-file {path}: no section for {node} (its node names: {listed}; '
                    '/** is every node)')
    return ''


def ros_args_problem(argv: list[str]) -> str:
    """Say which ``--ros-args`` argument rcl cannot parse (it raises a traceback), or ''.

    rcl reads a ``-p`` value as YAML: a URDF given as ``-p robot_description:=...`` often is
    no YAML, and an empty value (``-p world_joint:=``) is refused too.

    :param argv: the process's arguments.
    """
    ros = argv[argv.index('--ros-args') + 1:] if '--ros-args' in argv else []
    if not _rcl_refuses(ros):
        return ''
    for flag, value in zip(ros, ros[1:]):
        if flag in ('-p', '--param') and _rcl_refuses([flag, value]):
            name, _, given = value.partition(':=')
            if name == 'robot_description':
                return ('-p robot_description: rcl reads a -p value as YAML, and this URDF is '
                        'none: publish it on the robot_description topic (as '
                        'robot_state_publisher does) or set it in a --params-file')
            return (f'-p {name[:80]}: rcl cannot read ' +
                    ('an empty value' if not given else f'{given[:40]!r} as a YAML value') +
                    ' (quote a text value: -p \'name:="text"\')')
        if flag == '--params-file' and _rcl_refuses([flag, value]):
            reason = _rcl_refuses([flag, value]).partition('Error: ')[2].partition(', at ')[0]
            return f'--params-file {value}: rcl cannot read it ({reason or "not a params file"})'
    reason = _rcl_refuses(ros)
    reason = reason.partition('Failed to parse ROS arguments: ')[2] or reason
    return f'--ros-args: rcl cannot read them ({reason.partition(", at ")[0][:200]})'


def _rcl_refuses(args: list[str]) -> str:
    """Return rcl's error for ``--ros-args`` ``args`` on one line, or '' if it takes them.

    Its C side writes lines of its own on the process's stderr (an error string cut): they
    go to /dev/null while it tries, so the user reads one line.
    """
    from rclpy.impl.implementation_singleton import rclpy_implementation as impl
    from rclpy.utilities import remove_ros_args
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, 'w') as null:
            os.dup2(null.fileno(), 2)
        remove_ros_args(['node', '--ros-args', *args])
    except (impl.RCLInvalidROSArgsError, impl.UnknownROSArgsError) as e:
        return ' '.join(str(e).split())
    finally:
        os.dup2(saved, 2)
        os.close(saved)
    return ''


def _as_float(value):
    """Return a number, or a string that is one (YAML 1.1 reads ``1e3`` as text), as a float."""
    if isinstance(value, bool):
        return value
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    return float(value) if isinstance(value, (int, float)) else value


def parse_override(text: str, known: dict) -> tuple[str, object]:
    """``name:=value`` (as ``--ros-args -p`` takes it) to (name, typed value), validated.

    :param text: the ``name:=value`` text.
    :param known: parameter names to their current values (their types come from there).
    """
    import yaml
    name, sep, raw = text.partition(':=')
    if not sep:
        raise ValueError(f'-p {text!r}: expected name:=value')
    if name in RENAMED:
        raise ValueError(f'-p {name}: renamed {RENAMED[name]}')
    if name not in known:
        raise ValueError(f'-p {name}: not a parameter (see README)')
    try:
        value = yaml.safe_load(raw) if raw else ''
    except yaml.YAMLError:
        value = raw
    return name, typed_value(name, raw if isinstance(known[name], str) else value,
                             known[name], f'-p {name}', raw)


def typed_value(name: str, value: object, current: object, where: str,
                raw: str | None = None) -> object:
    """Return ``value`` for parameter ``name`` typed as its ``current`` value, validated.

    :param name: the parameter's name.
    :param value: the value given.
    :param current: its current value, whose type the value must have.
    :param where: what gave it, which every ValueError starts with.
    :param raw: the text the value came from, shown in errors; None: the value's repr.
    """
    value, reason = value_and_reason(name, value, current, raw)
    if reason:
        raise ValueError(f'{where}: {reason}')
    return value


def value_and_reason(name: str, value: object, current: object, raw: str | None = None,
                     rel_tol: float = 0.0) -> tuple[object, str]:
    """Return ``value`` typed as ``current``, and why it is not valid for ``name`` (or '').

    :param name: the parameter's name.
    :param value: the value given.
    :param current: a value of its type.
    :param raw: the text the value came from, shown in the reason; None: the value's repr.
    :param rel_tol: a number this close (relative) to an end of its range is in it; rclpy
        takes ``RCLPY_REL_TOL``.
    """
    shown = repr(raw) if raw is not None else repr(value)
    if isinstance(current, bool):
        ok = isinstance(value, bool)
    elif isinstance(current, int):
        ok = isinstance(value, int) and not isinstance(value, bool)
    elif isinstance(current, float):
        value = _as_float(value)
        ok = isinstance(value, float)
    elif isinstance(current, str):
        ok = isinstance(value, str)
    else:
        ok = isinstance(value, list)
        value = [_as_float(v) for v in value] if ok else value
        ok = ok and all(isinstance(v, float) for v in value)
    if not ok:
        return value, f'{shown} is not a {type(current).__name__}'
    spec = NODE_PARAMETERS.get(name)
    rng = spec[2] if spec else FABRIC_RANGES.get(name[len('fabric.'):])
    if rng is not None and not isinstance(value, (list, str)) and not rng[0] <= value <= rng[1] \
            and not (rel_tol and any(math.isclose(value, end, rel_tol=rel_tol) for end in rng)):
        return value, f'{value} is outside [{rng[0]}, {rng[1]}]'
    return value, check_value(name, value)
