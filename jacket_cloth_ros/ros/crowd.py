# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""jacket_cloth_crowd: many characters in one node, their steps in one compiled call.

Each character of the characters file (ros/characters.py) is what a jacket_cloth_node under
its namespace would be: its own ``<name>/joint_states`` in, its bones on ``/tf`` (its frame
prefix), ``<name>/jacket_cloth_node/markers``, its status on ``/diagnostics``, its own resets
and bad-input handling. What it shares is the process: one executor, one DDS participant, one
recording, one ``~/viewer`` (a camera for the whole crowd: each character's level of detail is
by its own distance to it), and one compiled call for the steps of every character with an input
(core/crowd.py), spread over the cores. Each executor wake-up, CrowdInputs takes every
queued message of the characters' subscriptions and the node processes them as one batch in
the same wake-up.
"""

import argparse
import functools
import sys
import time
from typing import TYPE_CHECKING, Callable

import rclpy
from rclpy.callback_groups import CallbackGroup
from rclpy.qos import qos_profile_sensor_data
from rclpy.waitable import NumberOfEntities, Waitable
from rcl_interfaces.msg import ParameterType as T
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from diagnostic_msgs.msg import DiagnosticArray
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from ..core.config import ConfigError, shipped
from ..core.fabric import load_fabrics
from ..core.rig import load_rig
from ..core.skeleton import Skeleton, shipped_character_urdf
from ..recording.writer import SessionRecorder
from . import cdr
from .characters import CharacterSpec, crowd_slice, load_characters
from .node import (LATCHED, NO_PUB_EVENTS, NO_SUB_EVENTS, TF_QOS, JacketNodeBase, _read,
                   input_problems, keep_loaded_out_of_collections, run)
from .pipeline import CrowdPipeline, SessionPipeline, session_topics, spread_phase

if TYPE_CHECKING:           # for the annotations only
    from ..core.simulation import JacketSimulation

# name: (type, default, (lo, hi) or None, read_only, description)
CROWD_PARAMETERS = {
    'characters': (T.PARAMETER_STRING, '', None, True,
                   'the characters file (YAML, see config/crowd.yaml)'),
    'slice_index': (T.PARAMETER_INTEGER, 0, (0, 4095), True,
                    'which slice of the characters this process runs (0 .. slice_count-1)'),
    'slice_count': (T.PARAMETER_INTEGER, 1, (1, 4096), True,
                    'into how many processes the characters are split'),
    'threads': (T.PARAMETER_INTEGER, 0, (0, 256), True,
                'threads for the characters\' steps; 0: one per core (NUMBA_NUM_THREADS)'),
    'record': (T.PARAMETER_STRING, '', None, True,
               'record the whole crowd to this MCAP file (.mcap) or bag folder; empty: off'),
    'record_compression': (T.PARAMETER_STRING, 'lz4', None, True,
                           'MCAP chunk compression: lz4, zstd or none'),
}


class Character:
    """One character of the crowd node: its set-up, and its pipeline once its URDF is known."""

    def __init__(self, spec: CharacterSpec):
        self.spec = spec
        self.index = -1                 # in the crowd's pipeline, once loaded
        self.pipeline = None
        self.viewer = None              # the last ~/viewer in its world frame, for a late load
        self.urdf = None
        self.subscription = None
        self.markers = None             # its ~/markers publisher
        self.description = self.fallback = None
        self.reader = cdr.JointStateReader()
        self.inputs = 0
        self.sequences = {}
        self.log_times = {}
        self.diag_wall = 0.0
        ns = spec.namespace
        self.topics = session_topics(f'{ns}/joint_states', f'{ns}/jacket_cloth_node/wind',
                                     f'{ns}/jacket_cloth_node/markers')

    @property
    def sim(self) -> 'JacketSimulation | None':
        return self.pipeline.sim if self.pipeline else None

    def count_lost(self, info: dict) -> None:
        """Count a gap in a publisher's numbering as lost inputs (as JacketClothNode does)."""
        seq, gid = info.get('publication_sequence_number'), info.get('publisher_gid')
        if not seq or not gid:
            return
        key = gid['data'] if isinstance(gid, dict) else gid
        last = self.sequences.pop(key, None)
        if last is not None and seq > last + 1:
            self.pipeline.note_lost(seq - last - 1)
        self.sequences[key] = seq if last is None else max(seq, last)
        if len(self.sequences) > 64:
            del self.sequences[next(iter(self.sequences))]


