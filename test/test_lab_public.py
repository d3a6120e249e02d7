# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The lab and the benchmarks reach the package through its public names only (issue 49).

A private name of the package (one leading underscore) may change with no notice; a lab that
reads or patches one breaks, or worse measures something else, silently. The profile's stage
timers are the pipeline's ``stage_timer``; what is left is listed here with why.
"""

import ast
import gc
import glob
import os

import pytest

from jacket_cloth_ros.core.skeleton import load_shipped_character

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PACKAGE = 'jacket_cloth_ros'
SCANNED = ('jacket_cloth_lab/*.py', 'jacket_cloth_lab/*/*.py', 'benchmarks/*.py')
# (file, what it reaches): why it may.
ALLOWED = {
    ('jacket_cloth_lab/tables.py', 'argparse._SubParsersAction'):
        'the standard library\'s: argparse has no public name for a subcommands action',
    ('benchmarks/crowd_breakdown.py', 'setattr(owner, ...)'):
        'public methods of the package\'s classes wrapped with a timer, in the benchmark\'s own '
        'process: the crowd\'s parts are timed as they run live',
}


def _private(name):
    return name.startswith('_') and not name.startswith('__')


def _package_names(tree):
    """Return the names a file binds to the package's modules and objects by its imports."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or '').split('.')[0] == PACKAGE:
            names.update(a.asname or a.name for a in node.names)
        elif isinstance(node, ast.Import):
            names.update(a.asname or a.name.split('.')[0] for a in node.names
                         if a.name.split('.')[0] == PACKAGE)
    return names


