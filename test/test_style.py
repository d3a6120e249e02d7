# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The code's style as ament_flake8 and ament_pep257 check it.

As tf2_ros_py does, the linters run as tests; here as subprocesses of this interpreter, so
a checkout without colcon's ament_lint runs the same checks.
"""

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
