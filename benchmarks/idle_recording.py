# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""What an idle crowd records: its file's growth per hour, with and without repeats recorded.

    python benchmarks/idle_recording.py [--characters 50] [--seconds 20]

Runs a jacket_cloth_crowd node of that many shipped characters in this process, recording,
with no input (a crowd up before its motion source): only the diagnostics watchdog writes, at
``diagnostics_rate`` (1 Hz) of wall time. Twice: as the node records (diagnostics that say
something new), and with every one recorded (each tick's, as before issue 48). Prints the
diagnostics published and recorded, the file's growth over a recording of the set-ups alone,
and, where they grow with time, both scaled to 500 characters for an hour. Run it alone
(real DDS, a domain of its own).
"""

import argparse
import os
import sys
import tempfile
import time


def _run(characters: int, seconds: float, every: bool,
         folder: str) -> tuple[int, int, int, int]:
    """Return (diagnostics published, recorded, their bytes, file bytes) of an idle recording."""
    import rclpy
    from rclpy.context import Context
    from rclpy.parameter import Parameter

    from jacket_cloth_ros.recording.reader import read_messages
    from jacket_cloth_ros.ros.node import JacketClothNode
    crowd = os.path.join(folder, f'crowd_{every}.yaml')
    with open(crowd, 'w', encoding='utf-8') as f:
        f.write(f'characters:\n  - name: idle\n    count: {characters}\n'
                '    urdf: character.urdf\n')
    path = os.path.join(folder, f'idle_{every}_{seconds}.mcap')
    ctx = Context()
    rclpy.init(context=ctx, domain_id=150 + os.getpid() % 50)
    node = JacketClothNode(crowd=True, context=ctx, parameter_overrides=[
        Parameter('characters', value=crowd), Parameter('record', value=path)])
    node.record_repeated_diagnostics = every        # stamps compared too: each tick's is new
    published = [0]
    plain = node.diagnostics.publish
    node.diagnostics.publish = lambda out: (published.__setitem__(0, published[0] + 1),
                                            plain(out))
    executor = rclpy.executors.SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        executor.spin_once(timeout_sec=0.1)
    node.close()
    executor.shutdown()
    node.destroy_node()
    rclpy.shutdown(context=ctx)
    recorded = read_messages(path, ['/diagnostics'])[0]
    return (published[0], len(recorded), sum(len(m.data) for m in recorded),
            os.path.getsize(path))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--characters', type=int, default=50)
    parser.add_argument('--seconds', type=float, default=20.0)
    args = parser.parse_args()
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    # Per hour of 500 characters: the growth over a recording of the set-ups alone.
    scale = 500 / args.characters * 3600 / args.seconds
    with tempfile.TemporaryDirectory() as folder:
        base = _run(args.characters, 0.0, False, folder)[3]
        for every, label in ((False, 'as recorded'), (True, 'every tick')):
            published, recorded, raw, size = _run(args.characters, args.seconds, every, folder)
            print(f'{label}: {args.characters} characters, {args.seconds:g} s: {published} '
                  f'diagnostics published, {recorded} recorded ({raw} bytes of CDR), the file '
                  f'{size - base} bytes over its set-ups')
            if every:           # grows with time; as recorded, one a character and change
                print(f'  {label}, 500 characters for an hour: {raw * scale / 1e6:.0f} MB of '
                      f'CDR, the file {(size - base) * scale / 1e6:.0f} MB')
    return 0


if __name__ == '__main__':
    sys.exit(main())
