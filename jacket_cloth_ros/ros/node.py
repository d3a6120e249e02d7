# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""jacket_cloth_node: JointState in; jacket and hood bones on /tf, markers, diagnostics out."""

import argparse
import functools
import gc
import os
import signal
import sys
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

import rclpy
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import (
    DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data)
from rcl_interfaces.msg import SetParametersResult
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PointStamped, Vector3Stamped
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from ..core.config import ConfigError, shipped
from ..core.fabric import load_fabrics
from .warm import kernels_cached
from ..core.rig import load_rig
from ..core.skeleton import Skeleton, shipped_character_urdf
from ..recording.writer import SessionRecorder
from . import cdr
from .parameters import NODE_PARAMETERS, check_value, descriptor, fabric_parameters
from .pipeline import SessionPipeline, session_topics
from .viewer import VIEWER_QOS, read_viewer
from .warm import warm_kernels

if TYPE_CHECKING:           # for the annotations only
    import numpy as np
    from rclpy.publisher import Publisher

    from ..core.simulation import JacketSimulation, StepReport

TF_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.VOLATILE, history=HistoryPolicy.KEEP_LAST)
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
# rclpy gives each publisher and subscription two QoS event handlers (incompatible QoS, type),
# and its executor visits every one on every wake-up. joint_states and /tf keep theirs, as a
# mismatch there must be heard; markers, diagnostics and wind go without (the peer's side
# warns too), which lowers the node's CPU per message (docs/performance.md).
NO_PUB_EVENTS = PublisherEventCallbacks(use_default_callbacks=False)
NO_SUB_EVENTS = SubscriptionEventCallbacks(use_default_callbacks=False)


def keep_loaded_out_of_collections() -> None:
    """Move every object alive now out of the cyclic garbage collector's reach (gc.freeze).

    Called once a character is loaded: rclpy, numba's dispatchers and the models live as long
    as the node, and a full collection that walked them all paused every input behind it.
    """
    gc.freeze()


class JacketNodeBase(Node):
    """What both jacket nodes share: parameters checked as declared, an optional recording.

    And the ``~/viewer`` input (ros/viewer.py). A write error stops the recording, not the node.
    """

    recorder: 'SessionRecorder | None' = None
    _viewer: 'tuple[bytes, int] | None' = None   # the last accepted ~/viewer: (raw, stamp)

    def _declare(self, name, spec):
        """Declare a parameter; a start value that the live check would refuse is a ConfigError."""
        kind, default, rng, ro, text = spec
        try:
            self.declare_parameter(name, default, descriptor(name, kind, rng, ro, text))
        except ParameterException as e:
            reason = str(e).removesuffix(f': {name}').rpartition('Reason: ')[2]
            raise ConfigError(f'parameter {name}: {reason}') from None
        reason = check_value(name, self._p(name))
        if reason:
            raise ConfigError(f'parameter {reason}' if reason.startswith(name) else
                              f'parameter {name}: {reason}')

    def _p(self, name):
        return self.get_parameter(name).value

    def _record(self, topic, data, stamp_ns):
        if self.recorder is None:
            return
        try:
            self.recorder.write(topic, data, stamp_ns)
        except (OSError, ValueError) as e:
            self.get_logger().error(f'recording stopped: {e}')
            self.recorder = None

    def _markers_wanted(self, publisher: 'Publisher') -> bool:
        """Tell whether markers due now have a reader: a subscriber or the recording.

        Unread, building them was a large share of each input (docs/crowd.md); their cadence
        goes on either way, so a viewer that subscribes gets them on the same ticks.
        """
        return self.recorder is not None or publisher.get_subscription_count() > 0

    def close(self) -> None:
        """Close the recording, if any."""
        if self.recorder is not None:
            self.recorder.close()
            self.recorder = None

    def _throttled(self, log_times, code, text, period=5.0):
        """Warn ``text`` at most once per ``period`` seconds per ``code`` of ``log_times``."""
        now = time.monotonic()
        if now - log_times.get(code, -1e9) >= period:
            log_times[code] = now
            self.get_logger().warning(text)

    # -- the viewer (one for the node, whatever the characters) ------------------------------
    def _subscribe_viewer(self) -> str:
        """Subscribe ``~/viewer``; returns its name in the graph, the one it is recorded under."""
        # Latched: a viewer published once, before a character is loaded, waits for it.
        self.create_subscription(PointStamped, '~/viewer', self._on_viewer, VIEWER_QOS,
                                 raw=True, event_callbacks=NO_SUB_EVENTS)
        return self.resolve_topic_name('~/viewer')

    def _world_frames(self) -> 'list[str]':
        """Return the world frames a viewer may be given in (its characters')."""
        raise NotImplementedError

    def _apply_viewer(self, frame: str, position: 'np.ndarray') -> None:
        """Set the viewer for the characters in ``frame``, from their next input."""
        raise NotImplementedError

    def _last_input_stamp(self, default: int) -> int:
        """Return the last input's stamp (ns), or ``default`` before the first one."""
        raise NotImplementedError

    def _on_viewer(self, raw):
        """~/viewer: the viewer's world position for the level of detail, from the next input.

        Recorded as an input at the last input's stamp: a replay applies it at the same point.
        """
        self.received['viewer'] += 1
        frames = self._world_frames()
        readings = [read_viewer(raw, frame) for frame in frames]
        if all(r.position is None for r in readings):
            self.refused['viewer'] += 1
            self._throttled(self._log_times, 'viewer', f'~/viewer rejected: '
                            f'{readings[0].reason}; the last viewer is kept')
            return
        self._viewer = (bytes(raw), readings[0].stamp_ns)
        for frame, reading in zip(frames, readings):
            if reading.position is not None:
                self._apply_viewer(frame, reading.position)
        self._record_viewer()

    def _record_viewer(self):
        """Record the last accepted viewer, if any; a file opened after it starts with it."""
        if self._viewer is not None:
            raw, stamp = self._viewer
            self._record(self._topics['viewer'][0], raw, self._last_input_stamp(stamp))


