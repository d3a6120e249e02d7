# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""How long an input waits for the recorder's writer thread, at two thread switch intervals.

    python benchmarks/recording_gil.py [--rounds 5] [--seconds 4]

A 120 Hz walk's JointState bytes go through a SessionPipeline back to back, every output
handed to a background SessionRecorder, as a node recording its session does when inputs
queue up. Once a second of stamps the recorder closes a chunk and its writer thread lays it
out in Python, holding the GIL; an input that finishes meanwhile waits for it. Prints, for
CPython's default switch interval and for the one the node's process sets
(``jacket_cloth_ros.ros.node.GIL_SWITCH_S``), the median over the rounds of: an input's
median time, the input right after the first chunk's close, and the worst input after each
later close (ms, wall clock).
"""

import argparse
import os
import statistics
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from rclpy.serialization import serialize_message  # noqa: E402

from jacket_cloth_ros.core.fabric import load_fabrics  # noqa: E402
from jacket_cloth_ros.core.rig import load_rig  # noqa: E402
from jacket_cloth_ros.core.skeleton import load_shipped_character  # noqa: E402
from jacket_cloth_ros.motion.messages import clip_messages  # noqa: E402
from jacket_cloth_ros.recording.writer import SessionRecorder  # noqa: E402
from jacket_cloth_ros.ros.node import GIL_SWITCH_S  # noqa: E402
from jacket_cloth_ros.ros.pipeline import SessionPipeline, session_topics  # noqa: E402
from jacket_cloth_ros.ros.values import default_values  # noqa: E402

RATE = 120.0


def one_round(skeleton, rig, values, raws, folder):
    """Feed ``raws`` through a new pipeline and recorder; each input's wall time (ms)."""
    pipeline = SessionPipeline(skeleton, rig, values, timing=False)
    path = os.path.join(folder, 'gil.mcap')
    if os.path.exists(path):
        os.remove(path)
    recorder = SessionRecorder(path, background=True)
    topics = session_topics()
    for name, kind, qos in topics.values():
        recorder.add_topic(name, kind, qos)
    took = []
    try:
        for raw in raws:
            started = time.perf_counter()
            report, outputs = pipeline.on_raw(raw)
            recorder.write(topics['joint_states'][0], raw, report.stamp_ns)
            for key, data in outputs:
                recorder.write(topics[key][0], data, report.stamp_ns)
            took.append((time.perf_counter() - started) * 1e3)
    finally:
        recorder.close()
    return took


def main(argv=None):
    """Time the inputs at both intervals, in turns, and print the medians."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--rounds', type=int, default=5)
    parser.add_argument('--seconds', type=float, default=4.0)
    args = parser.parse_args(argv)
    skeleton = load_shipped_character()
    rig, values = load_rig(skeleton), default_values(load_fabrics()['tweed_jacket'])
    raws = [bytes(serialize_message(m))
            for _, m in clip_messages(skeleton, 'walk', RATE, args.seconds, 10 ** 10)]
    per_second = int(RATE)
    default = sys.getswitchinterval()
    figures = {default: [], GIL_SWITCH_S: []}
    with tempfile.TemporaryDirectory() as folder:
        for _ in range(args.rounds):
            for interval in figures:
                sys.setswitchinterval(interval)
                took = one_round(skeleton, rig, values, raws, folder)
                later = [max(took[k:k + 3]) for k in range(2 * per_second + 1, len(took),
                                                           per_second)]
                figures[interval].append((statistics.median(took[2:]),
                                          max(took[per_second + 1:per_second + 4]),
                                          max(later)))
        sys.setswitchinterval(default)
    print(f'A {RATE:g} Hz walk of {args.seconds:g} s, back to back, recorded; median of '
          f'{args.rounds} rounds (ms):')
    print(f'  {"switch interval":>16s} {"an input":>9s} {"after the 1st chunk":>20s} '
          f'{"worst after a later one":>24s}')
    for interval, rows in figures.items():
        median = [statistics.median(column) for column in zip(*rows)]
        print(f'  {interval * 1e3:13.1f} ms {median[0]:9.2f} {median[1]:20.2f} {median[2]:24.2f}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
