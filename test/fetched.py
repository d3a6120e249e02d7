# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Files ``make mocap`` fetches from the package registries into the venv (never committed).

Motion captures, the DeepMimic humanoid and its clips, and robot URDFs (JVRC-1; Unitree G1,
TALOS and Romeo out of example-robot-data), each by its file name.
"""

import os
import sys

import pytest

MOCAP = os.path.join(sys.prefix, 'share', 'mocap')


def fetched(name: str) -> str:
    """Return the path of a fetched file; fail the test, naming the make target, if absent."""
    path = os.path.join(MOCAP, name)
    if not os.path.isfile(path):
        pytest.fail(f'{path} is missing: run `make mocap` (`make test` fetches it)')
    return path
