# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Every parameter's default, range and meaning has one source (core.params and the node's
table); the shipped YAML, the README and the ROS declarations must agree with it."""

import os
import re

import pytest
import yaml

from jacket_cloth_ros.core.params import SIM_FIELDS, SimParams
from jacket_cloth_ros.ros.parameters import NODE_PARAMETERS, check_value, parse_override

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _readme_rows():
    """{name: (default cell, range cell)} of the README's parameter table."""
    with open(os.path.join(ROOT, 'README.md'), encoding='utf-8') as f:
        text = f.read()
    rows = re.findall(r'^\| `([a-z_.<>]+)` \|([^|]*)\|([^|]*)\|', text, re.MULTILINE)
    return {name: (default.strip(), rng.strip()) for name, default, rng in rows}


def _cell(value):
    if isinstance(value, bool):
        return f'`{str(value).lower()}`'
    if isinstance(value, str):
        return f'`{value}`' if value else "`''`"
    if isinstance(value, list):
        return '`[' + ', '.join(f'{v:g}' for v in value) + ']`'
    return repr(value)


def test_the_shipped_parameter_file_holds_the_defaults_under_any_namespace():
    with open(os.path.join(ROOT, 'config', 'node_params.yaml'), encoding='utf-8') as f:
        data = yaml.safe_load(f)
    assert list(data) == ['/**']          # a node name key is ignored under a namespace
    for name, value in data['/**']['ros__parameters'].items():
        assert value == NODE_PARAMETERS[name][1], name
        # ros2 param load sets it on a running node: nothing read-only, nothing that stops
        # a recording.
        assert not NODE_PARAMETERS[name][3] and name != 'record', name


def test_no_parameter_name_is_also_the_group_of_others():
    # ros2 param dump writes a.b as a: {b: ...}; an a of its own cannot be written beside it.
    from jacket_cloth_ros.core.fabric import load_fabric
    from jacket_cloth_ros.ros.parameters import fabric_parameters
    names = set(NODE_PARAMETERS) | set(fabric_parameters(load_fabric('tweed_jacket')))
    groups = {n.rsplit('.', 1)[0] for n in names if '.' in n}
    assert not names & groups, names & groups


def test_the_readme_table_lists_every_parameter_with_its_default_and_range():
    rows = _readme_rows()
    for name, (kind, default, rng, read_only, text) in NODE_PARAMETERS.items():
        assert name in rows, f'README parameter table lacks {name}'
        cell, range_cell = rows[name]
        assert cell == _cell(default), (name, cell)
        if rng is not None:
            assert range_cell.startswith(f'{rng[0]:g}–{rng[1]:g}'), (name, range_cell)
        if read_only:
            assert 'start' in range_cell, name
    for name, f in SIM_FIELDS.items():
        if f.metadata['choices'] is not None:
            listed = set(rows[name][1].replace('`', '').split(', '))
            assert listed == set(f.metadata['choices'].names()), name


@pytest.mark.parametrize('name, value', [
    ('sim_rate', 5.0), ('sim_rate', float('nan')), ('wind', [1e308, 0.0, 0.0]),
    ('wind', [0.0, 0.0]), ('stretch_limit', 'bogus'), ('solver', 'bogus'),
    ('record_compression', 'gzip'), ('substeps', 65)])
def test_one_check_refuses_a_bad_value_with_its_reason_everywhere(name, value):
    reason = check_value(name, value)
    assert reason.startswith(name), reason
    with pytest.raises(ValueError, match=name):
        if name in SIM_FIELDS:
            SimParams(**{name: value})
        else:
            raise ValueError(reason)


def test_overrides_take_the_same_ranges():
    assert parse_override('sim_rate:=240', {'sim_rate': 120.0}) == ('sim_rate', 240.0)
    with pytest.raises(ValueError, match='outside'):
        parse_override('sim_rate:=5', {'sim_rate': 120.0})


def test_a_recording_made_before_the_rename_reads_its_preset():
    from jacket_cloth_ros.ros.parameters import from_recording
    assert from_recording({'fabric': 'veil', 'fabric.damping': 0.1}) == {
        'fabric_preset': 'veil', 'fabric.damping': 0.1}
    assert from_recording({'fabric_preset': 'veil'}) == {'fabric_preset': 'veil'}