def reaches(source):
    """Return what a file's source reaches past the package's public names, as readable text.

    A private name imported from the package; a private attribute of anything but the
    object's own (``self``, ``cls``); an attribute of a package module or class assigned
    (patched); a ``setattr`` on anything but ``self``.

    :param source: a Python file's text.
    """
    tree = ast.parse(source)
    package = _package_names(tree)
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or '').split('.')[0] == PACKAGE:
            found += [f'from {node.module} import {a.name}' for a in node.names
                      if _private(a.name) or any(map(_private, node.module.split('.')))]
        elif isinstance(node, ast.Import):
            found += [f'import {a.name}' for a in node.names
                      if a.name.split('.')[0] == PACKAGE and any(map(_private, a.name.split('.')))]
        elif isinstance(node, ast.Attribute) and _private(node.attr) and not (
                isinstance(node.value, ast.Name) and node.value.id in ('self', 'cls')):
            found.append(ast.unparse(node))
        elif isinstance(node, (ast.Assign, ast.AugAssign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            found += [f'{ast.unparse(t)} = ...' for t in targets
                      if isinstance(t, ast.Attribute) and isinstance(t.value, ast.Name)
                      and t.value.id in package]
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
              and node.func.id == 'setattr' and node.args
              and ast.unparse(node.args[0]) not in ('self', 'cls')):
            found.append(f'setattr({ast.unparse(node.args[0])}, ...)')
    return found


def test_the_lab_reaches_no_private_name_of_the_package():
    seen = set()
    for pattern in SCANNED:
        for path in sorted(glob.glob(os.path.join(ROOT, pattern))):
            where = os.path.relpath(path, ROOT)
            with open(path, encoding='utf-8') as f:
                seen.update((where, what) for what in reaches(f.read()))
    unexplained = [f'{where}: {what}' for where, what in sorted(seen - set(ALLOWED))]
    assert not unexplained, ('the lab reaches past the package\'s public names (add a public '
                             'API, or an entry in ALLOWED saying why):\n' + '\n'.join(unexplained))
    assert not set(ALLOWED) - seen, 'ALLOWED lists what no file reaches any more'


@pytest.mark.parametrize('source, found', [
    ('from jacket_cloth_ros.ros.node import _DIAG_STAMP_END', 1),
    ('from jacket_cloth_ros.ros import node as n\nn._DIAG_STAMP_END = 0', 2),
    ('from jacket_cloth_ros.ros import pipeline as p\np.messages = None', 1),
    ('sim._advance_kernel = wrap(sim._advance_kernel)', 2),
    ('pipeline._tf.encode = wrap(pipeline._tf.encode)', 2),
    ('self._clock = 0\nsim.time_stages(wrap)\nsetattr(self, "x", 1)', 0),
])
def test_the_scan_finds_what_the_lab_did_before(source, found):
    # What the lab's profile and benchmarks did before the stage timers (issue 49).
    assert len(reaches(source)) == found


def test_a_profile_leaves_the_package_as_it_found_it():
    # The timers went on the /tf template and the outfit that every pipeline of the character
    # shares (and on the pipeline module's messages): each later profile in the same process
    # ran inside every earlier one's timers, and bench speed runs several.
    from jacket_cloth_lab.profile import per_input_profile
    from jacket_cloth_ros.core.rig import load_rig
    from jacket_cloth_ros.core.simulation import bone_set
    from jacket_cloth_ros.ros import messages, pipeline
    skeleton = load_shipped_character()
    got = per_input_profile(skeleton, seconds=1.0)
    # (A steady input's /tf is laid out within its step: the tf stage reads none here.)
    assert got['us']['step'] > 0 and got['us']['markers'] > 0
    assert got['markers_skinning_us'] > 0
    bones = bone_set(skeleton, load_rig(skeleton))
    prefix = _defaults().frame_prefix
    template = messages.tf_template(tuple(bones.names), tuple(bones.parents), prefix)
    assert 'encode' not in vars(template)
    outfits = [o for o in gc.get_objects() if isinstance(o, messages.Outfit)]
    assert outfits and not any('draw_jacket' in vars(o) for o in outfits)
    assert pipeline.messages is messages


def _defaults():
    from jacket_cloth_ros.core.fabric import load_fabrics
    from jacket_cloth_ros.ros.values import default_values
    return default_values(load_fabrics()['tweed_jacket'])


def test_a_timed_pipeline_gives_the_same_messages_and_times_each_stage():
    from jacket_cloth_ros.core.rig import load_rig
    from jacket_cloth_ros.motion.messages import clip_messages
    from jacket_cloth_ros.ros.cdr import JointStateReader
    from jacket_cloth_ros.ros.pipeline import TIMED_STAGES, SessionPipeline
    from rclpy.serialization import serialize_message
    skeleton = load_shipped_character()
    rig = load_rig(skeleton)
    calls = dict.fromkeys(TIMED_STAGES, 0)

    def timer(name, stage):
        def counted(*args, **kwargs):
            calls[name] += 1
            return stage(*args, **kwargs)
        return counted
    plain = SessionPipeline(skeleton, rig, _defaults(), timing=False)
    timed = SessionPipeline(skeleton, rig, _defaults(), timing=False, stage_timer=timer)
    read = JointStateReader().read
    for stamp, msg in clip_messages(skeleton, 'walk', 60.0, 1.5, 10 ** 10):
        content = read(serialize_message(msg))
        assert timed.on_joint_state(content, stamp)[1] == plain.on_joint_state(content, stamp)[1]
    assert all(calls.values()), calls
    assert calls['markers'] == calls['skinning']


def test_a_timed_crowd_gives_the_same_messages_and_times_its_compiled_call():
    from jacket_cloth_ros.core.rig import load_rig
    from jacket_cloth_ros.motion.messages import clip_messages
    from jacket_cloth_ros.ros.cdr import JointStateReader
    from jacket_cloth_ros.ros.pipeline import CrowdPipeline, SessionPipeline
    from rclpy.serialization import serialize_message
    skeleton = load_shipped_character()
    rig = load_rig(skeleton)
    calls = []

    def timer(name, call):
        def counted(*args):
            calls.append(name)
            return call(*args)
        return counted
    crowds = CrowdPipeline(threads=1), CrowdPipeline(threads=1)
    crowds[0].add(SessionPipeline(skeleton, rig, _defaults(), timing=False))
    with pytest.raises(ValueError, match='fewer than two'):
        crowds[0].steps.time_stages(timer)          # one character: no compiled call yet
    for crowd in crowds:
        while len(crowd.pipelines) < 2:
            crowd.add(SessionPipeline(skeleton, rig, _defaults(), timing=False))
    crowds[1].steps.time_stages(timer)
    read = JointStateReader().read
    for stamp, msg in clip_messages(skeleton, 'walk', 60.0, 0.5, 10 ** 10):
        content = read(serialize_message(msg))
        plain, timed = (c.on_joint_states([(0, content), (1, content)]) for c in crowds)
        assert [outputs for _, outputs in timed] == [outputs for _, outputs in plain]
    assert calls and set(calls) == {'step'} and len(calls) == crowds[1].steps.calls


def test_the_labs_own_exports_are_public():
    # The split speed package re-exported two private helpers in its __all__, which the scan
    # above does not read; a name others import is public and named so.
    for path in glob.glob(os.path.join(ROOT, 'jacket_cloth_lab', '**', '*.py'), recursive=True):
        with open(path, encoding='utf-8') as f:
            tree = ast.parse(f.read())
        for node in ast.walk(tree):
            if isinstance(node, ast.Assign) and any(
                    isinstance(t, ast.Name) and t.id == '__all__' for t in node.targets):
                names = [e.value for e in node.value.elts]
                assert not [n for n in names if _private(n)], path
