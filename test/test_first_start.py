# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""First start in seconds: `jacket_cloth warm` (run by make, or once after colcon build) leaves
numba's cache holding every kernel the node's per-input path calls."""

import os
import subprocess
import sys

# In a fresh process on the cache `warm` filled: the node's pipeline on the shipped character,
# every output of a few inputs, then every kernel's compile misses counted.
_NODE_PATH = '''
import sys
from numba.core.registry import CPUDispatcher
from jacket_cloth_ros.ros.warm import kernels_cached
assert kernels_cached(), 'the cache is empty'
from jacket_cloth_ros.ros.warm import warm_kernels
warm_kernels()
import jacket_cloth_ros.core.physics.cloth, jacket_cloth_ros.core.physics.pose
import jacket_cloth_ros.core.physics.step, jacket_cloth_ros.core.physics.sampling
import jacket_cloth_ros.ros.cdr, jacket_cloth_ros.ros.marker_kernel
missed = [f'{m.__name__}.{name}' for m in list(sys.modules.values())
          if m and m.__name__.startswith('jacket_cloth_ros')
          for name, f in vars(m).items()
          if isinstance(f, CPUDispatcher) and sum(f.stats.cache_misses.values())]
print(sorted(set(missed)))
'''


def test_after_warm_the_node_path_compiles_nothing(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    empty = subprocess.run(
        [sys.executable, '-c', 'from jacket_cloth_ros.ros.warm import kernels_cached;'
         'print(kernels_cached())'], env=env, capture_output=True, text=True, timeout=120)
    assert empty.stdout.strip() == 'False', empty.stderr     # a fresh install: not cached
    warm = subprocess.run([sys.executable, '-m', 'jacket_cloth_ros', 'warm'], env=env,
                          capture_output=True, text=True, timeout=600)
    assert warm.returncode == 0 and 'compiled and cached' in warm.stdout, warm.stderr
    after = subprocess.run([sys.executable, '-c', _NODE_PATH], env=env, capture_output=True,
                           text=True, timeout=300)
    assert after.returncode == 0, after.stderr
    assert after.stdout.strip() == '[]'                        # nothing left to compile


def test_ctrl_c_while_the_node_compiles_is_one_line_and_a_prompt_exit(tmp_path):
    # It compiled inside an executor callback: Ctrl-C shut the context down, the compile ran
    # on for half a minute and the node ended in a traceback.
    # Signalled once it says it compiles: an event, not a guess at how long imports take.
    import signal
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path), ROS_DOMAIN_ID='97')
    node = subprocess.Popen([sys.executable, '-m', 'jacket_cloth_ros.ros.node'], env=env,
                            stderr=subprocess.PIPE, text=True)
    said = node.stderr.readline()
    assert 'compiling the simulation kernels' in said, said
    node.send_signal(signal.SIGINT)
    err = said + node.communicate(timeout=120)[1]     # compiling on would take minutes more
    assert node.returncode == 130 and 'Traceback' not in err, err
    assert err.strip().splitlines()[-1] == \
        'jacket_cloth_node: stopped while compiling the kernels'