def test_a_refused_value_is_shown_as_a_user_writes_it():
    # rclpy hands arrays as array('d', ...): the reason printed Python's repr of it.
    from array import array
    reason = check_value('wind', array('d', [1e9, 0.0, 0.0]))
    assert reason.startswith('wind [1000000000.0, 0.0, 0.0] is outside'), reason
    assert 'array' not in check_value('lod_distances', array('d', [1.0, float('inf')]))
    assert check_value('sim_rate', True) == 'sim_rate must be a number, not true'
    many = check_value('wind', list(range(1000)))
    assert len(many) < 200, many


@pytest.mark.parametrize('name', ['record', 'frame_prefix', 'world_frame', 'world_joint'])
@pytest.mark.parametrize('char', ['\u202e', '\n', '\x1b', '\x00', '\u2028'])
def test_a_name_or_path_with_a_control_character_is_refused(name, char):
    # U+202E turns the rest of a log line around: `record:=/tmp/\u202eacm.session` reads as
    # another path, and a frame id with one names a frame no one sees as written.
    reason = check_value(name, f'a{char}b')
    assert reason.startswith(f'{name} holds a control character (U+{ord(char):04X}'), reason
    assert char not in reason
    assert check_value(name, 'npc1/ab') == ''


def _bundle():
    from jacket_cloth_ros.core.fabric import load_fabrics
    from jacket_cloth_ros.ros.values import default_values
    return default_values(load_fabrics()['tweed_jacket'])


@pytest.mark.parametrize('name, value', [
    ('markers_body', 'sideways'), ('record_compression', 'gzip'), ('markers_rate', 1e-300),
    ('frame_prefix', '/npc1/'), ('world_frame', ''), ('world_joint', 'a\nb'),
    ('wind', [1e308, 0.0, 0.0]), ('stretch_limit', 'glue'), ('sim_rate', float('nan'))])
def test_a_character_bundle_refuses_a_bad_value_with_the_nodes_reason(name, value):
    # Issue 49 item 3: the values are held once, as one checked bundle; it refuses what the
    # node refuses, saying why as the node's parameter callback does (check_value).
    values = _bundle()
    reason = check_value(name, value)
    assert reason
    with pytest.raises(ValueError) as e:
        values.with_changes({name: value})
    assert str(e.value) in (reason, f'{name}: {reason}')
    with pytest.raises(ValueError, match='outside'):      # its range too, as rclpy's
        values.with_changes({'fabric.damping': 2.0})
    with pytest.raises(ValueError, match='not a parameter of a character'):
        values.with_changes({'fabric': 'veil'})


def test_a_character_bundle_is_typed_immutable_and_changed_whole():
    import dataclasses

    from jacket_cloth_ros.ros.values import VALUE_NAMES, NodeValues
    values = _bundle()
    with pytest.raises(dataclasses.FrozenInstanceError):
        values.markers_rate = 5.0
    # Every parameter of a character is a field: the node's own typed, sim and fabric once.
    own = {f.name for f in dataclasses.fields(NodeValues)} - {'sim', 'fabric'}
    assert own == set(NODE_PARAMETERS) - set(SIM_FIELDS)
    assert list(values.by_name()) == list(VALUE_NAMES)
    changed = values.with_changes({'markers_rate': 10, 'fabric.iterations': 4,
                                   'wind': [1, 0, 0]})
    assert changed.markers_rate == 10.0 and isinstance(changed.markers_rate, float)
    assert changed.fabric.iterations == 4 and changed.sim.wind == (1.0, 0.0, 0.0)
    assert values.markers_rate == 30.0 and values.sim.wind == (0.0, 0.0, 0.0)
    # A part not changed is the same object: the simulation keeps its SimParams and Fabric.
    node_only = values.with_changes({'markers_debug': True})
    assert node_only.sim is values.sim and node_only.fabric is values.fabric
    # What a recording holds: the names, and arrays as lists (parameters_json).
    by_name = changed.by_name()
    assert by_name['wind'] == [1.0, 0.0, 0.0] and by_name['fabric.iterations'] == 4
    assert values.with_changes(by_name) == changed
    # rclpy takes a double within its tolerance of a range's end: the bundle does too.
    assert values.with_changes({'markers_rate': 240.0001}).markers_rate == 240.0001
