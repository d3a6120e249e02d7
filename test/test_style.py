# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The code's style as ament_flake8 and ament_pep257 check it, type hints and docstring fields.

As tf2_ros_py does, the linters run as tests; here as subprocesses of this interpreter, so
a checkout without colcon's ament_lint runs the same checks.

Docstrings (package and lab): every public function or method with parameters says each in a
Sphinx field, ``:param name: what it means`` (units, frames, shapes; the hint gives the type), in
the signature's order (``__init__``'s may sit in the class docstring); ``:returns:`` is optional,
spelt so; no Google ``Args:`` or numpy ``Parameters`` sections, no ``:type:``/``:rtype:``.
"""

import ast
import os
import re
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


def _modules():
    """Yield the path from ROOT and the parsed tree of every module of the package and the lab."""
    for package in ('jacket_cloth_ros', 'jacket_cloth_lab'):
        for folder, dirs, files in os.walk(os.path.join(ROOT, package)):
            dirs[:] = sorted(d for d in dirs if d != '__pycache__')
            for name in sorted(f for f in files if f.endswith('.py')):
                path = os.path.join(folder, name)
                with open(path, encoding='utf-8') as f:
                    yield os.path.relpath(path, ROOT), ast.parse(f.read(), path)


def test_public_functions_have_type_hints():
    missing = [f'{module}: {m}' for module, tree in _modules()
               for m in _unannotated(tree.body, '')]
    assert not missing, ('public functions without parameter or return annotations '
                         f'({len(missing)}):\n' + '\n'.join(missing))


_PARAM = re.compile(r'^:param\s+\\?\*{0,2}(\w+)\s*:')
_FOREIGN = (
    (re.compile(r'^(Args|Arguments|Keyword Args|Returns|Yields|Raises):$'), 'Google-style'),
    (re.compile(r'^:(type\s+\w+|rtype):'), 'types in the docstring'),
    (re.compile(r'^:return:'), ':return: for :returns:'),
)
_NUMPY = re.compile(r'^(Parameters|Returns|Yields|Raises|Other Parameters)$')


def _docstring_faults(function, class_doc):
    """Say what ``function``'s docstring lacks or holds against the :param convention.

    :param function: the function's AST node, public and not a kernel.
    :param class_doc: the enclosing class's docstring, read for ``__init__`` without its own.
    :returns: the faults, each a short phrase; empty when the docstring is right.
    """
    args = function.args
    names = [a.arg for a in (*args.posonlyargs, *args.args) if a.arg not in ('self', 'cls')]
    names += [a.arg for a in (args.vararg,) if a] + [a.arg for a in args.kwonlyargs]
    names += [a.arg for a in (args.kwarg,) if a]
    doc = ast.get_docstring(function)
    if doc is None and function.name == '__init__':
        doc = class_doc
    if not names and doc is None:
        return []
    if doc is None:
        return ['no docstring']
    lines = [line.strip() for line in doc.splitlines()]
    faults = [what for line in lines for pattern, what in _FOREIGN if pattern.match(line)]
    faults += ['numpy-style' for line, under in zip(lines, lines[1:])
               if _NUMPY.match(line) and re.fullmatch(r'-{3,}', under)]
    fields = [m.group(1) for m in map(_PARAM.match, lines) if m]
    missing = [n for n in names if n not in fields]
    stale = [n for n in fields if n not in names]
    if missing:
        faults.append('missing :param ' + ', '.join(missing))
    if stale:
        faults.append('stale :param ' + ', '.join(stale))
    if not missing and not stale and fields != names:
        faults.append('fields not in the signature\'s order')
    return sorted(set(faults), key=faults.index)


def _undocumented(statements, where, class_doc=None):
    """Yield ``where``-qualified public functions in ``statements`` with docstring faults.

    The same functions as ``_unannotated`` looks at: classes entered, nested functions and
    numba kernels exempt.
    """
    for node in statements:
        if isinstance(node, ast.ClassDef):
            if not node.name.startswith('_'):
                yield from _undocumented(node.body, f'{where}{node.name}.',
                                         ast.get_docstring(node))
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            if _public(node.name) and not _is_kernel(node):
                faults = _docstring_faults(node, class_doc)
                if faults:
                    yield f'{where}{node.name} ({"; ".join(faults)})'
        else:
            for field in ('body', 'orelse', 'finalbody', 'handlers'):
                yield from _undocumented(getattr(node, field, []), where, class_doc)


def test_public_functions_say_each_parameter_in_a_param_field():
    offenders = [f'{module}: {f}' for module, tree in _modules()
                 for f in _undocumented(tree.body, '')]
    assert not offenders, (f'public functions against the :param convention ({len(offenders)}):'
                           '\n' + '\n'.join(offenders))


_MADE_UP = '''
class Pose:
    """A made-up class whose constructor is told in the class docstring.

    :param frame: the parent frame.
    """

    def __init__(self, frame: str):
        self.frame = frame

    def moved(self, offset: float, *axes: str) -> 'Pose':
        """Return the pose moved.

        :param offset: how far, in metres.
        :param axes: the axes moved along.
        :returns: the moved pose.
        """

    def missing(self, offset: float, scale: float) -> None:
        """Say one parameter only.

        :param offset: how far, in metres.
        """

    def stale(self, offset: float) -> None:
        """Name a parameter the function lacks.

        :param offset: how far, in metres.
        :param scale: the scale it once took.
        """

    def google(self, offset: float) -> float:
        """Write Google's sections.

        Args:
            offset: how far, in metres.

        Returns:
            the offset.
        """

    def _private(self, offset):
        pass
'''


def test_the_docstring_check_tells_each_fault_apart():
    found = list(_undocumented(ast.parse(_MADE_UP).body, ''))
    assert found == ['Pose.missing (missing :param scale)',
                     'Pose.stale (stale :param scale)',
                     'Pose.google (Google-style; missing :param offset)']
    assert _docstring_faults(ast.parse(
        'def f(a, b):\n    """Swap.\n\n    :param b: x.\n    :param a: y.\n    """').body[0],
        None) == ['fields not in the signature\'s order']
    assert _docstring_faults(ast.parse(
        'def f(a):\n    """Do.\n\n    :param a: x.\n    :return: y.\n    """').body[0],
        None) == [':return: for :returns:']
    assert _docstring_faults(ast.parse('def f(a):\n    pass').body[0], None) == ['no docstring']
