# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""jacket_cloth_node: JointState in; jacket and hood bones on /tf, markers, diagnostics out."""

import argparse
import sys
import time

import numpy as np
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import (
    DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data)
from rclpy.serialization import deserialize_message, serialize_message
from rcl_interfaces.msg import SetParametersResult
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Vector3Stamped
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from ..core.config import ConfigError, shipped
from ..core.fabric import load_fabrics
from ..core.rig import load_rig
from ..core.simulation import STRETCH_LIMITS, JacketSimulation, SimParams
from ..core.skeleton import Skeleton
from ..recording.writer import SessionRecorder, qos_profile_yaml
from . import messages
from .parameters import NODE_PARAMETERS, descriptor, fabric_parameters

TF_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.VOLATILE, history=HistoryPolicy.KEEP_LAST)
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
SIM_KEYS = ('sim_rate', 'max_steps_per_input', 'gravity', 'wind', 'wind_gust',
            'wind_gust_period', 'stretch_limit', 'reset_gap', 'teleport_distance',
            'teleport_angle_deg')
# Topics as recorded: (type, offered QoS as rosbag2 writes it).
RECORDED = {
    'joint_states': ('sensor_msgs/msg/JointState', qos_profile_yaml(reliable=False)),
    'wind': ('geometry_msgs/msg/Vector3Stamped', qos_profile_yaml()),
    '/tf': ('tf2_msgs/msg/TFMessage', qos_profile_yaml(depth=100)),
    'markers': ('visualization_msgs/msg/MarkerArray', qos_profile_yaml()),
    '/diagnostics': ('diagnostic_msgs/msg/DiagnosticArray', qos_profile_yaml()),
}