class _TakenElsewhere(CallbackGroup):
    """A callback group the executor never runs: CrowdInputs takes its subscriptions' messages."""

    def can_execute(self, entity: object) -> bool:
        return False

    def beginning_execution(self, entity: object) -> bool:
        return False

    def ending_execution(self, entity: object) -> None:
        pass


class CrowdInputs(Waitable):
    """Every character's joint_states subscription, waited on and taken as one entity.

    rclpy's executor makes a task, a handler and a wake-up's bookkeeping per ready
    subscription: in a crowd that was a large share of each character's input
    (docs/crowd.md). Here one wake-up takes every message queued on each ready subscription
    (at most ``DRAIN`` each), in order, and hands them to ``on_inputs`` as [(character, raw
    bytes, message info)]; the subscriptions are in a callback group the executor never runs,
    so it does not take them itself. Taking all of them lets ``on_inputs`` process a backlog
    in the same wake-up instead of a wake-up per queued message.
    """

    DRAIN = 16                      # the sensor-data queue is 5 deep; more only while taking

    def __init__(self, callback_group: CallbackGroup,
                 on_inputs: Callable[[list], None]) -> None:
        super().__init__(callback_group)
        self._on_inputs = on_inputs
        self._subs = []             # (character, subscription handle, its pointer)
        self._ready = []
        self._taken_elsewhere = _TakenElsewhere()

    def subscribe(self, node: 'rclpy.node.Node', character: object, topic: str) -> object:
        """Subscribe ``node`` to ``topic`` (raw JointStates, sensor data QoS) for ``character``.

        The subscription is taken here, never by the executor, and has no QoS event handlers
        (2 per character per wake-up); a publisher with incompatible QoS is still warned on
        its own side. Returns the subscription.
        """
        subscription = node.create_subscription(
            JointState, topic, _never_called, qos_profile_sensor_data, raw=True,
            callback_group=self._taken_elsewhere, event_callbacks=NO_SUB_EVENTS)
        handle = subscription.handle
        self._subs.append((character, handle, handle.pointer))
        return subscription

    def __enter__(self) -> None:
        pass

    def __exit__(self, *exc: object) -> None:
        pass

    def get_num_entities(self) -> NumberOfEntities:
        return NumberOfEntities(len(self._subs))

    def add_to_wait_set(self, wait_set: object) -> None:
        for _, handle, _ in self._subs:
            wait_set.add_subscription(handle)

    def is_ready(self, wait_set: object) -> bool:
        ready = wait_set.get_ready_entities('subscription')
        if ready:
            ready = set(ready)
            self._ready = [(c, h) for c, h, pointer in self._subs if pointer in ready]
        return bool(self._ready)

    def take_data(self) -> list:
        taken = []
        for c, handle in self._ready:
            for _ in range(self.DRAIN):
                got = handle.take_message(JointState, True)
                if got is None:
                    break
                taken.append((c, got[0], got[1]))
        self._ready = []
        return taken

    async def execute(self, taken: list) -> None:
        self._on_inputs(taken)


