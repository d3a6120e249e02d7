# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The code's style as ament_flake8 and ament_pep257 check it, and the package's type hints.

As tf2_ros_py does, the linters run as tests; here as subprocesses of this interpreter, so
a checkout without colcon's ament_lint runs the same checks.
"""

import ast
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CHECKED = ('jacket_cloth_ros', 'jacket_cloth_lab', 'test', 'benchmarks', 'launch_scripts',
           'setup.py')


def _lint(*command):
    """Run ``python -m <command> CHECKED`` in the checkout; return its exit code and output."""
    result = subprocess.run([sys.executable, '-m', *command, *CHECKED], cwd=ROOT,
                            capture_output=True, text=True)
    return result.returncode, (result.stdout + result.stderr).strip()


def test_flake8_as_ament_flake8():
    # ament_flake8's line length; caches hold no source.
    code, output = _lint('flake8', '--max-line-length', '99', '--exclude', '__pycache__')
    assert code == 0, f'flake8 violations:\n{output}'


def test_pep257_as_ament_pep257():
    # As ament_pep257: a missing docstring is no error, the form of every present one is.
    code, output = _lint('pydocstyle', '--convention=pep257',
                         '--add-ignore=D100,D101,D102,D103,D104,D105,D106,D107')
    assert code == 0, f'pydocstyle violations:\n{output}'


def _is_kernel(function):
    """Tell whether ``function`` is compiled by numba (decorated ``@njit`` or ``@njit(...)``)."""
    for decorator in function.decorator_list:
        target = decorator.func if isinstance(decorator, ast.Call) else decorator
        name = target.attr if isinstance(target, ast.Attribute) else getattr(target, 'id', '')
        if name == 'njit':
            return True
    return False


def _public(name):
    """Tell whether a function or method name is public: no leading underscore, or a dunder."""
    return not name.startswith('_') or (name.startswith('__') and name.endswith('__'))


def _unannotated(statements, where):
    """Yield ``where``-qualified names of public functions in ``statements`` lacking hints.

    Class bodies are entered (a private class's methods are private); function bodies are
    not (nested functions are exempt), nor are numba kernels, whose types numba infers.
    """
    for node in statements:
        if isinstance(node, ast.ClassDef):
            if not node.name.startswith('_'):
                yield from _unannotated(node.body, f'{where}{node.name}.')
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            if not _public(node.name) or _is_kernel(node):
                continue
            args = node.args
            missing = [a.arg for a in (*args.posonlyargs, *args.args, *args.kwonlyargs)
                       if a.annotation is None and a.arg not in ('self', 'cls')]
            missing += [f'*{a.arg}' for a in (args.vararg,) if a and a.annotation is None]
            missing += [f'**{a.arg}' for a in (args.kwarg,) if a and a.annotation is None]
            if node.returns is None and node.name != '__init__':
                missing.append('return')
            if missing:
                yield f'{where}{node.name} ({", ".join(missing)})'
        else:
            # if/try/with blocks at module or class level can define functions too.
            for field in ('body', 'orelse', 'finalbody', 'handlers'):
                yield from _unannotated(getattr(node, field, []), where)


def test_public_functions_have_type_hints():
    package = os.path.join(ROOT, 'jacket_cloth_ros')
    missing = []
    for folder, dirs, files in os.walk(package):
        dirs[:] = sorted(d for d in dirs if d != '__pycache__')
        for name in sorted(f for f in files if f.endswith('.py')):
            path = os.path.join(folder, name)
            with open(path, encoding='utf-8') as f:
                tree = ast.parse(f.read(), path)
            module = os.path.relpath(path, ROOT)
            missing += [f'{module}: {m}' for m in _unannotated(tree.body, '')]
    assert not missing, ('public functions without parameter or return annotations '
                         f'({len(missing)}):\n' + '\n'.join(missing))
