# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The docs' figure tables rewritten from a test's quick lab run, on a copy of docs/.

The tests that run a bench's quick mode hand its folder here, so the tables are checked
against real results without running any bench again.
"""

import os
import shutil

from jacket_cloth_lab.cli import main
from jacket_cloth_lab.tables import TABLES, regions

DOCS = os.path.join(os.path.dirname(__file__), '..', 'docs')

# Which test file hands which results here: test_lab_tables checks every kind is covered.
COVERED = {'speed.latest': 'test_lab_speed.py', 'speed.profile': 'test_lab_speed.py',
           'crowd.held': 'test_lab_speed.py', 'speed.host': 'test_lab_speed.py',
           'lod.latest': 'test_lod.py', 'crowd.lod': 'test_lod.py',
           'bench.pareto': 'test_lab_accuracy.py', 'bench.references': 'test_lab_accuracy.py',
           'stress.matrix': 'test_lab.py', 'analyze.clips': 'test_lab_tables.py',
           'analyze.deepmimic': 'test_lab_tables.py'}


def _regions(docs):
    out = {}
    for name in sorted(os.listdir(docs)):
        if name.endswith('.md'):
            with open(os.path.join(docs, name), encoding='utf-8') as f:
                out[name] = regions(f.read())
    return out


def _run(outputs, source, command):
    """Return what the head names for a source: the run's folder, or the documented command."""
    folder = outputs[source.split('/')[0]]
    return str(folder) if os.path.isfile(os.path.join(folder, 'run.json')) else command


def rewritten(tmp_path, outputs, kinds):
    """Run ``tables`` on a copy of docs/ from the given results; check what it wrote.

    Every region of ``kinds`` is rewritten, headed by the run that made its results (their
    folder is in the command), the other regions keep their text, and a second run changes
    nothing (``--check`` says so too).

    :param tmp_path: a folder of the test's own.
    :param outputs: the results folder under ``--from`` (``bench``, ``stress``, ...) -> the
        folder the test's run wrote.
    :param kinds: the kinds of table those results make.
    :returns: kind -> its new body, of each region rewritten.
    """
    results = tmp_path / 'results'
    results.mkdir()
    for name, folder in outputs.items():
        os.symlink(folder, results / name)
    docs = tmp_path / 'docs'
    shutil.copytree(DOCS, docs, ignore=shutil.ignore_patterns('images'))
    before = _regions(docs)
    assert main(['tables', '--from', str(results), '--docs', str(docs)]) == 0
    after = _regions(docs)
    bodies = {}
    for name, old in before.items():
        assert [k for k, _ in old] == [k for k, _ in after[name]], name
        for (kind, was), (_, now) in zip(old, after[name]):
            if kind not in kinds:
                assert now == was, (name, kind)
                continue
            assert now != was and now.endswith('\n\n'), (name, kind)   # a blank line ends a table
            assert all(_run(outputs, s, c) in now.split('\n')[0]
                       for s, c in zip(TABLES[kind].sources, TABLES[kind].commands)), now
            bodies[kind] = now
    assert set(bodies) == set(kinds), set(kinds) - set(bodies)
    texts = {n: (docs / n).read_text() for n in before}
    assert main(['tables', '--from', str(results), '--docs', str(docs), '--check']) == 0
    assert main(['tables', '--from', str(results), '--docs', str(docs)]) == 0
    assert {n: (docs / n).read_text() for n in before} == texts
    return bodies