class JacketCrowdNode(JacketNodeBase):
    """Runs the jacket and hood simulation of every character of a characters file."""

    def __init__(self, **kwargs: object):
        super().__init__('jacket_cloth_crowd', **kwargs)
        for name, spec in CROWD_PARAMETERS.items():
            self._declare(name, spec)
        path = self._p('characters')
        if not path:
            raise ConfigError('parameter characters: give the characters file '
                              '(-p characters:=crowd.yaml)')
        every = load_characters(path)
        mine = crowd_slice(every, self._p('slice_index'), self._p('slice_count'))
        self.characters = [Character(spec) for spec in mine]
        self.crowd = CrowdPipeline(self._p('threads'))
        self.recorder = None
        self._models = {}
        self._last_stamp = None         # the last input's, for recording the viewer after it
        self._log_times = {}            # the crowd's own warnings (each character has its own)
        self.received, self.refused = {'viewer': 0}, {'viewer': 0}
        self._topics = session_topics(viewer=self._subscribe_viewer())
        self.tf = self.create_publisher(TFMessage, '/tf', TF_QOS)
        self.diagnostics = self.create_publisher(DiagnosticArray, '/diagnostics', 10,
                                                 event_callbacks=NO_PUB_EVENTS)
        self._inputs = CrowdInputs(self.default_callback_group, self._on_inputs)
        self.add_waitable(self._inputs)
        self._open_recorder(self._p('record'))
        for c in self.characters:
            if c.spec.urdf:
                try:
                    self._load(c, _read(c.spec.urdf), c.spec.urdf)
                except ConfigError as e:
                    raise ConfigError(f'character {c.spec.name}: {e}') from None
            else:
                c.description = self.create_subscription(
                    String, f'{c.spec.namespace}/robot_description',
                    lambda raw, c=c: self._on_description(c, raw), LATCHED, raw=True)
                c.fallback = self.create_timer(c.spec.values['robot_description_timeout'],
                                               lambda c=c: self._use_shipped(c))
        rate = max((c.spec.values['diagnostics_rate'] for c in self.characters), default=1.0)
        self.create_timer(1.0 / rate, self._diagnostics_watchdog)
        self.get_logger().info(
            f'{len(self.characters)} of {len(every)} characters (slice '
            f'{self._p("slice_index")} of {self._p("slice_count")}), steps on '
            f'{self.crowd.steps.threads} thread(s)')

    # -- characters ---------------------------------------------------------------------------
    def _on_description(self, c, raw):
        if c.pipeline is not None:
            return
        try:
            msg = cdr.deserialize(raw, String)
            self._load(c, msg.data, f'{c.spec.namespace}/robot_description')
        except cdr.DECODE_ERRORS as e:     # ConfigError is a ValueError too
            self._warn(c, 'description', f'{c.spec.name}: robot_description rejected: {e}')

    def _use_shipped(self, c):
        c.fallback.cancel()
        if c.pipeline is None:
            self._load(c, shipped_character_urdf(), 'the shipped character')

    def _load(self, c, urdf, source):
        spec = c.spec
        # Characters of one URDF and rig share them (read-only): loaded once, not per copy.
        key = (urdf, spec.rig, spec.fabric_file)
        if key not in self._models:
            skeleton = Skeleton(urdf)
            self._models[key] = (skeleton, load_rig(skeleton, spec.rig),
                                 load_fabrics(spec.fabric_file))
        skeleton, rig, fabrics = self._models[key]
        pipeline = SessionPipeline(skeleton, rig, fabrics, spec.values, spec.name, timing=True,
                                   output_phase=spread_phase(len(self.crowd.pipelines)))
        clash = set(spec.values['frame_prefix'] + b for b in pipeline.sim.bone_names) & set(
            skeleton.link_names)
        if clash:
            raise ConfigError(f'{spec.name}: bone frame(s) {", ".join(sorted(clash))} would '
                              'republish URDF links: change its frame_prefix')
        c.pipeline, c.urdf = pipeline, urdf
        if c.viewer is not None:        # it came before the character
            pipeline.set_viewer(c.viewer)
        c.index = self.crowd.add(pipeline)
        if c.description is not None:
            self.destroy_subscription(c.description)
            self.destroy_timer(c.fallback)
            c.description = c.fallback = None
        c.markers = self.create_publisher(MarkerArray, c.topics['markers'][0], 10,
                                          event_callbacks=NO_PUB_EVENTS)
        pipeline.markers_wanted = functools.partial(self._markers_wanted, c.markers)
        if self.recorder is not None:
            self._add_character_to_recording(c)
        c.diag_wall = time.monotonic()
        c.subscription = self._inputs.subscribe(self, c, c.topics['joint_states'][0])
        self.get_logger().debug(f'{spec.name}: {skeleton.name!r} from {source}')
        keep_loaded_out_of_collections()

    # -- recording ----------------------------------------------------------------------------
    def _open_recorder(self, path):
        if not path:
            return
        try:
            self.recorder = SessionRecorder(path, compression=self._p('record_compression'))
            for key in ('tf', 'diagnostics', 'viewer'):
                self.recorder.add_topic(*self._topics[key])
        except OSError as e:
            self.recorder = None
            self.get_logger().error(f'cannot record to {path!r} ({e}); running without '
                                    'recording')
            return
        self._record_viewer()

    def _add_character_to_recording(self, c):
        for key in ('joint_states', 'markers'):
            self.recorder.add_topic(*c.topics[key])
        spec = c.spec
        self.recorder.add_session_config(
            c.urdf, _read(spec.rig or shipped('jacket_rig.yaml')),
            _read(spec.fabric_file or shipped('fabrics.yaml')), c.pipeline.values, spec.name,
            c.pipeline.output_phase)

    # -- inputs -------------------------------------------------------------------------------
    def _warn(self, c, code, text, period=5.0):
        """One line per character and kind of bad input per ``period`` seconds."""
        self._throttled(c.log_times, code, text, period)

    def _world_frames(self):
        return sorted({c.spec.values['world_frame'] for c in self.characters})

    def _apply_viewer(self, frame, position):
        for c in self.characters:
            if c.spec.values['world_frame'] == frame:
                c.viewer = position
                if c.pipeline is not None:
                    c.pipeline.set_viewer(position)

    def _last_input_stamp(self, default):
        return default if self._last_stamp is None else self._last_stamp

    def _on_inputs(self, taken: list) -> None:
        """Process the inputs of one wake-up, each character's backlog included, as one batch."""
        now = time.time_ns()
        # Latency counts from the message's arrival in this process, as the single node's.
        self.on_joint_states([(c, raw, info, info.get('received_timestamp') or now)
                              for c, raw, info in taken])

    def on_joint_states(self, batch: list) -> None:
        """Process (character, raw bytes, message info, arrival ns) inputs together.

        Public so a harness can feed the node without DDS, as the lab's crowd bench does.
        """
        entries = []
        for c, raw, info, arrived in batch:
            c.count_lost(info)
            try:
                msg = c.reader.read(raw)
            except cdr.DECODE_ERRORS as e:
                c.pipeline.note_undecodable()
                self._warn(c, 'decode', f'{c.spec.name}: a JointState that does not decode '
                           f'({e}): message dropped')
                continue
            c.inputs += 1
            entries.append((c, raw, msg, arrived))
        results = self.crowd.step_and_tf([(c.index, msg) for c, _, msg, _ in entries])
        if entries:
            self._last_stamp = entries[-1][2].stamp_ns
        # Every character's /tf first: a listener waits for it, not for markers or diagnostics.
        for (c, _, _, arrived), (_, tf, _) in zip(entries, results):
            if tf:
                for _, out in tf:
                    self.tf.publish(out)
                c.pipeline.note_latency(time.time_ns() - arrived)
        for (c, raw, msg, _), (report, tf, later) in zip(entries, results):
            stamp_ns = msg.stamp_ns
            periodic = later()
            self._record(c.topics['joint_states'][0], raw, stamp_ns)
            self._warn_about(c, report, tf)
            for key, out in tf:
                self._record(c.topics[key][0], out, stamp_ns)
            for key, out in periodic:
                if key == 'markers':
                    c.markers.publish(out)
                else:
                    self.diagnostics.publish(out)
                    c.diag_wall = time.monotonic()
                self._record(c.topics[key][0], out, stamp_ns)

    def _warn_about(self, c, report, tf):
        """Log what an input's report says went wrong (each kind throttled per character)."""
        for code, text in input_problems(report, bool(tf)):
            self._warn(c, code, f'{c.spec.name}: {text}')

    def _diagnostics_watchdog(self):
        """Diagnostics of each character whose inputs' own have not gone out for a period."""
        now = time.monotonic()
        for c in self.characters:
            if c.pipeline is None or now - c.diag_wall < 1.2 / c.spec.values['diagnostics_rate']:
                continue
            last = c.sim.last
            stamp_ns = last.stamp_ns if last else self.get_clock().now().nanoseconds
            out = c.pipeline.diagnostics_now(stamp_ns)
            self.diagnostics.publish(out)
            c.diag_wall = now
            self._record(c.topics['diagnostics'][0], out, stamp_ns)


def _never_called(raw: bytes) -> None:
    """Do nothing: CrowdInputs takes the characters' messages, the executor never calls this."""


def main(args: list[str] | None = None) -> int:
    argv = sys.argv if args is None else args
    parser = argparse.ArgumentParser(
        prog='jacket_cloth_crowd',
        description='Many jacketed characters in one node: each subscribes <name>/joint_states '
        'and publishes its bones on /tf, <name>/jacket_cloth_node/markers and /diagnostics. '
        'Start with --ros-args -p characters:=crowd.yaml (see docs/crowd.md).')
    parser.parse_args(rclpy.utilities.remove_ros_args(argv)[1:])
    return run('jacket_cloth_crowd', JacketCrowdNode, argv, crowd=True)


if __name__ == '__main__':
    sys.exit(main())
