# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Full ``ros2msg`` schema text for a message type, from the installed .msg files.

MCAP's ros2 profile wants the top-level definition followed, for every type it uses, by a line
of 80 '=', ``MSG: pkg/Type`` and that type's definition (the format rosbag2 writes).
"""

import functools
import os
import re
import sys

from ament_index_python.packages import get_package_share_directory

PRIMITIVES = {
    'bool', 'byte', 'char', 'float32', 'float64', 'int8', 'uint8', 'int16', 'uint16', 'int32',
    'uint32', 'int64', 'uint64', 'string', 'wstring', 'time', 'duration'}
_FIELD = re.compile(r'^\s*([A-Za-z][\w/]*)(?:<=\d+)?(?:\[[^\]]*\])?\s+\w+')


@functools.lru_cache(maxsize=None)
def message_text(type_name: str) -> str:
    """Return the .msg text of ``pkg/msg/Type`` (or ``pkg/Type``) as installed.

    :param type_name: the message type, ``pkg/msg/Type`` or ``pkg/Type``.
    """
    pkg, _, name = _split(type_name)
    path = os.path.join(_share_directory(pkg), 'msg', name + '.msg')
    with open(path, encoding='utf-8') as f:
        return f.read()


def _share_directory(pkg):
    try:
        return get_package_share_directory(pkg)
    except (OSError, LookupError):
        # PyPI-wheel environments are a ROS prefix but may not set AMENT_PREFIX_PATH.
        return os.path.join(sys.prefix, 'share', pkg)


def _split(type_name):
    parts = type_name.split('/')
    if len(parts) == 3:
        return parts[0], 'msg', parts[2]
    if len(parts) == 2:
        return parts[0], 'msg', parts[1]
    raise ValueError(f'not a message type name: {type_name!r}')


def dependencies(type_name: str) -> list[str]:
    """Return the message types a definition uses, as ``pkg/Type``.

    :param type_name: the message type, ``pkg/msg/Type`` or ``pkg/Type``.
    """
    pkg, _, _ = _split(type_name)
    out = []
    for line in message_text(type_name).splitlines():
        line = line.split('#', 1)[0]
        m = _FIELD.match(line)
        if not m or '=' in line:     # no field, or a constant
            continue
        base = m.group(1)
        if base in PRIMITIVES:
            continue
        if base == 'Header':
            base = 'std_msgs/Header'
        elif '/' not in base:
            base = f'{pkg}/{base}'
        out.append(base)
    return out


@functools.lru_cache(maxsize=None)
def ros2msg_schema(type_name: str) -> str:
    """Return the concatenated definition: top level first, then each dependency once.

    :param type_name: the top-level message type, ``pkg/msg/Type`` or ``pkg/Type``.
    """
    parts = [message_text(type_name).rstrip('\n')]
    seen, queue = set(), list(dependencies(type_name))
    while queue:
        dep = queue.pop(0)
        if dep in seen:
            continue
        seen.add(dep)
        parts.append('=' * 80 + f'\nMSG: {dep}\n' + message_text(dep).rstrip('\n'))
        queue.extend(dependencies(dep))
    return '\n'.join(parts) + '\n'
