# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A crowd's characters file: who runs in one jacket_cloth_crowd node, validated on load.

Example (``config/crowd.yaml``)::

    defaults:                    # optional: every character's, unless it sets its own
      fabric: tweed_jacket
      parameters: {markers_rate: 10.0}
    characters:
      - name: npc1               # its namespace: /npc1/joint_states, bones npc1/...
        urdf: character.urdf     # a file; none: the /npc1/robot_description topic
      - name: npc2
        urdf: examples/mannequin.urdf
        rig: examples/mannequin_rig.yaml
        parameters: {wind: [2.0, 0.0, 0.0]}
      - name: walker             # count: walker_0 .. walker_15, each its own character
        count: 16

Files are looked up beside the characters file, then in the shipped config folder. Every
error is one line naming the file and the key.
"""

import os
import re
from dataclasses import dataclass

from ..core.config import ConfigError, Section, config_dir, load_yaml, shown
from ..core.fabric import load_fabrics
from .parameters import typed_value
from .values import NodeValues, default_values

MAX_CHARACTERS = 4096
# The character's own keys: set there, not under ``parameters``; ``record`` is the crowd's.
_NOT_PARAMETERS = ('robot_description', 'rig_file', 'fabric_file', 'fabric', 'fabric_preset',
                   'frame_prefix', 'record', 'record_compression')
_NAME = re.compile(r'[A-Za-z][A-Za-z0-9_]*(/[A-Za-z][A-Za-z0-9_]*)*')
# A name is its topics' namespace: /<name>/jacket_cloth_node/markers must stay within the
# 247 characters a ROS topic name may have (rcl's 255 less 8), with room for a count's _k.
MAX_NAME = 200
_KEYS = ('urdf', 'rig', 'fabric_file', 'fabric', 'frame_prefix', 'parameters')


@dataclass
class CharacterSpec:
    """One character of a crowd, as its characters file sets it."""

    name: str                   # its namespace, without the leading '/'
    urdf: str | None            # a URDF file, or None: the robot_description topic
    rig: str | None             # a rig file, or None: the shipped rig
    fabric_file: str | None     # a fabrics file, or None: the shipped presets
    values: NodeValues          # its parameters' values, as a node's, until it is loaded

    @property
    def namespace(self) -> str:
        return '/' + self.name


def _path(value, folder, where):
    """Find a file the characters file names: beside it, else in the shipped config folder."""
    if os.path.isabs(value):
        found = value
    else:
        found = os.path.join(folder, value)
        if not os.path.exists(found):
            found = os.path.join(config_dir(), value)
    if not os.path.isfile(found):
        raise ConfigError(f'{where}: no file {shown(value)} (beside the characters file or in '
                          'the shipped config folder)')
    return found


def _flat(data: dict, prefix: str = '') -> list[tuple[str, object]]:
    """Return (name, value) of a parameters mapping, a nested group as a params file's.

    ``fabric: {damping: 0.2}`` is ``fabric.damping``, as rcl reads it in a params file.
    """
    out = []
    for key, value in data.items():
        name = f'{prefix}{key}'
        out += _flat(value, name + '.') if isinstance(value, dict) else [(name, value)]
    return out


def load_characters(path: str) -> list[CharacterSpec]:
    """Read and validate a characters file; a ConfigError names the file and key.

    :param path: the characters file (YAML).
    """
    data = load_yaml(path)
    top = Section(data, path)
    folder = os.path.dirname(os.path.abspath(path))
    defaults = top.section('defaults', {})
    entries = top.sections('characters')
    top.reject_unknown()
    if not entries:
        raise ConfigError(f'{path}.characters: expected at least one character')
    base = {k: defaults._data[k] for k in _KEYS if defaults.has(k)}
    for k in _KEYS:
        if defaults.has(k):
            defaults._used.add(k)
    defaults.reject_unknown()
    fabrics_by_file = {}
    out, names, prefixes = [], set(), {}
    for entry in entries:
        name = entry.text('name')
        if not _NAME.fullmatch(name):
            raise ConfigError(f'{entry._where}.name: {shown(name)} is not a ROS name (letters, '
                              'digits, _ and /, starting with a letter)')
        if len(name) > MAX_NAME:
            raise ConfigError(f'{entry._where}.name: {len(name)} characters, over the '
                              f'{MAX_NAME} its topics\' names leave it')
        count = entry.integer('count', 1, 1, MAX_CHARACTERS)
        keys = dict(base)
        for k in _KEYS:
            if entry.has(k):
                keys[k] = entry._data[k]
                entry._used.add(k)
        entry.reject_unknown()
        where = entry._where
        own = Section(keys, where)
        urdf = _path(own.text('urdf'), folder, f'{where}.urdf') if own.has('urdf') else None
        rig = _path(own.text('rig'), folder, f'{where}.rig') if own.has('rig') else None
        fabric_file = (_path(own.text('fabric_file'), folder, f'{where}.fabric_file')
                       if own.has('fabric_file') else None)
        if fabric_file not in fabrics_by_file:
            fabrics_by_file[fabric_file] = load_fabrics(fabric_file)
        fabrics = fabrics_by_file[fabric_file]
        fabric = own.text('fabric', 'tweed_jacket')
        if fabric not in fabrics:
            raise ConfigError(f'{where}.fabric: {shown(fabric)} is not a preset (presets: '
                              f'{", ".join(fabrics)})')
        prefix = keys.get('frame_prefix')
        if prefix is not None and not isinstance(prefix, str):
            raise ConfigError(f'{where}.frame_prefix: {shown(prefix)} is not text (quote it: '
                              f'"{prefix}")')
        parameters = own.section('parameters', {})
        values = default_values(fabrics[fabric], fabric)
        known = values.by_name()        # the file names them: typed at this boundary
        given = {}
        for key, value in _flat(parameters._data):
            if key not in known or key in _NOT_PARAMETERS:
                raise ConfigError(f'{where}.parameters.{shown(key)}: not a character\'s '
                                  'parameter' + (' (a key of the character itself)'
                                                 if key in _NOT_PARAMETERS else ''))
            try:
                given[key] = typed_value(key, value, known[key], f'{where}.parameters.{key}')
            except ValueError as e:
                raise ConfigError(str(e)) from None
        values = values.with_changes(given)
        for k in range(count):
            # Unpadded, as docs/crowd.md says: a publisher's loop names /walker_{k}, and a
            # count grown past 10 renames no character (padding made walker_1 walker_01).
            each = name if count == 1 else f'{name}_{k}'
            if each in names:
                raise ConfigError(f'{where}.name: {shown(each)} is there twice')
            names.add(each)
            try:
                frame_prefix = typed_value('frame_prefix', each + '/' if prefix is None
                                           else prefix, '', f'{where}.frame_prefix')
            except ValueError as e:
                raise ConfigError(str(e)) from None
            mine = values.with_changes({'frame_prefix': frame_prefix})
            # One prefix, one tree on /tf: two characters would publish the same frames.
            other = prefixes.setdefault(frame_prefix, each)
            if other != each:
                raise ConfigError(f'{where}.frame_prefix: characters {shown(other)} and '
                                  f'{shown(each)} both have {shown(frame_prefix)} (the '
                                  'same frames on /tf): give each its own')
            out.append(CharacterSpec(each, urdf, rig, fabric_file, mine))
            if len(out) > MAX_CHARACTERS:
                raise ConfigError(f'{path}: more than {MAX_CHARACTERS} characters')
    return out


def crowd_slice(characters: list, index: int, count: int) -> list:
    """Return the ``index``-th of ``count`` contiguous, near-equal slices of ``characters``.

    Each of K node processes started with the same file takes one slice: together they run
    every character once (sizes differ by at most one).

    :param characters: the file's characters, in its order.
    :param index: this process's slice, from 0.
    :param count: how many slices (node processes).
    """
    if count < 1 or not 0 <= index < count:
        raise ConfigError(f'slice {index} of {count}: expected 0 <= slice_index < slice_count')
    n = len(characters)
    return characters[index * n // count:(index + 1) * n // count]
