# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Where a live crowd's time goes: each part's wall time per character-input, over real DDS.

    python benchmarks/crowd_breakdown.py [--characters 64] [--seconds 4]

Runs a jacket_cloth_crowd node in this process (pinned to core 0, one step thread, its
executor spun in this thread) and the lab's live driver (``jacket_cloth_lab.crowd.live``: one
120 Hz JointState stream every character hears) in another process on the other cores. Named
methods are wrapped with a timer (about 0.4 us a call, in the figures), so the parts are as
they run live, cold caches and all: an in-process loop without DDS ran them 0.5-0.9x as long.
Prints each part's wall time per character-input (``on_joint_states`` holds ``step_and_tf``,
which holds ``CrowdSteps.run``, which holds the compiled steps; the ``CrowdInputs`` parts run
in the executor, outside the batch) and the process's CPU per character-input, which also
counts the DDS threads. Exits 1 if the driver failed or no input came. Run it alone.
"""

import argparse
import collections
import os
import subprocess
import sys
import tempfile
import time

# (module, class, its methods timed)
PARTS = (
    ('ros.node', 'JacketClothNode', ('on_joint_states',)),
    ('ros.pipeline', 'CrowdPipeline', ('step_and_tf',)),
    ('core.crowd', 'CrowdSteps', ('run',)),
    ('core.simulation', 'JacketSimulation', ('prepare', 'complete')),
    ('ros.cdr', 'JointStateReader', ('read',)),
    ('ros.pipeline', 'SessionPipeline', ('account_tf', 'periodic_outputs')),
    ('ros.character', 'CrowdInputs', ('take_data', 'add_to_wait_set', 'is_ready')),
    ('ros.character', 'Character', ('count_lost',)),
)


def _timed(spent, label, f):
    def timed(*args, **kwargs):
        started = time.perf_counter_ns()
        try:
            return f(*args, **kwargs)
        finally:
            spent[label] += time.perf_counter_ns() - started
    return timed


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--characters', type=int, default=64)
    parser.add_argument('--seconds', type=float, default=4.0)
    parser.add_argument('--driver', action='store_true', help=argparse.SUPPRESS)
    args = parser.parse_args()
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    sys.path.insert(0, root)
    domain = 40 + os.getpid() % 20
    if args.driver:                 # the other process: drive until the crowd has been measured
        from jacket_cloth_lab.crowd import live
        from jacket_cloth_ros.core.skeleton import Skeleton, shipped_character_urdf
        # cores={0}: the driver keeps off the crowd's core (it starts no process of its own).
        live(Skeleton(shipped_character_urdf()), [], args.characters, args.seconds + 8.0,
             int(os.environ['ROS_DOMAIN_ID']), cores={0})
        return 0
    os.environ['NUMBA_NUM_THREADS'] = '1'
    os.sched_setaffinity(0, {0})
    import importlib

    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    from jacket_cloth_lab.crowd import crowd_command
    from jacket_cloth_ros.ros.node import JacketClothNode
    spent = collections.Counter()
    for module, cls, methods in PARTS:
        owner = getattr(importlib.import_module(f'jacket_cloth_ros.{module}'), cls)
        for method in methods:
            setattr(owner, method, _timed(spent, f'{cls}.{method}', getattr(owner, method)))
    with tempfile.TemporaryDirectory() as folder:       # the characters file (its URDF shipped)
        argv = crowd_command(args.characters, folder, 1)
        ctx = rclpy.Context()
        rclpy.init(args=['crowd'] + argv[argv.index('--ros-args'):], context=ctx,
                   domain_id=domain)
        node = JacketClothNode(crowd=True, context=ctx)     # every character loaded: typed
        node.crowd.steps.time_stages(
            lambda _, call: _timed(spent, 'compiled steps (advance_crowd)', call))
        executor = SingleThreadedExecutor(context=ctx)
        executor.add_node(node)
        others = set(range(os.cpu_count())) - {0} or {0}
        driver = subprocess.Popen(
            [sys.executable, os.path.abspath(__file__), '--driver', '--characters',
             str(args.characters), '--seconds', str(args.seconds)],
            env=dict(os.environ, ROS_DOMAIN_ID=str(domain),
                     PYTHONPATH=os.pathsep.join(filter(None, (root,
                                                              os.environ.get('PYTHONPATH'))))),
            preexec_fn=lambda: os.sched_setaffinity(0, others))

        def inputs():
            return sum(c.inputs for c in node.characters)

        def spin(until):
            while not until():
                executor.spin_once(timeout_sec=0.05)
        try:
            limit = time.monotonic() + 120.0
            # Past the kernels' loading and the first diagnostics: 3 s of inputs.
            spin(lambda: inputs() >= args.characters * 360 or time.monotonic() > limit)
            spent.clear()
            cpu, taken, end = time.process_time(), inputs(), time.monotonic() + args.seconds
            spin(lambda: time.monotonic() > end)
            cpu, taken = time.process_time() - cpu, inputs() - taken
        finally:
            try:
                driver.wait(timeout=60 + args.seconds)
            except subprocess.TimeoutExpired:
                driver.kill()
                driver.wait()
            finally:
                executor.shutdown()
                node.destroy_node()
                rclpy.shutdown(context=ctx)
    if driver.returncode or not taken:
        print(f'crowd_breakdown: the driver exited with {driver.returncode} after {taken} '
              'inputs; no figures', file=sys.stderr)
        return 1
    expected = args.characters * 120 * args.seconds
    print(f'{args.characters} characters, {taken} inputs in {args.seconds:g} s '
          f'({taken / expected:.0%} of those sent); wall time per character-input:')
    for label, ns in spent.most_common():
        print(f'  {label:36s} {ns / taken / 1e3:6.1f} us')
    print(f'CPU of this process per character-input: {cpu / taken * 1e6:.1f} us')
    return 0


if __name__ == '__main__':
    sys.exit(main())
