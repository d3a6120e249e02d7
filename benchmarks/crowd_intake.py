# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A crowd character's input against a lone simulation's ``process``, side by side in one run.

    python benchmarks/crowd_intake.py [--characters 8] [--inputs 600]

Each 120 Hz walk input goes, in turn, to a lone pipeline (``SessionPipeline.on_joint_state``:
the simulation's ``process``, what jacket_cloth_node and a replay run) and to crowds of
``--characters`` shipped characters (``CrowdPipeline.on_joint_states``, one thread) given
the same content as: the reader's one name list object (the steady way), a new name list
object each message (as rclpy's own deserialisation gives), a list that changes every
message (turned round every other one: never the steady way). Prints the median thread CPU
per character-input of each and its ratio to the lone one's. Interleaved, so a drift in the
machine's speed reaches each alike.
"""

import argparse
import os
import statistics
import sys
import time


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--characters', type=int, default=8)
    parser.add_argument('--inputs', type=int, default=600)
    args = parser.parse_args()
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    import numpy as np
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import JointState

    from jacket_cloth_ros.core.fabric import load_fabrics
    from jacket_cloth_ros.core.rig import load_rig
    from jacket_cloth_ros.core.skeleton import load_shipped_character
    from jacket_cloth_ros.motion.clips import joint_state_content
    from jacket_cloth_ros.ros import cdr
    from jacket_cloth_ros.ros.parameters import default_values
    from jacket_cloth_ros.ros.pipeline import CrowdPipeline, SessionPipeline
    skeleton, fabrics = load_shipped_character(), load_fabrics()
    values = default_values(fabrics['tweed_jacket'])

    def pipeline():
        return SessionPipeline(skeleton, load_rig(skeleton), fabrics, values, timing=False)
    n = args.characters
    ways = {'lone process': None, 'crowd, one name list': CrowdPipeline(1),
            'crowd, a new name list object each message': CrowdPipeline(1),
            'crowd, a list that changes every message': CrowdPipeline(1)}
    lone = pipeline()
    for crowd in list(ways.values())[1:]:
        for _ in range(n):
            crowd.add(pipeline())
    reader = cdr.JointStateReader()

    def by_rclpy(raw):
        """Return a JointState's content as rclpy's deserialisation gives it: new names."""
        msg = deserialize_message(raw, JointState)
        return cdr.JointStateContent(stamp, tuple(msg.name), np.array(msg.position))
    spent = {way: [] for way in ways}
    for k in range(args.inputs):
        names, positions = joint_state_content(skeleton.joint_names, 'walk', k / 120)
        stamp = 10 ** 10 + round(k * 1e9 / 120)
        raw = cdr.joint_state(stamp, names, positions)
        same = reader.read(raw)
        fresh = [by_rclpy(raw) for _ in range(n)]
        turned = (cdr.JointStateContent(stamp, same.name[::-1], same.position[::-1].copy())
                  if k % 2 else same)
        contents = {'crowd, one name list': [same] * n,
                    'crowd, a new name list object each message': fresh,
                    'crowd, a list that changes every message': [turned] * n}
        for way, crowd in ways.items():
            started = time.thread_time_ns()
            if crowd is None:
                lone.on_joint_state(fresh[0], stamp)
            else:
                crowd.on_joint_states(list(enumerate(contents[way])))
            spent[way].append((time.thread_time_ns() - started) / (1 if crowd is None else n))
    first = 20                  # past the first inputs' resets and loads
    alone = statistics.median(spent['lone process'][first:])
    for way, got in spent.items():
        median = statistics.median(got[first:])
        print(f'{way}: {median / 1e3:.1f} us per character-input, {median / alone:.2f}x')
    steady = {way: c.steps.steady_inputs for way, c in ways.items() if c is not None}
    print(f'inputs taken the steady way: {steady}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