class JacketClothNode(JacketNodeBase):
    """Runs the fixed-step jacket and hood simulation on a character's JointState stream."""

    def __init__(self, **kwargs: object):
        super().__init__('jacket_cloth_node', **kwargs)
        for name, spec in NODE_PARAMETERS.items():
            self._declare(name, spec)
        fabric_file = self._p('fabric_file') or None
        self._fabric_file = fabric_file or shipped('fabrics.yaml')
        self.fabrics = load_fabrics(fabric_file)
        preset = self._p('fabric')
        if preset not in self.fabrics:
            raise ConfigError(f'parameter fabric: {preset!r} is not a preset '
                              f'(presets: {", ".join(self.fabrics)})')
        for name, spec in fabric_parameters(self.fabrics[preset]).items():
            self._declare(name, spec)
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)

        self.pipeline = None
        self._joint_states = cdr.JointStateReader()
        self.recorder = None
        self._urdf = None
        self._log_times = {}
        self.inputs = 0
        self._sequences = {}        # publisher gid -> the last sequence number it sent us
        # Messages on the other subscriptions, and those of them refused (undecodable, invalid).
        self.received = dict.fromkeys(('wind', 'viewer', 'robot_description'), 0)
        self.refused = dict.fromkeys(('wind', 'viewer', 'robot_description'), 0)
        self._viewer_position = None        # the last accepted ~/viewer's
        self._diag_timer = None
        self._diag_wall = 0.0

        self.publishers_by_key = {
            'tf': self.create_publisher(TFMessage, '/tf', TF_QOS),
            'markers': self.create_publisher(MarkerArray, '~/markers', 10,
                                             event_callbacks=NO_PUB_EVENTS),
            'diagnostics': self.create_publisher(DiagnosticArray, '/diagnostics', 10,
                                                 event_callbacks=NO_PUB_EVENTS),
        }
        self.create_subscription(Vector3Stamped, '~/wind', self._on_wind, 10, raw=True,
                                 event_callbacks=NO_SUB_EVENTS)
        viewer = self._subscribe_viewer()
        # Recorded under the names the topics have in the graph (resolved once).
        self._topics = session_topics(
            self.resolve_topic_name('joint_states'), self.resolve_topic_name('~/wind'),
            self.publishers_by_key['markers'].topic_name, viewer)
        self._open_recorder(self._p('record'))
        self._description = self._fallback = None
        urdf = self._p('robot_description')
        if urdf:
            self._load_model(urdf, 'the robot_description parameter')
        else:
            # Relative, as robot_state_publisher publishes it: under a namespace the node hears
            # its own character's description, not another's. Raw: bytes that are no String
            # reach the callback, which says so, not the executor.
            self._description = self.create_subscription(
                String, 'robot_description', self._on_description, LATCHED, raw=True)
            self._fallback = self.create_timer(self._p('robot_description_timeout'),
                                               self._use_shipped_character)

    @property
    def sim(self) -> 'JacketSimulation | None':
        return self.pipeline.sim if self.pipeline else None

    # -- model --------------------------------------------------------------------------------
    def _values(self):
        """Every parameter's current value, by name (arrays as lists)."""
        out = {}
        for name in self.list_parameters([], 0).names:
            if name in NODE_PARAMETERS or name.startswith('fabric.'):
                p = self.get_parameter(name)
                out[name] = list(p.value) if p.type_ == Parameter.Type.DOUBLE_ARRAY else p.value
        return out

    def _on_description(self, raw):
        self.received['robot_description'] += 1
        if self.pipeline is None:
            try:
                msg = cdr.deserialize(raw, String)
            except cdr.DECODE_ERRORS as e:
                self.refused['robot_description'] += 1
                self._warn('description_decode', f'a {self._description.topic_name} that does '
                           f'not decode ({e}): message dropped')
                return
            try:
                self._load_model(msg.data, f'the {self._description.topic_name} topic')
            except ConfigError as e:
                self.refused['robot_description'] += 1
                self.get_logger().error(f'{self._description.topic_name} rejected: {e}')

    def _use_shipped_character(self):
        self._fallback.cancel()                 # once, even if the shipped one fails to load
        if self.pipeline is None:
            self._load_model(shipped_character_urdf(),
                             'the shipped character (config/character.urdf)')

    def _load_model(self, urdf, source):
        if not kernels_cached(crowd=False):
            self.get_logger().info(
                'compiling the simulation kernels into numba\'s cache: a first start after an '
                'install or an edit of a kernel takes about half a minute (`jacket_cloth warm` '
                'does it ahead)')
        skeleton = Skeleton(urdf)
        rig = load_rig(skeleton, self._p('rig_file') or None)
        pipeline = SessionPipeline(skeleton, rig, self.fabrics, self._values(),
                                   self.get_name(), timing=True)
        clash = set(self._p('frame_prefix') + b for b in pipeline.sim.bone_names) & set(
            skeleton.link_names)
        if clash:
            raise ConfigError(f'bone frame(s) {", ".join(sorted(clash))} would republish URDF '
                              'links: change frame_prefix')
        pipeline.markers_wanted = functools.partial(self._markers_wanted,
                                                    self.publishers_by_key['markers'])
        self.pipeline = pipeline
        if self._viewer_position is not None:       # it came before the character
            pipeline.set_viewer(self._viewer_position)
        self._urdf = urdf
        # Done waiting: every entity left in the node is work for each executor wake-up.
        if self._description is not None:
            self.destroy_subscription(self._description)
            self.destroy_timer(self._fallback)
            self._description = self._fallback = None
        self._write_session_config()
        # Diagnostics keep their own rate when inputs stop or nothing else is published.
        self._diag_wall = time.monotonic()
        self._diag_timer = self.create_timer(1.0 / self._p('diagnostics_rate'),
                                             self._diagnostics_watchdog)
        keep_loaded_out_of_collections()
        # Subscribed only now: a publisher that waits for us knows we can simulate.
        self.create_subscription(JointState, 'joint_states', self.on_joint_state,
                                 qos_profile_sensor_data, raw=True)
        self.get_logger().info(
            f'character {skeleton.name!r} from {source}: {len(skeleton.joint_names)} joints, '
            f'cloth {rig.cols}x{rig.rows}, {len(pipeline.sim.bone_names)} bones under '
            f'{skeleton.link_names[0]!r}')

    # -- parameters ---------------------------------------------------------------------------
    def _validate_parameters(self, params):
        for p in params:
            if p.name == 'wind' and p.type_ != Parameter.Type.DOUBLE_ARRAY:
                return SetParametersResult(successful=False,
                                           reason='wind must be 3 finite numbers [x, y, z]')
            reason = check_value(p.name, p.value)
            if reason:
                return SetParametersResult(successful=False, reason=reason)
        return SetParametersResult(successful=True)

    def _apply_parameters(self, params):
        """Apply valid changes from the next step; they never reset the cloth."""
        names = {p.name for p in params}
        if 'record' in names:
            self._open_recorder(self._p('record'))
        if self.pipeline is None:
            return
        if 'diagnostics_rate' in names:
            self._diag_timer.timer_period_ns = int(1e9 / self._p('diagnostics_rate'))
        values = self._values()
        self.pipeline.apply({n: values[n] for n in names})
        # Recorded at the last input's stamp: a replay applies them after the same input.
        stamp = self._last_input_stamp(0)
        self._record(self._topics['parameter_events'][0], cdr.parameter_event(
            stamp, self.get_fully_qualified_name(), [p.to_parameter_msg() for p in params]),
            stamp)

    # -- recording ----------------------------------------------------------------------------
    def _open_recorder(self, path):
        if self.recorder is not None:
            self.recorder.close()
            self.get_logger().info(f'recording closed: {self.recorder.path}')
            self.recorder = None
        if not path:
            return
        try:
            self.recorder = SessionRecorder(path, compression=self._p('record_compression'))
            for topic, kind, qos in self._topics.values():
                self.recorder.add_topic(topic, kind, qos)
            self.get_logger().info(f'recording the session to {path}')
        except OSError as e:
            self.recorder = None
            self.get_logger().error(f'cannot record to {path!r} ({e}); running without '
                                    'recording')
            return
        self._write_session_config()
        self._record_viewer()

    def _write_session_config(self):
        """Record the character, rig, fabrics and parameters, so a replay needs only the file."""
        if self.recorder is None or self.pipeline is None:
            return
        rig_file = self._p('rig_file') or shipped('jacket_rig.yaml')
        self.recorder.add_session_config(self._urdf, _read(rig_file), _read(self._fabric_file),
                                         self._values())

    # -- the input ----------------------------------------------------------------------------
    def _warn(self, code, text, period=5.0):
        """One line per kind of bad input per ``period`` seconds."""
        self._throttled(self._log_times, code, text, period)

    def _diagnostics_watchdog(self):
        """Diagnostics, when the inputs' own have not gone out for a period of wall time."""
        if time.monotonic() - self._diag_wall < 1.2 / self._p('diagnostics_rate'):
            return
        last = self.sim.last
        stamp_ns = last.stamp_ns if last else self.get_clock().now().nanoseconds
        out = self.pipeline.diagnostics_now(stamp_ns)
        self.publishers_by_key['diagnostics'].publish(out)
        self._diag_wall = time.monotonic()
        self._record(self._topics['diagnostics'][0], out, stamp_ns)

    def _count_lost(self, info):
        """Count a gap in a publisher's numbering as messages lost before this callback."""
        seq, gid = info.get('publication_sequence_number'), info.get('publisher_gid')
        if not seq or not gid:
            return
        key = gid['data'] if isinstance(gid, dict) else gid
        last = self._sequences.pop(key, None)       # re-inserted: the dict stays in use order
        if last is not None and seq > last + 1:
            self.pipeline.note_lost(seq - last - 1)
        self._sequences[key] = seq if last is None else max(seq, last)
        if len(self._sequences) > 64:
            del self._sequences[next(iter(self._sequences))]

    def _on_wind(self, raw):
        """~/wind sets the wind live, through the ``wind`` parameter (one path, validated).

        The change is recorded as a parameter event; the message itself is recorded too.
        """
        self.received['wind'] += 1
        try:
            msg = cdr.deserialize(raw, Vector3Stamped)
        except cdr.DECODE_ERRORS as e:
            self.refused['wind'] += 1
            self._warn('wind_decode', f'a ~/wind that does not decode ({e}): message dropped')
            return
        v = [msg.vector.x, msg.vector.y, msg.vector.z]
        result = self.set_parameters([Parameter('wind', Parameter.Type.DOUBLE_ARRAY, v)])[0]
        if not result.successful:
            self.refused['wind'] += 1
            self._warn('wind', f'~/wind rejected: {result.reason}')
            return
        header = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        self._record(self._topics['wind'][0], raw, self._last_input_stamp(header))

    def _world_frames(self):
        return [self._p('world_frame')]

    def _apply_viewer(self, frame, position):
        self._viewer_position = position
        if self.pipeline is not None:
            self.pipeline.set_viewer(position)

    def _last_input_stamp(self, default):
        last = self.sim.last if self.sim else None
        return last.stamp_ns if last else default

    def on_joint_state(self, raw: bytes, info: dict) -> None:
        """One serialized JointState in (the joint_states callback): simulate, publish, record.

        Public so a harness can feed the node without DDS, as the lab's endurance run does.

        Args:
            raw (bytes): the CDR-serialized message.
            info (dict): rclpy's message info; its ``received_timestamp`` (ns, system clock)
                starts the latency, else (``{}``) now does. It has no default because rclpy
                passes the info only to a callback that needs a second argument.
        """
        # Latency counts from the message's arrival in this process (the rmw's receive time,
        # system clock), so time queued behind other callbacks is in it; without one, from now.
        arrived = info.get('received_timestamp') or time.time_ns()
        self._count_lost(info)
        try:
            msg = self._joint_states.read(raw)
        except cdr.DECODE_ERRORS as e:
            self.pipeline.note_undecodable()
            self._warn('decode', f'a JointState that does not decode ({e}): message dropped')
            return
        stamp_ns = msg.stamp_ns
        self.inputs += 1
        self._record(self._topics['joint_states'][0], raw, stamp_ns)
        report, outputs = self.pipeline.on_joint_state(msg, stamp_ns)
        for code, text in input_problems(report, any(key == 'tf' for key, _ in outputs)):
            self._warn(code, text)
        tf_sent = None
        for key, out in outputs:
            self.publishers_by_key[key].publish(out)
            if key == 'tf':
                tf_sent = time.time_ns()
            elif key == 'diagnostics':
                self._diag_wall = time.monotonic()
            self._record(self._topics[key][0], out, stamp_ns)
        # Latency, once per input as in the crowd: arrival to its last /tf handed to DDS
        # (publish_world_tf sends two).
        if tf_sent is not None:
            self.pipeline.note_latency(tf_sent - arrived)


