# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Where the time of one input goes: the replay's and the node's per-input path, in stages.

Part of ``bench speed`` (issue 37 item 1). A walk at 60 Hz JointState (two 120 Hz steps each)
runs through the live node's :class:`SessionPipeline` in this process, as ``replay`` runs it,
with a timer around each stage (the pipeline's ``stage_timer``, which wraps them in that
pipeline alone; the decode, record, take and publish timers are the profile's own):

- decode: the JointState's CDR read (``cdr.JointStateReader``) of an input that is not
  steady; a steady one is read within its step;
- prepare: the simulation's work before its compiled steps (stamp checks, joint sampling,
  the level of detail);
- step: the compiled steps (``physics.step.advance``: pose, colliders, cloth, hard passes);
  for a steady input the one call from its bytes to its /tf (``ros/steady_lane.py``);
- complete: taking the steps' outcome into the simulation;
- bones: the jacket and hood bones from the cloth;
- tf: /tf encoded (a steady input's is laid out within its step);
- markers, diagnostics: those messages encoded, when due;
- record: handing every message to the MCAP recorder, as the node and the replay record
  (their ``record_compression``; each closed chunk laid out, compressed and written by a
  writer thread, whose CPU is given apart);
- take, publish (the node only): each JointState taken from a subscription as the node
  takes it, and each output handed to rclpy as serialized bytes, on a real DDS context in
  this process (the inputs are sent before the run, so a take never waits).

Shares are of the main thread's CPU per input; ``other`` is what no stage timer covers (the
pipeline's accounting between stages). Each timer adds its own small cost to its stage.

``bench speed`` times the bare kernel just before and after each profile, as it does beside
each replay (``speed.beside_kernel``; wall time of back-to-back steps, where the stages are the
thread's CPU), so the summary can say how far the simulation alone, with no output at all, is
from the kernel-only limit: a bound on what any replay with these stages can reach.
"""

import functools
import os
import tempfile
import time
from typing import Callable, Dict, List

from jacket_cloth_lab import lab_domain
from jacket_cloth_ros.core.skeleton import Skeleton

INPUT_RATE = 60.0
STAGES = ('take', 'decode', 'prepare', 'step', 'complete', 'bones', 'tf', 'markers', 'diagnostics',
          'record', 'publish')
NODE_ONLY = ('take', 'publish')


class StageClock:
    """Thread CPU time per named stage, summed over the inputs of a run."""

    def __init__(self) -> None:
        self.ns: Dict[str, int] = {name: 0 for name in STAGES}

    def wrap(self, name: str, function: Callable) -> Callable:
        """Return ``function`` with its thread CPU time added to stage ``name``.

        :param name: one of :data:`STAGES`.
        :param function: the callable to time.
        :returns: the timed callable, taking and returning what ``function`` does.
        """
        @functools.wraps(function)
        def timed(*args, **kwargs):
            started = time.thread_time_ns()
            try:
                return function(*args, **kwargs)
            finally:
                self.ns[name] = self.ns.get(name, 0) + time.thread_time_ns() - started
        return timed


def per_input_profile(skeleton: Skeleton, seconds: float = 15.0, node: bool = False,
                      overrides: Dict | None = None, record: bool = True,
                      stages: bool = True) -> Dict:
    """Run a walk through the pipeline with stage timers; return CPU per input by stage.

    :param skeleton: the character (its rig is the shipped proposal, its fabric the default).
    :param seconds: the session's length; the first half second (resets, first loads) is run
        but not counted.
    :param node: add the node's rclpy take and publish (DDS in this process, own domain).
    :param overrides: node parameters to set over the defaults (e.g. ``markers_rate``).
    :param record: record the session (inputs and outputs), as the node's ``record`` does.
    :param stages: put the stage timers in; False: the pipeline runs as the replay and the
        node run it, only the node's publish timed (the figure it is set apart by), and
        ``us`` holds the node's ``take`` and ``publish`` and ``other``, all the rest: the
        main thread without the timers' own cost, which the kernel-only limit is judged on.
    :returns: ``{'inputs', 'us_per_input', 'us': {stage: us per input}, 'share': {stage:
        share of the main thread}, 'writer_thread_us' (the process's other threads: the
        recorder's writer thread, and the node's DDS), 'markers_publish_us' (of 'publish'),
        'markers_skinning_us' (of 'markers': the jacket skinned, shaded and laid out),
        'sweeps_per_input',
        'substeps_per_input', 'steps_per_input'}`` (``bench speed`` adds
        ``kernel_step_us``, the bare kernel's step timed beside the run).
    """
    from jacket_cloth_ros.core.fabric import load_fabrics
    from jacket_cloth_ros.core.rig import load_rig
    from jacket_cloth_ros.motion.clips import joint_state_content
    from jacket_cloth_ros.recording.writer import SessionRecorder
    from jacket_cloth_ros.ros import cdr
    from jacket_cloth_ros.ros.values import default_values
    from jacket_cloth_ros.ros.pipeline import SessionPipeline, session_topics
    fabrics = load_fabrics()
    values = default_values(fabrics['tweed_jacket']).with_changes(overrides or {})
    clock = StageClock()
    # The markers' share of publishing and their skinning (within the markers stage), timed
    # again apart (markers_cost).
    markers_clock = StageClock()

    def stage_timer(name, function):
        return (markers_clock if name == 'skinning' else clock).wrap(name, function)
    pipeline = SessionPipeline(skeleton, load_rig(skeleton), values, timing=False,
                               stage_timer=stage_timer if stages else None)
    if stages:
        # As the replay reads them (SessionPipeline.on_raw): a steady input decoded, stepped
        # and its /tf laid out in one compiled call, timed as the step; any other read first.
        pipeline.reader.read = clock.wrap('decode', pipeline.reader.read)
    raws = []
    for k in range(int(seconds * INPUT_RATE)):
        names, positions = joint_state_content(skeleton.joint_names, 'walk', k / INPUT_RATE)
        raws.append(cdr.joint_state(10 ** 10 + round(k * 1e9 / INPUT_RATE), names, positions))
    skip = int(0.5 * INPUT_RATE)
    topics = session_topics()
    ros = _NodeIO(raws, clock) if node else None
    sweeps = substeps = 0
    try:
        with tempfile.TemporaryDirectory() as tmp:
            recorder = SessionRecorder(os.path.join(tmp, 'profile.mcap'), background=True,
                                       compression=values.record_compression)
            for name, kind, qos in topics.values():
                recorder.add_topic(name, kind, qos)
            write = recorder.write if record else _no_write
            write = clock.wrap('record', write) if stages else write
            publish = clock.wrap('publish', ros.publish) if ros else None
            publish_markers = markers_clock.wrap('publish', publish) if ros and stages \
                else publish
            for k, raw in enumerate(raws):
                if k == skip:
                    for name in clock.ns:
                        clock.ns[name] = 0 if name != 'take' else ros.take_ns(skip) if ros else 0
                    markers_clock.ns.update(publish=0, skinning=0)
                    started, cpu = time.thread_time_ns(), time.process_time_ns()
                    sweeps = substeps = 0
                if ros:
                    raw = ros.taken[k]
                report, outputs = pipeline.on_raw(raw)
                sweeps += report.sweeps
                substeps += report.substeps
                write(topics['joint_states'][0], raw, report.stamp_ns)
                for key, data in outputs:
                    write(topics[key][0], data, report.stamp_ns)
                    if publish:
                        (publish_markers if key == 'markers' else publish)(key, data)
            main_ns = time.thread_time_ns() - started
            recorder.close()
            all_ns = time.process_time_ns() - cpu
    finally:
        if ros:
            ros.close()
    counted = len(raws) - skip
    us = {name: ns / counted / 1e3 for name, ns in clock.ns.items()
          if (node or name not in NODE_ONLY) and (stages or name in NODE_ONLY)}
    total = main_ns / counted / 1e3 + us.get('take', 0.0)     # the takes ran before the run
    us['other'] = max(total - sum(us.values()), 0.0)
    return {'inputs': counted, 'node': node, 'us_per_input': total, 'us': us,
            'share': {name: v / total for name, v in us.items()},
            'writer_thread_us': max(all_ns - main_ns, 0) / counted / 1e3,
            'markers_publish_us': markers_clock.ns['publish'] / counted / 1e3,
            'markers_skinning_us': markers_clock.ns.get('skinning', 0) / counted / 1e3,
            'sweeps_per_input': sweeps / counted, 'substeps_per_input': substeps / counted,
            'steps_per_input': values.sim.sim_rate / INPUT_RATE}


def _no_write(*_: object) -> None:
    """Record nothing (a node without ``record``)."""


class _NodeIO:
    """The node's side of DDS for the profile: inputs taken from a subscription, outputs sent.

    Every input is published and taken before the run, each take timed alone, so the run
    reads them from memory and a take never waits for DDS.
    """

    def __init__(self, raws: List[bytes], clock: StageClock) -> None:
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from rclpy.qos import QoSProfile
        from sensor_msgs.msg import JointState
        from tf2_msgs.msg import TFMessage
        from visualization_msgs.msg import MarkerArray
        self._context = rclpy.Context()
        rclpy.init(context=self._context, domain_id=lab_domain('profile'))
        self._node = rclpy.create_node('profile', context=self._context)
        qos = QoSProfile(depth=len(raws))
        source = self._node.create_publisher(JointState, 'profile_joint_states', qos)
        sub = self._node.create_subscription(JointState, 'profile_joint_states',
                                             lambda _: None, qos, raw=True)
        kinds = {'tf': TFMessage, 'markers': MarkerArray, 'diagnostics': DiagnosticArray}
        self._out = {key: self._node.create_publisher(kind, 'profile_' + key, QoSProfile(depth=10))
                     for key, kind in kinds.items()}
        _wait(lambda: source.get_subscription_count() > 0, 'the profile\'s own subscription')
        for raw in raws:
            source.publish(raw)
        self.taken: List[bytes] = []
        self._take_ns: List[int] = []
        take = sub.handle.take_message

        def one():
            started = time.thread_time_ns()
            got = take(JointState, True)
            if got is not None:
                self._take_ns.append(time.thread_time_ns() - started)
                self.taken.append(got[0])
            return len(self.taken) == len(raws)
        _wait(one, 'every input back from DDS')

    def take_ns(self, skip: int) -> int:
        """Return the CPU of the takes from input ``skip`` on, in ns.

        :param skip: the inputs not counted (the run's warm-up).
        """
        return sum(self._take_ns[skip:])

    def publish(self, key: str, data: bytes) -> None:
        """Publish one output's CDR bytes as the node does.

        :param key: ``tf``, ``markers`` or ``diagnostics``.
        :param data: the message's CDR bytes.
        """
        self._out[key].publish(data)

    def close(self) -> None:
        """Destroy the node and shut its context down."""
        self._node.destroy_node()
        self._context.try_shutdown()


def _wait(done: Callable[[], bool], what: str, limit_s: float = 30.0) -> None:
    """Poll ``done`` until it holds; raise naming ``what`` after ``limit_s`` seconds."""
    deadline = time.monotonic() + limit_s
    while not done():
        if time.monotonic() > deadline:
            raise RuntimeError(f'profile: no {what} in {limit_s:.0f} s')
        time.sleep(0.001)


def summary(profiles: List[Dict]) -> List[str]:
    """Return markdown lines: one column of CPU and shares per profile.

    :param profiles: :func:`per_input_profile` results (the replay's, the node's).
    """
    names = [n for n in STAGES + ('other',) if any(n in p['us'] for p in profiles)]
    head = ' | '.join(f'{"node" if p["node"] else "replay"} us | share' for p in profiles)
    lines = ['Where one input\'s CPU goes (main thread; a 60 Hz walk, two 120 Hz steps per '
             'input):', '', f'| stage | {head} |', '|---|' + '---|---|' * len(profiles)]
    for name in names:
        cells = ' | '.join(f'{p["us"].get(name, 0.0):.1f} | {p["share"].get(name, 0.0):.0%}'
                           for p in profiles)
        lines.append(f'| {name} | {cells} |')
    cells = ' | '.join(f'{p["us_per_input"]:.1f} | 100%' for p in profiles)
    lines.append(f'| all | {cells} |')
    p = profiles[0]
    lines += ['', f'The recorder\'s writer thread: {p["writer_thread_us"]:.1f} us per input '
              f'more. Per input: {p["substeps_per_input"]:.1f} substeps, '
              f'{p["sweeps_per_input"]:.1f} sweeps.']
    return lines + limit_lines(p) + [line for node in profiles[1:]
                                     for line in _untimed_line(node)]


# The stages a replay with no output at all would still run for each input.
SIMULATION_ONLY = ('decode', 'prepare', 'step', 'complete')
# The main thread's share of the kernel-only limit each path is to reach, without the stage
# timers: the replay's whole, the node's less rclpy's take and publish (issue 49).
MAIN_THREAD_AT_LEAST = {False: 0.55, True: 0.5}


def main_thread_share(p: Dict) -> tuple[float, float, float] | None:
    """Return the kernel-only limit over the main thread's CPU per input, without the timers.

    The node's main thread less rclpy's take and publish, which no change of the package moves.

    :param p: a :func:`per_input_profile` result as ``bench speed`` keeps it, with ``untimed``.
    :returns: (share, limit us, main thread us), or None for a run without the untimed pass.
    """
    u = p.get('untimed')
    if not u:
        return None
    limit = u['kernel_step_us'] * p['steps_per_input']
    main = u['us_per_input'] - u['us'].get('take', 0.0) - u['us'].get('publish', 0.0)
    return limit / main, limit, main


def limit_lines(p: Dict) -> List[str]:
    """Return the lines setting a profile against its kernel-only limit.

    Shares as item 2 counts the replay's: the limit's time over the time taken, so 0.8 is
    item 2's bar for a whole replay.

    :param p: a :func:`per_input_profile` result, with ``kernel_step_us``.
    :returns: a blank line and the text; none for a run from before the kernel was timed
        beside the profile.
    """
    if 'kernel_step_us' not in p:
        return []
    limit = p['kernel_step_us'] * p['steps_per_input']
    alone = sum(p['us'][name] for name in SIMULATION_ONLY)
    return ['', f'The kernel-only limit beside this run: {limit:.1f} us per input (the bare '
            f'kernel\'s {p["kernel_step_us"]:.1f} us step, {p["steps_per_input"]:g} an '
            f'input). The step stage alone costs {p["us"]["step"] / limit:.2f}x it; a replay '
            f'doing only decode to complete (the simulation with no output) would be at '
            f'{limit / alone:.2f} of the limit, the whole main thread is at '
            f'{limit / p["us_per_input"]:.2f}.'] + _untimed_line(p)


def _untimed_line(p):
    share = main_thread_share(p)
    if share is None:
        return []
    return ['', f'Without the stage timers (the same walk again, between two more rounds of '
            f'the kernel): the main thread{" less take and publish" if p["node"] else ""} '
            f'{share[2]:.1f} us per input, {share[0]:.2f} of its limit ({share[1]:.1f} us).']
