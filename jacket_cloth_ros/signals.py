# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Ctrl-C or SIGTERM at any moment of a program's life: one line, never a traceback.

The executables start here (setup.py's entry points), before anything heavy is imported:
Python takes a second or more to import rclpy, numpy and numba, and a Ctrl-C then raised
KeyboardInterrupt inside an import. While a program starts, a signal ends it at once with one
line and 128 + the signal's number; once it runs, SIGINT raises KeyboardInterrupt as Python's
default does (rclpy's own handler has shut its context down too), but not inside a block or
function that must finish whole (:func:`uninterrupted`, :func:`whole`), SIGTERM is left to
rclpy's handler, and while it stops a second signal (``ros2 launch`` forwards the terminal's
Ctrl-C the process also got) is ignored.
"""

import contextlib
import importlib
import os
import signal
import sys
from typing import Callable, Iterator

STARTING, RUNNING, STOPPING = 'starting', 'running', 'stopping'
_SIGNALS = (signal.SIGINT, signal.SIGTERM)
_now = {'program': sys.argv[0], 'phase': STARTING, 'doing': 'starting', 'held': 0,
        'pending': False}
_whole = set()          # the code of each function marked whole()


def _on_signal(signum: int, frame: object) -> None:
    if _now['phase'] == STARTING:
        # The process's own stderr: a signal may come while a URDF parse has sys.stderr taken.
        print(f'{_now["program"]}: stopped while {_now["doing"]}', file=sys.__stderr__,
              flush=True)
        os._exit(128 + signum)
    if _now['phase'] == RUNNING and signum == signal.SIGINT:
        if _now['held'] or _in_whole(frame):
            _now['pending'] = True          # raised as the block ends (uninterrupted)
            return
        _now['phase'] = STOPPING
        raise KeyboardInterrupt


def whole(function: Callable) -> Callable:
    """Mark ``function`` as one that finishes whole: a SIGINT while it runs waits for its end.

    As :func:`uninterrupted`, but held by the function's code being on the stack when the
    signal comes, so a call costs nothing and adds no frame (the node's JointState callback).
    The function ends with :func:`raise_held`, in a ``finally``.

    :param function: a plain function or method, returned as it is.
    :returns: ``function``.
    """
    _whole.add(function.__code__)
    return function


def raise_held() -> None:
    """Raise a SIGINT held while the calling :func:`whole` function ran, unless still held.

    It stays held while an :func:`uninterrupted` block or another whole function below the
    caller is still running.
    """
    caller = sys._getframe(1)
    if _now['pending'] and not _now['held'] and not _in_whole(caller.f_back):
        _now['pending'] = False
        _now['phase'] = STOPPING
        raise KeyboardInterrupt


def _in_whole(frame: object) -> bool:
    """Tell whether a :func:`whole` function is running at ``frame`` or below it."""
    while frame is not None:
        if frame.f_code in _whole:
            return True
        frame = frame.f_back
    return False


@contextlib.contextmanager
def uninterrupted() -> Iterator[None]:
    """Hold a SIGINT that comes inside the block until the block ends, then raise it.

    Why: a Ctrl-C between an input's /tf going out and the input's recording left a recording
    without the input that /tf came from (seen in a test under load).

    :returns: a context manager; blocks may nest.
    """
    _now['held'] += 1
    try:
        yield
    finally:
        _now['held'] -= 1
        if not _now['held'] and _now['pending'] and not _in_whole(sys._getframe()):
            _now['pending'] = False
            _now['phase'] = STOPPING
            raise KeyboardInterrupt


def _unraisable(what: object) -> None:
    """Drop llvmlite's finaliser complaint once a signal stops the program; pass on the rest.

    A Ctrl-C while numba loads or compiles a kernel cuts an llvmlite object short in its
    making; its ``__del__`` then fails and Python prints that traceback as the program ends.

    :param what: the ``sys.unraisablehook`` argument.
    """
    where = getattr(getattr(what, 'object', None), '__module__', None) or ''
    if _now['phase'] == STOPPING and where.startswith('llvmlite.'):
        return
    sys.__unraisablehook__(what)


def guard(program: str) -> None:
    """Take SIGINT and SIGTERM for ``program``, starting: from now on a signal stops it cleanly.

    Installed before rclpy.init, so rclpy's handlers chain to this one.

    :param program: the executable's name, which the line starts with.
    """
    _now.update(program=program, phase=STARTING, doing='starting')
    sys.unraisablehook = _unraisable
    for signum in _SIGNALS:
        signal.signal(signum, _on_signal)


def doing(what: str) -> None:
    """Name what the program does while it starts (``compiling the kernels``), for the line.

    :param what: the doing, as the line ``stopped while ...`` says it.
    """
    _now['doing'] = what


def running() -> None:
    """Mark the program started: SIGINT raises KeyboardInterrupt, SIGTERM is rclpy's."""
    _now['phase'] = RUNNING


def stopping() -> None:
    """Mark the program stopping: further signals are ignored until it has.

    Ignored by the OS from here on, not only by our handler: Python's finalisation puts a
    handler of its own back to the default, and a signal then ended the process (exit -2).
    """
    _now['phase'] = STOPPING
    for signum in _SIGNALS:
        signal.signal(signum, signal.SIG_IGN)


def _start(program: str, target: str, ours: bool = True) -> int:
    """Guard ``program``, import ``target`` (``module:function``) and return what it returns.

    ``ours``: the program goes on with these handlers; else Python's defaults are put back
    once it is imported (the ``jacket_cloth`` tools set their own).
    """
    guard(program)
    module, function = target.split(':')
    main = getattr(importlib.import_module(module), function)
    if not ours:
        signal.signal(signal.SIGINT, signal.default_int_handler)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
    return main()


def node_command() -> list[str]:
    """Return the command that runs ``jacket_cloth_node`` in this Python, guarded from the start.

    For a tool that starts the node as its child: ``python -m jacket_cloth_ros.ros.node``
    imports everything before a line of its own runs, so a signal then was a traceback.
    """
    return [sys.executable, '-c',
            'import sys; from jacket_cloth_ros import signals; sys.exit(signals.node())']


def node() -> int:
    """``jacket_cloth_node``."""
    return _start('jacket_cloth_node', 'jacket_cloth_ros.ros.node:main')


def crowd() -> int:
    """``jacket_cloth_crowd``."""
    return _start('jacket_cloth_crowd', 'jacket_cloth_ros.ros.crowd:main')


def tools() -> int:
    """``jacket_cloth``."""
    return _start('jacket_cloth', 'jacket_cloth_ros.tools.cli:main', ours=False)