def input_problems(report: 'StepReport', published: bool) -> list[tuple[str, str]]:
    """Return (code, text) of what went wrong with an input, for the nodes' throttled warnings.

    ``published``: whether its bones went out on /tf.
    """
    out = list(report.warnings)
    if report.reset and report.reset != 'first sample':
        out.append(('reset', f'cloth reset to the skinned pose: {report.reset}'))
    if report.skipped_steps:
        out.append(('overrun', f'{report.skipped_steps} steps skipped (cap '
                    'max_steps_per_input); the cloth lags no further behind'))
    if report.accepted and not published:
        out.append(('nan', 'non-finite bone pose: nothing published'))
    return out


def _read(path):
    with open(path, encoding='utf-8') as f:
        return f.read()


def main(args: list[str] | None = None) -> int:
    argv = sys.argv if args is None else args
    parser = argparse.ArgumentParser(
        prog='jacket_cloth_node',
        description='Jacket and hood secondary motion: subscribes joint_states '
        '(sensor_msgs/JointState), publishes bones on /tf, ~/markers and /diagnostics. '
        'Parameters are set with --ros-args -p name:=value (see README).')
    parser.parse_args(rclpy.utilities.remove_ros_args(argv)[1:])
    return run('jacket_cloth_node', JacketClothNode, argv, crowd=False)


