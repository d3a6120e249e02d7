# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""core is built in one-way layers (core/__init__.py), and its compiled code takes bundles.

Every import counts: at the top, inside a function and under TYPE_CHECKING, since any of them
ties two modules together for a reader as much as for Python.
"""

import ast
import pathlib

CORE = pathlib.Path(__file__).resolve().parent.parent / 'jacket_cloth_ros' / 'core'

# Bottom up: a module imports only from its own layer or those below (core/__init__.py).
LAYERS = (
    ('bundles', 'compiled', 'choices', 'config', 'transforms', 'geometry'),
    ('physics.pose', 'physics.colliders', 'physics.cloth', 'physics.hood', 'physics.step',
     'physics.crowd', 'physics.sampling', 'physics.skinning'),
    ('skeleton', 'bone_layer', 'urdf_colliders', 'rig', 'fabric', 'params', 'jacket_mesh',
     'body_mesh'),
    ('inputs', 'lod', 'measures', 'body_proxy', 'stepping', 'simulation', 'crowd'),
)
LAYER_OF = {name: k for k, names in enumerate(LAYERS) for name in names}


def _module_name(path):
    parts = path.relative_to(CORE).with_suffix('').parts
    return '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)


def _imports(path):
    """Yield every module name this core module imports (any place in the file)."""
    package = _module_name(path).split('.')
    if path.name != '__init__.py':
        package = package[:-1]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - (node.level - 1)] if node.level > 1 else package
                if node.level - 1 > len(package):
                    yield '..'                      # above core
                    continue
                stem = base + (node.module.split('.') if node.module else [])
            elif node.module.startswith('jacket_cloth_ros.core'):
                stem = node.module.split('.')[2:]
            elif node.module.startswith('jacket_cloth_ros'):
                yield '..'
                continue
            else:
                yield '!' + node.module
                continue
            # ``from .physics import step`` names a module; ``from .bundles import Body`` not.
            for alias in node.names:
                candidate = '.'.join(stem + [alias.name])
                yield candidate if candidate in LAYER_OF else '.'.join(stem)
        elif isinstance(node, ast.Import):
            for alias in node.names:
                yield '!' + alias.name


def _graph():
    graph = {}
    for path in sorted(CORE.rglob('*.py')):
        name = _module_name(path)
        if name in ('', 'physics'):
            continue
        graph[name] = {m for m in _imports(path) if m not in ('', 'physics')}
    return graph


def _upward(graph):
    """Return the edges of ``graph`` from a module to a module of a higher layer."""
    return [(a, b) for a, deps in graph.items() for b in deps
            if b in LAYER_OF and LAYER_OF[b] > LAYER_OF[a]]


def _cycle(graph):
    """Return one import cycle of ``graph`` among core modules as a list, or []."""
    graph = {a: sorted(b for b in deps if b in graph) for a, deps in graph.items()}
    state = {}

    def visit(node, trail):
        state[node] = 'open'
        for nxt in graph[node]:
            if state.get(nxt) == 'open':
                return trail + [node, nxt]
            found = [] if nxt in state else visit(nxt, trail + [node])
            if found:
                return found
        state[node] = 'done'
        return []

    for node in sorted(graph):
        found = [] if node in state else visit(node, [])
        if found:
            return found
    return []


def test_every_core_module_has_a_layer_and_imports_only_its_own_or_lower_ones():
    graph = _graph()
    assert set(graph) == set(LAYER_OF), 'place every core module in LAYERS (core/__init__.py)'
    assert not _upward(graph), f'imports from a higher layer: {_upward(graph)}'
    outside = [(a, b) for a, deps in graph.items() for b in deps if b == '..']
    assert not outside, f'core imports the rest of the package: {outside}'
    ros = [(a, b) for a, deps in graph.items() for b in deps
           if b.startswith(('!rclpy', '!sensor_msgs', '!tf2_msgs', '!mcap'))]
    assert not ros, f'core imports ROS or MCAP: {ros}'


def test_core_has_no_import_cycle():
    assert not _cycle(_graph()), ' -> '.join(_cycle(_graph()))


def test_the_layer_checks_read_every_kind_of_import_and_see_what_they_must():
    # They would pass on a graph they cannot read: hold them to known edges, and to a cycle
    # and an upward import made up here.
    graph = _graph()
    assert {'compiled', 'physics.colliders'} <= graph['physics.cloth']
    assert 'rig' in graph['simulation'] and 'skeleton' in graph['rig']   # TYPE_CHECKING too
    assert 'urdf_colliders' in graph['rig']                                  # in a function
    assert _cycle({'rig': {'skeleton'}, 'skeleton': {'bone_layer'}, 'bone_layer': {'rig'}})
    assert _upward({'bundles': {'simulation'}}) == [('bundles', 'simulation')]


def test_no_compiled_function_takes_more_than_ten_parameters():
    # Bundles instead of long positional lists (core/bundles.py): two neighbouring arrays of
    # one dtype and shape can no longer be swapped by a caller.
    package = CORE.parent
    long = []
    for path in package.rglob('*.py'):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef) and any(
                    'njit' in ast.unparse(d) for d in node.decorator_list):
                if len(node.args.args) > 10:
                    long.append(f'{path.name}:{node.name}({len(node.args.args)})')
    assert not long, long


def test_a_simulation_holds_its_model_tuning_and_state_once(make_sim):
    sim = make_sim()
    # 23 since the rig's start-inside check, the M9 grid bones' last good frames (an edge
    # pressed flat) and the collapse watch: each held here alone.
    assert len(vars(sim)) <= 23, sorted(vars(sim))
    # The cloth is the state's very array: a write through either is seen by both and by
    # the compiled step, and assigning one writes into it rather than replacing it.
    x = sim.state.x
    sim.x = sim.x + 1.0
    assert sim.state.x is x and sim.x is x and (x == sim.rig.rest + 1.0).all()
    assert sim.tuning.damping is not None and not hasattr(sim, 'damping')
