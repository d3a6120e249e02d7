# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The crowd part of ``bench speed``: a crowd node against one node process per character.

Everything runs live over DDS on this machine, driven by one JointState stream at 120 Hz
that every character hears (the crowd's characters remapped onto it), so both sides do the
same work per tick; the driver only publishes and reads ``/diagnostics``:

- held: the most characters that one core (the processes pinned to core 0, the driver to
  another) and all cores hold, each character's latency p99 (its diagnostics: arrival to
  /tf handed to DDS, per 1 s window) under one step (8.33 ms) and every input answered;
  for the crowd node (jacket_cloth_crowd) and for single-character node processes;
- cost: CPU per character per input against N, and memory per character, for both;
- tf: one TFMessage for the crowd's characters against one per character (encode and
  publish, in this process), which the node's choice rests on;
- intake: a crowd character's input, taken each way a JointState can arrive, against a lone
  simulation's ``process`` (``crowd_intake``), in this process;
- floor: how many characters the crowd's floor (floor_node --crowd, the least a crowd node
  of this design does) holds on one core: the ceiling for the crowd's one-core figure.
"""

import os
import subprocess
import sys
import tempfile
import time
from typing import Callable, Sequence

import numpy as np

from jacket_cloth_lab import crowd_intake, lab_domain
from jacket_cloth_lab.proc import cpu_seconds
from jacket_cloth_ros.core.skeleton import Skeleton, shipped_character_urdf

RATE = 120.0
STEP_US = 1e6 / RATE
COUNTS = (1, 4, 16, 64, 256)               # cost per character against N
CROWD_LADDER = (4, 8, 12, 16, 20, 24, 28, 32, 40, 48, 56, 64, 72, 80, 88, 96, 112, 128, 192, 256)
SINGLE_LADDER = (1, 2, 4, 8, 16, 32)


def _rss_mb(pid):
    try:
        with open(f'/proc/{pid}/status', encoding='ascii') as f:
            for line in f:
                if line.startswith('VmRSS:'):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return float('nan')


def crowd_command(n: int, folder: str, threads: int, name: str = 'c') -> list[str]:
    """Return the argv of a crowd node, all its characters hearing /joint_states.

    :param n: how many characters.
    :param folder: where its characters file is written.
    :param threads: the crowd's threads.
    :param name: the characters' name (``<name>_<k>``) and the node's suffix.
    """
    path = os.path.join(folder, f'crowd_{name}_{n}.yaml')
    with open(path, 'w', encoding='utf-8') as f:
        f.write(f'characters:\n  - name: {name}\n    count: {n}\n    urdf: character.urdf\n')
    names = [name] if n == 1 else [f'{name}_{k}' for k in range(n)]     # as characters.py
    remaps = [a for each in names for a in ('-r', f'/{each}/joint_states:=/joint_states')]
    return [sys.executable, '-m', 'jacket_cloth_ros.ros.crowd', '--ros-args', '-r',
            f'__node:=jacket_cloth_crowd_{name}', '-p', f'characters:={path}', '-p',
            f'threads:={threads}'] + remaps


def floor_command(n: int) -> list[str]:
    """Return the argv of the crowd's floor (floor_node --crowd).

    :param n: how many characters.
    """
    return [sys.executable, '-m', 'jacket_cloth_lab.floor_node', '--crowd', str(n), '--kernel']


def single_commands(n: int) -> list[list[str]]:
    """Return the argv of single-character nodes (the ROS default), one per character.

    :param n: how many characters.
    """
    return [[sys.executable, '-m', 'jacket_cloth_ros.ros.node', '--ros-args', '-r',
             f'__node:=jacket_cloth_node_{k}', '-p', f'frame_prefix:=s{k}/'] for k in range(n)]


def endless_walk(skeleton: Skeleton) -> tuple[list, tuple[int, list[float]], float]:
    """Return the walk clip's JointStates, and how to walk on past its end without a teleport.

    The clip's root jumps back to its start every loop, which made every character of a crowd
    reset at once each 4 s.

    :param skeleton: the character whose joints the messages name.
    :returns: (messages of one loop, (index of world_joint/trans_x, its values), x to add per
        loop, metres).
    """
    from jacket_cloth_ros.motion.messages import clip_messages
    walk = [m for _, m in clip_messages(skeleton, 'walk', RATE, 4.0, 10 ** 10)][:-1]
    i = list(walk[0].name).index('world_joint/trans_x')
    x = [m.position[i] for m in walk]
    return walk, (i, x), (x[-1] - x[0]) * len(x) / (len(x) - 1)


def live(skeleton: Skeleton, commands: Sequence[list[str]], characters: int, seconds: float,
         domain: int, cores: set[int] | None = None, start_limit_s: float = 120.0,
         cores_each: Sequence[set[int]] | None = None) -> dict:
    """Drive node processes with one JointState stream at RATE; say if the characters hold.

    :param skeleton: the character the stream moves.
    :param commands: the processes' argv lists, started at once; the driver runs on the
        cores they are not pinned to.
    :param characters: how many diagnostics statuses to wait for.
    :param seconds: how long to measure, after the start and a warm-up.
    :param domain: the ROS domain id the run has to itself.
    :param cores: the cores every process is pinned to; None: not pinned.
    :param start_limit_s: how long the characters may take to start answering.
    :param cores_each: a set of cores per process, instead of ``cores``.
    :returns: {held, latency_us_p99 (worst window of any character), answered (worst share
        of the inputs a character took), cpu_us (per character per input),
        rss_mb_per_character, sent}.
    """
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    from jacket_cloth_ros.ros.character import LATCHED
    if cores_each:
        cores = set().union(*cores_each)
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST',
               NUMBA_NUM_THREADS=str(len(cores) if cores else os.cpu_count()))
    all_cores = set(range(os.cpu_count()))
    mine = (all_cores - set(cores)) or all_cores if cores else all_cores
    os.sched_setaffinity(0, mine)
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=domain)
    node = rclpy.create_node('jacket_cloth_crowd_driver', context=ctx)
    windows = {}                    # status -> [(latency p99, inputs so far)]

    def on_diag(msg):
        for s in msg.status:
            values = {kv.key: kv.value for kv in s.values}
            if 'latency_us_p99' in values:
                windows.setdefault(s.name, []).append(
                    (float(values['latency_us_p99']), int(values['inputs']),
                     msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9))
    node.create_subscription(DiagnosticArray, '/diagnostics', on_diag, 1000)
    pub = node.create_publisher(JointState, 'joint_states',
                                QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE))
    node.create_publisher(String, '/robot_description', LATCHED).publish(
        String(data=shipped_character_urdf()))
    walk, along_x, loop_x = endless_walk(skeleton)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    sent = [0]

    def send_for(duration, until=lambda: False):
        t0 = time.monotonic()
        j = 0
        while time.monotonic() - t0 < duration and not until():
            loop, frame = divmod(sent[0], len(walk))
            msg = walk[frame]
            msg.position[along_x[0]] = along_x[1][frame] + loop * loop_x
            stamp = 10 ** 10 + int(round(sent[0] / RATE * 1e9))
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp, 10 ** 9)
            if pub.get_subscription_count():
                pub.publish(msg)
                sent[0] += 1
            j += 1
            while True:
                left = t0 + j / RATE - time.monotonic()
                if left <= 0:
                    break
                ex.spin_once(timeout_sec=left)

    def pinned(own):
        def pin():
            if own:
                os.sched_setaffinity(0, own)
        return pin
    own = cores_each or [cores] * len(commands)
    procs = []
    try:
        for argv, c in zip(commands, own):      # in the try: a failed start stops the others
            procs.append(subprocess.Popen(
                argv, env=dict(env, NUMBA_NUM_THREADS=str(len(c or all_cores))),
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, preexec_fn=pinned(c)))
        send_for(start_limit_s, until=lambda: len(windows) >= characters)
        if len(windows) < characters:
            raise NotAnswering(f'{len(windows)} of {characters} characters answered within '
                               f'{start_limit_s:g} s')
        send_for(1.5)                                   # warm-up, past the first windows
        first = {k: len(v) for k, v in windows.items()}
        cpu0 = sum(cpu_seconds(p.pid) for p in procs)
        sent0 = sent[0]
        send_for(seconds)
        cpu1 = sum(cpu_seconds(p.pid) for p in procs)
        rss = sum(_rss_mb(p.pid) for p in procs)
        n = sent[0] - sent0
        end = time.monotonic() + 1.2
        while time.monotonic() < end:
            ex.spin_once(timeout_sec=0.05)
    finally:
        from .speed import stop_processes      # speed imports this module
        stop_processes(procs)
        ex.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=ctx)
        os.sched_setaffinity(0, all_cores)
    worst, answered = 0.0, 1.0
    for name, w in windows.items():
        measured = w[first.get(name, 0):]
        if len(measured) < 2:
            answered = 0.0
            continue
        worst = max(worst, max(lat for lat, _, _ in measured[1:]))
        span = (measured[-1][2] - measured[0][2]) * RATE        # inputs sent in between
        answered = min(answered, (measured[-1][1] - measured[0][1]) / max(span, 1.0))
    return {'held': worst <= STEP_US and answered >= 0.95, 'latency_us_p99': worst,
            'answered': min(answered, 1.0), 'cpu_us': (cpu1 - cpu0) / max(1, n * characters) * 1e6,
            'rss_mb_per_character': rss / characters, 'sent': n}


def tf_batching(n: int = 64, repeat: int = 200) -> dict:
    """Time /tf for many characters: one TFMessage each against one for all (CPU us per tick).

    Encode (the templates the node uses) and publish, to a subscriber in this process.

    :param n: how many characters.
    :param repeat: how many ticks timed; the medians are reported.
    """
    import rclpy
    from tf2_msgs.msg import TFMessage

    from jacket_cloth_ros.ros.cdr import TfTemplate
    from jacket_cloth_ros.ros.character import TF_QOS
    bones = 68
    names = [f'jacket_bone_{i:02d}' for i in range(bones)]
    poses = np.tile([0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0], (bones, 1))
    each = [TfTemplate(names, ['spine'] * bones, f'c{k}/') for k in range(n)]
    crowd = TfTemplate([f'c{k}/{b}' for k in range(n) for b in names], ['spine'] * bones * n)
    all_poses = np.tile(poses, (n, 1))
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=lab_domain('tf_batching'))
    node = rclpy.create_node('tf_batching', context=ctx)
    pub = node.create_publisher(TFMessage, '/tf', TF_QOS)
    node.create_subscription(TFMessage, '/tf', lambda m: None, TF_QOS, raw=True)
    try:
        per, one = [], []
        for r in range(repeat):
            t0 = time.thread_time_ns()
            for k, template in enumerate(each):
                pub.publish(template.encode(poses, r))
            t1 = time.thread_time_ns()
            pub.publish(crowd.encode(all_poses, r))
            t2 = time.thread_time_ns()
            per.append(t1 - t0)
            one.append(t2 - t1)
    finally:
        node.destroy_node()
        rclpy.shutdown(context=ctx)
    per_us, one_us = np.median(per) * 1e-3, np.median(one) * 1e-3
    return {'characters': n, 'per_character_us': float(per_us), 'one_message_us': float(one_us),
            'ratio': float(per_us / one_us), 'one_message_bytes': len(crowd.encode(all_poses, 0))}


class NotAnswering(RuntimeError):
    """Some characters never answered: their processes did not start in time."""


def _ladder(measure, ladder):
    """Measure up the ladder until a count is not held; returns (most held, rows).

    A count whose characters do not all start answering is not held either: a run lost all
    its figures to that once, 16 single-node processes on two cores.
    """
    rows, best = [], 0
    for n in ladder:
        try:
            row = dict(measure(n), characters=n)
        except NotAnswering as e:
            row = {'characters': n, 'held': False, 'not_answering': str(e)}
        rows.append(row)
        if not row['held']:
            break
        best = n
    return best, rows


def crowd_bench(skeleton: Skeleton, quick: bool = False, seconds: float | None = None,
                say: Callable[[str], None] = print) -> dict:
    """Run the crowd part; returns its figures (see the module's docstring).

    :param skeleton: the shipped character.
    :param quick: whether the quick mode: the costs at 1 and 4 characters, no ladders.
    :param seconds: how long each count is measured; None: 2.5 s quick, else 4 s.
    :param say: called with a line of text as each part starts.
    """
    # At least two diagnostics windows (about 1 s apart) after the warm-up, whatever their
    # phase: 1.5 s gave one now and then, and a run with one window counts as not answering.
    seconds = seconds or (2.5 if quick else 4.0)
    domain = lab_domain('crowd')
    one, every = {0}, set(range(os.cpu_count()))
    out = {'quick': quick, 'cores': os.cpu_count()}
    with tempfile.TemporaryDirectory() as tmp:
        def crowd(n, cores):
            return live(skeleton, [crowd_command(n, tmp, len(cores))], n, seconds, domain,
                        cores)

        def singles(n, cores):
            return live(skeleton, single_commands(n), n, seconds, domain, cores)

        def per_core(n):
            usable = sorted(os.sched_getaffinity(0))[:n]     # a cpuset may hide some cores
            k = len(usable)
            shares = [n * (i + 1) // k - n * i // k for i in range(k)]
            commands = [crowd_command(m, tmp, 1, name=f'p{i}') for i, m in enumerate(shares)]
            return live(skeleton, commands, n, seconds, domain,
                        cores_each=[{c} for c in usable])
        counts = (1, 4) if quick else COUNTS
        say('crowd: cost per character against N (one core)')
        out['cost'] = [dict(crowd(n, one), characters=n) for n in counts]
        say('crowd: one single-character node process per character (one core)')
        single_counts = (1,) if quick else (1, 4)
        out['single_cost'] = [dict(singles(n, one), characters=n) for n in single_counts]
        out['tf'] = tf_batching(8 if quick else 64, 50 if quick else 300)
        say('crowd: a character\'s input against a lone process')
        out['intake'] = crowd_intake.intake_vs_process(
            skeleton, 2 if quick else 8, 60 if quick else 600)
        if not quick:
            for label, cores in (('one_core', one), ('all_cores', every)):
                say(f'crowd: characters held on {label.replace("_", " ")}')
                out[f'crowd_{label}'] = _ladder(lambda n: crowd(n, cores), CROWD_LADDER)
                say(f'single nodes: characters held on {label.replace("_", " ")}')
                out[f'single_{label}'] = _ladder(lambda n: singles(n, cores), SINGLE_LADDER)
            # What this stack allows: the least a node does per character and input, the
            # crowd's own take of the messages and the crowd core's steps included.
            say('crowd floor: characters held on one core')
            out['floor_one_core'] = _ladder(
                lambda n: live(skeleton, [floor_command(n)], n, seconds, domain, one),
                CROWD_LADDER)
            # Item 4's answer on one machine: K crowd processes, one per core, each its share.
            say('crowd: characters held by one crowd process per core')
            out['crowd_per_core'] = _ladder(lambda n: per_core(n), CROWD_LADDER)
    single = out['single_cost'][0]
    out['cost_ratio'] = {r['characters']: r['cpu_us'] / single['cpu_us'] for r in out['cost']}
    return out


def summary(c: dict) -> list[str]:
    """Markdown lines of the crowd part.

    :param c: what :func:`crowd_bench` returned.
    """
    single = c['single_cost'][0]
    lines = ['## Crowd: many characters in one node (jacket_cloth_crowd)', '',
             'One 120 Hz JointState stream that every character hears; processes pinned to one '
             'core unless said; figures from one run.', '',
             '| characters | crowd CPU us per character-input | / single node | latency p99 '
             'us (worst window) | answered | RSS MB per character |', '|---|---|---|---|---|---|']
    for r in c['cost']:
        lines.append(f'| {r["characters"]} | {r["cpu_us"]:.0f} | '
                     f'{r["cpu_us"] / single["cpu_us"]:.2f}x | {r["latency_us_p99"]:.0f} | '
                     f'{r["answered"]:.2f} | {r["rss_mb_per_character"]:.1f} |')
    for r in c['single_cost']:
        lines.append(f'| {r["characters"]} single-node process(es) | {r["cpu_us"]:.0f} | 1x | '
                     f'{r["latency_us_p99"]:.0f} | {r["answered"]:.2f} | '
                     f'{r["rss_mb_per_character"]:.1f} |')
    if 'crowd_one_core' in c:
        co, ca = c['crowd_one_core'][0], c['crowd_all_cores'][0]
        so, sa = c['single_one_core'][0], c['single_all_cores'][0]
        lines += ['', f'Characters held at 120 Hz (every character\'s latency p99 under one '
                  f'step, {STEP_US:.0f} us, every input answered): crowd node {co} on one core, '
                  f'{ca} on all {c["cores"]} ({ca / max(co, 1):.2f}x); single-character node '
                  f'processes {so} on one core, {sa} on all cores. Ladders: crowd '
                  f'{", ".join(str(r["characters"]) for r in c["crowd_one_core"][1])}; '
                  f'single {", ".join(str(r["characters"]) for r in c["single_one_core"][1])} '
                  '(each stops at the first count not held).']
    if 'floor_one_core' in c:
        fo, co = c['floor_one_core'][0], c['crowd_one_core'][0]
        lines += ['', f'The crowd\'s floor (floor_node --crowd: the same take of the messages, '
                  f'the crowd core\'s steps and a pre-built /tf per character and input, '
                  f'nothing else of the node) held {fo} on one core, the crowd node {co}.']
    if 'crowd_per_core' in c:
        pc = c['crowd_per_core'][0]
        co = c['crowd_one_core'][0]
        lines += ['', f'One crowd process per core ({c["cores"]}, each one thread and its '
                  f'share of the characters): {pc} held ({pc / max(co, 1):.2f}x one crowd on '
                  'one core).']
    lines += [''] + crowd_intake.summary(c['intake'])
    t = c['tf']
    lines += ['', f'/tf for {t["characters"]} characters per tick: one TFMessage each '
              f'{t["per_character_us"]:.0f} us, one for all {t["one_message_us"]:.0f} us '
              f'({t["ratio"]:.1f}x; {t["one_message_bytes"] / 1024:.0f} KiB).']
    return lines


def chart(c: dict, path: str) -> None:
    """Cost per character against N (log-log), the single node's as a line.

    :param c: what :func:`crowd_bench` returned.
    :param path: the PNG file.
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 3.6))
    n = [r['characters'] for r in c['cost']]
    ax.plot(n, [r['cpu_us'] for r in c['cost']], 'o-', label='crowd node, per character')
    single = c['single_cost'][0]['cpu_us']
    ax.axhline(single, color='C1', ls='--', label='one node process per character')
    ax.axhline(single / 3, color='C1', ls=':', label='a third of that (target)')
    ax.set_xscale('log')
    ax.set_yscale('log')
    ax.set_xlabel('characters in the node')
    ax.set_ylabel('CPU us per character per input')
    ax.set_title('cost per character at 120 Hz (one core)', fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


PICTURE = (('npc1', 'walk', 'tweed_jacket', None), ('npc2', 'run', 'down_jacket', None),
           ('npc3', 'dodge', 'veil', None), ('npc4', 'idle', 'tweed_jacket', 'mannequin'),
           ('npc5', 'arms_up', 'down_jacket', None), ('npc6', 'jump', 'tweed_jacket', None))


def crowd_picture(png_path: str, at_s: float = 1.15) -> None:
    """Draw six characters of one crowd (its one compiled call) at one instant, side by side.

    Each its own clip and fabric, one of them on another skeleton (the mannequin example).

    :param png_path: the PNG file.
    :param at_s: the instant drawn, seconds into the clips.
    """
    from jacket_cloth_ros.core.config import shipped
    from jacket_cloth_ros.core.fabric import load_fabrics
    from jacket_cloth_ros.core.rig import load_rig
    from jacket_cloth_ros.motion.clips import joint_state_content
    from jacket_cloth_ros.ros.cdr import JointStateContent
    from jacket_cloth_ros.ros.values import default_values
    from jacket_cloth_ros.ros.pipeline import CrowdPipeline, SessionPipeline
    from jacket_cloth_ros.tools.picture import draw_filmstrip, sim_frame
    fabrics = load_fabrics()
    crowd = CrowdPipeline()
    for name, _, fabric, other in PICTURE:
        if other:
            with open(shipped(f'examples/{other}.urdf'), encoding='utf-8') as f:
                skeleton = Skeleton(f.read())
            rig = load_rig(skeleton, shipped(f'examples/{other}_rig.yaml'))
        else:
            skeleton = Skeleton(shipped_character_urdf())
            rig = load_rig(skeleton)
        crowd.add(SessionPipeline(skeleton, rig, default_values(fabrics[fabric], fabric), name,
                                  timing=False))
    rate, start = 60.0, 10 ** 10
    for k in range(int(at_s * rate) + 1):
        stamp = start + int(round(k / rate * 1e9))
        inputs = []
        for i, (_, clip, _, _) in enumerate(PICTURE):
            sim = crowd.pipelines[i].sim
            names, pos = joint_state_content(sim.skeleton.joint_names, clip, k / rate)
            inputs.append((i, JointStateContent(stamp, tuple(names), np.asarray(pos, float))))
        crowd.on_joint_states(inputs)
    frames = [sim_frame(p.sim, stamp) for p in crowd.pipelines]
    draw_filmstrip(frames, [p.sim.skeleton for p in crowd.pipelines], png_path, start,
                   columns=[f'{n}: {c}, {f.replace("_", " ")}' + (f' ({o})' if o else '')
                            for n, c, f, o in PICTURE],
                   title=f'one crowd node, six characters at t = {at_s:g} s: each its own '
                   'motion, fabric and skeleton, stepped in one compiled call')


if __name__ == '__main__':
    crowd_picture(sys.argv[1] if len(sys.argv) > 1 else 'crowd.png')