class JacketClothNode(Node):
    """Runs the fixed-step jacket and hood simulation on a character's JointState stream."""

    def __init__(self, **kwargs):
        super().__init__('jacket_cloth_node', **kwargs)
        for name, (kind, default, rng, ro, text) in NODE_PARAMETERS.items():
            self.declare_parameter(name, default, descriptor(name, kind, rng, ro, text))
        fabric_file = self._p('fabric_file') or None
        self.fabrics = load_fabrics(fabric_file)
        preset = self._p('fabric')
        if preset not in self.fabrics:
            raise ConfigError(f'parameter fabric: {preset!r} is not a preset '
                              f'(presets: {", ".join(self.fabrics)})')
        for name, (kind, default, rng, ro, text) in fabric_parameters(self.fabrics[preset]).items():
            self.declare_parameter(name, default, descriptor(name, kind, rng, ro, text))
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)

        self.sim = None
        self.recorder = None
        self._log_times = {}
        self._last_marker = None
        self._last_diag = None
        self._marker_reset = True
        self._costs = []
        self.inputs = 0
        self.dropped = 0
        self._last_reset_reason = ''

        self.tf_pub = self.create_publisher(TFMessage, '/tf', TF_QOS)
        self.marker_pub = self.create_publisher(MarkerArray, '~/markers', 10)
        self.diag_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.create_subscription(Vector3Stamped, '~/wind', self._on_wind, 10, raw=True)
        # Recorded under the names the topics have in the graph (resolved once).
        self._recorded_topics = {'joint_states': self.resolve_topic_name('joint_states'),
                                 'wind': self.resolve_topic_name('~/wind'),
                                 'markers': self.marker_pub.topic_name,
                                 '/tf': '/tf', '/diagnostics': '/diagnostics'}
        self._cache_output_parameters()
        self._open_recorder(self._p('record'))
        urdf = self._p('robot_description')
        if urdf:
            self._load_model(urdf, 'the robot_description parameter')
        else:
            self.create_subscription(String, '/robot_description', self._on_description,
                                     LATCHED)
            self._fallback = self.create_timer(self._p('robot_description_timeout'),
                                               self._use_shipped_character)

    # -- model --------------------------------------------------------------------------------
    def _p(self, name):
        return self.get_parameter(name).value

    def _cache_output_parameters(self):
        """Read on every input: keep them in attributes, not in parameter look-ups."""
        self._frame_prefix = self._p('frame_prefix')
        self._markers_rate = self._p('markers_rate')
        self._diagnostics_rate = self._p('diagnostics_rate')

    def _on_description(self, msg):
        if self.sim is None:
            try:
                self._load_model(msg.data, 'the /robot_description topic')
                self._fallback.cancel()
            except ConfigError as e:
                self.get_logger().error(f'/robot_description rejected: {e}')

    def _use_shipped_character(self):
        self._fallback.cancel()
        if self.sim is None:
            with open(shipped('character.urdf'), encoding='utf-8') as f:
                self._load_model(f.read(), 'the shipped character (config/character.urdf)')

    def _load_model(self, urdf, source):
        skeleton = Skeleton(urdf)
        rig = load_rig(skeleton, self._p('rig_file') or None)
        sim = JacketSimulation(skeleton, rig, self._fabric(), self._sim_params(),
                               self._p('world_joint'))
        clash = set(self._p('frame_prefix') + b for b in sim.bone_names) & set(
            skeleton.link_names)
        if clash:
            raise ConfigError(f'bone frame(s) {", ".join(sorted(clash))} would republish URDF '
                              'links: change frame_prefix')
        self.sim = sim
        # Subscribed only now: a publisher that waits for us knows we can simulate.
        self.create_subscription(JointState, 'joint_states', self._on_joint_state,
                                 qos_profile_sensor_data, raw=True)
        self.get_logger().info(
            f'character {skeleton.name!r} from {source}: {len(skeleton.joint_names)} joints, '
            f'cloth {rig.cols}x{rig.rows}, {len(sim.bone_names)} bones under '
            f'{skeleton.link_names[0]!r}')

    def _fabric(self):
        base = self.fabrics[self._p('fabric')]
        values = {f: self._p('fabric.' + f) for f in base.__dataclass_fields__}
        return base.with_values(**values)

    def _sim_params(self):
        values = {k: self._p(k) for k in SIM_KEYS}
        values['wind'] = tuple(float(w) for w in values['wind'])
        return SimParams(**values)

    # -- parameters ---------------------------------------------------------------------------
    def _validate_parameters(self, params):
        for p in params:
            if p.name == 'wind':
                v = p.value
                if (p.type_ != Parameter.Type.DOUBLE_ARRAY or len(v) != 3
                        or not np.isfinite(v).all()):
                    return SetParametersResult(successful=False,
                                               reason='wind must be 3 finite numbers [x, y, z]')
            if p.name == 'stretch_limit' and p.value not in STRETCH_LIMITS:
                return SetParametersResult(
                    successful=False,
                    reason=f'stretch_limit must be one of {", ".join(STRETCH_LIMITS)}')
            if p.name in ('frame_prefix',) and p.value.startswith('/'):
                return SetParametersResult(successful=False,
                                           reason='frame ids must not start with "/"')
            if p.name == 'world_joint' and not p.value:
                return SetParametersResult(successful=False, reason='world_joint is empty')
        return SetParametersResult(successful=True)

    def _apply_parameters(self, params):
        """Valid changes act from the next step; the cloth is never reset by them."""
        names = {p.name for p in params}
        self._cache_output_parameters()
        if 'record' in names:
            self._open_recorder(self._p('record'))
        if self.sim is None:
            return
        if names & set(SIM_KEYS):
            self.sim.set_params(self._sim_params())
        if any(n.startswith('fabric.') for n in names):
            self.sim.set_fabric(self._fabric())
        if 'world_joint' in names:
            self.sim.parser.set_world_joint(self._p('world_joint'))

    # -- recording ----------------------------------------------------------------------------
    def _open_recorder(self, path):
        if self.recorder is not None:
            self.recorder.close()
            self.get_logger().info(f'recording closed: {self.recorder.path}')
            self.recorder = None
        if not path:
            return
        try:
            self.recorder = SessionRecorder(path)
            for topic, (kind, qos) in RECORDED.items():
                self.recorder.add_topic(self._recorded_topics[topic], kind, qos)
            self.get_logger().info(f'recording the session to {path}')
        except OSError as e:
            self.recorder = None
            self.get_logger().error(f'cannot record to {path!r} ({e}); running without '
                                    'recording')

    def _record(self, topic, data, stamp_ns):
        if self.recorder is None:
            return
        try:
            self.recorder.write(self._recorded_topics[topic], data, stamp_ns)
        except (OSError, ValueError) as e:
            self.get_logger().error(f'recording stopped: {e}')
            self.recorder = None

    def close(self):
        if self.recorder is not None:
            self.recorder.close()
            self.recorder = None

    # -- the input ----------------------------------------------------------------------------
    def _warn(self, code, text, period=5.0):
        """One line per kind of bad input per ``period`` seconds."""
        now = time.monotonic()
        if now - self._log_times.get(code, -1e9) >= period:
            self._log_times[code] = now
            self.get_logger().warning(text)

    def _on_wind(self, raw):
        """~/wind sets the wind live, through the ``wind`` parameter (one path, validated).

        Recorded at the stamp of the last JointState, so a replay applies it at the same step.
        """
        msg = deserialize_message(raw, Vector3Stamped)
        v = [msg.vector.x, msg.vector.y, msg.vector.z]
        result = self.set_parameters([Parameter('wind', Parameter.Type.DOUBLE_ARRAY, v)])[0]
        if not result.successful:
            self._warn('wind', f'~/wind rejected: {result.reason}')
            return
        header = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        self._record('wind', raw, self.sim.last.stamp_ns if self.sim and self.sim.last else header)

    def _on_joint_state(self, raw):
        msg = deserialize_message(raw, JointState)
        stamp_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        self.inputs += 1
        self._record('joint_states', raw, stamp_ns)
        report = self.sim.process(stamp_ns, msg.name, msg.position)
        for code, text in report.warnings:
            self._warn(code, text)
        if not report.accepted:
            self.dropped += 1
            return
        if report.reset:
            self._last_reset_reason = report.reset
            self._marker_reset = True
            if report.reset != 'first sample':
                self._warn('reset', f'cloth reset to the skinned pose: {report.reset}')
        if report.skipped_steps:
            self._warn('overrun', f'{report.skipped_steps} steps skipped (cap '
                       f'max_steps_per_input); the cloth lags no further behind')
        self._costs.append(report.step_cost_ns)
        self._publish(stamp_ns)

    def _publish(self, stamp_ns):
        bones = self.sim.bones()
        if not (np.isfinite(bones.translations).all() and np.isfinite(bones.quaternions).all()):
            self._warn('nan', 'non-finite bone pose: nothing published')
            return
        tf = messages.tf_message(bones, stamp_ns, self._frame_prefix)
        self.tf_pub.publish(tf)
        self._record('/tf', serialize_message(tf), stamp_ns)
        rate = self._markers_rate
        if rate > 0 and self._due(self._last_marker, stamp_ns, rate):
            self._last_marker = stamp_ns
            markers = messages.marker_array(self.sim, stamp_ns, self.sim.skeleton.link_names[0],
                                            reset=self._marker_reset)
            self._marker_reset = False
            self.marker_pub.publish(markers)
            self._record('markers', serialize_message(markers), stamp_ns)
        if self._due(self._last_diag, stamp_ns, self._diagnostics_rate):
            self._last_diag = stamp_ns
            diag = self._diagnostics(stamp_ns)
            self.diag_pub.publish(diag)
            self._record('/diagnostics', serialize_message(diag), stamp_ns)

    @staticmethod
    def _due(last, stamp_ns, rate):
        # 5% slack: stamps rounded to whole ns must not turn every 2nd input into every 3rd.
        return last is None or stamp_ns - last >= 0.95e9 / rate or stamp_ns < last

    def _diagnostics(self, stamp_ns):
        costs = np.array(self._costs or [0]) * 1e-3
        self._costs = []
        vert, horiz = self.sim.strain()
        budget_us = 1e6 / self.sim.params.sim_rate
        values = {
            'step_cost_us_median': f'{np.median(costs):.1f}',
            'step_cost_us_max': f'{costs.max():.1f}',
            'overruns': self.sim.overruns,
            'resets': self.sim.resets,
            'last_reset': self._last_reset_reason,
            'worst_vertical_strain': f'{vert:.4f}',
            'worst_horizontal_strain': f'{horiz:.4f}',
            'inputs': self.inputs,
            'dropped_inputs': self.dropped,
            'sim_steps': self.sim.steps_total,
            'recording': self.recorder.path if self.recorder else '',
        }
        slow = costs.max() > budget_us
        message = 'step cost above one step of real time' if slow else 'ok'
        return messages.diagnostics(stamp_ns, self.get_name(), values, slow, message)


def main(args=None):
    argv = sys.argv if args is None else args
    parser = argparse.ArgumentParser(
        prog='jacket_cloth_node',
        description='Jacket and hood secondary motion: subscribes joint_states '
        '(sensor_msgs/JointState), publishes bones on /tf, ~/markers and /diagnostics. '
        'Parameters are set with --ros-args -p name:=value (see README).')
    parser.parse_args(rclpy.utilities.remove_ros_args(argv)[1:])
    rclpy.init(args=argv)
    node = None
    try:
        node = JacketClothNode()
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except ConfigError as e:
        print(f'jacket_cloth_node: {e}', file=sys.stderr)
        return 1
    finally:
        if node is not None:
            node.close()
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