def run(program: str, make_node: Callable[[], Node], argv: list[str], crowd: bool) -> int:
    """Compile the kernels if need be, then spin ``make_node()`` until shutdown; the exit code.

    Shared by jacket_cloth_node and jacket_cloth_crowd (``crowd``: its one call is compiled too).
    """
    # Compiled here, before rclpy takes SIGINT: in a callback, Ctrl-C only shut the context
    # down, the compile ran on for half a minute and ended in a traceback.
    if not kernels_cached(crowd=crowd):
        print(f'{program}: compiling the simulation kernels into numba\'s cache (a first '
              'start after an install or an edit of a kernel; about a minute; '
              '`jacket_cloth warm` does it ahead)', file=sys.stderr)

        def stop_compiling(signum, frame):
            print(f'{program}: stopped while compiling the kernels', file=sys.stderr,
                  flush=True)
            os._exit(128 + signum)
        # Ctrl-C or SIGTERM stop it at once: raised as KeyboardInterrupt, numba can swallow it
        # inside a compiler callback and go on compiling. Nothing is lost: numba writes each
        # cache file whole or not at all.
        for signum in (signal.SIGINT, signal.SIGTERM):
            signal.signal(signum, stop_compiling)
        warm_kernels(crowd=crowd)
        for signum in (signal.SIGINT, signal.SIGTERM):
            signal.signal(signum, signal.SIG_DFL if signum == signal.SIGTERM
                          else signal.default_int_handler)
    rclpy.init(args=argv)
    node = None
    try:
        node = make_node()
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except ConfigError as e:
        print(f'{program}: {e}', file=sys.stderr)
        return 1
    except Exception:
        if rclpy.ok():
            raise
        # A signal shut the context down while a callback was still working: stopping.
    finally:
        if node is not None:
            node.close()
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
