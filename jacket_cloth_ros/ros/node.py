# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The jacket node: JointState in; jacket and hood bones on /tf, markers, diagnostics out.

One class for ``jacket_cloth_node`` (one character, its parameters the node's own) and
``jacket_cloth_crowd`` (ros/crowd.py: the characters of a characters file). Each character
(ros/character.py) has its own input, outputs, resets, warnings and recording channels; the
node has what is one per process: parameters, ``~/viewer``, /tf and /diagnostics, the
recording (ros/recording.py, which the node hands what it records), the diagnostics
watchdog, and one CrowdInputs taking every character's JointStates
each executor wake-up, processed as one batch (ros/pipeline.py's CrowdPipeline: the steps of
every character with an input in one compiled call over the cores; a lone character's alone).
"""

import argparse
import functools
import gc
import os
import sys
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rcl_interfaces.msg import SetParametersResult
from std_msgs.msg import String
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PointStamped, Vector3Stamped
from tf2_msgs.msg import TFMessage

from .. import signals
from ..core.config import ConfigError, MissingLink, read_text, shown
from ..core.fabric import load_fabrics
from ..core.rig import load_rig
from ..core.skeleton import Skeleton, shipped_character_urdf
from ..core.stepping import NOT_STEADY
from . import cdr, messages
from .character import (NO_PUB_EVENTS, NO_SUB_EVENTS, TF_QOS, Character, CrowdInputs,
                        cut_line, input_problems, throttled)
from .characters import CharacterSpec, crowd_slice, load_characters
from .clock_watch import ClockWatch, guard_clock
from .parameter_services import guard_parameter_services
from .parameters import (CROWD_PARAMETERS, NODE_PARAMETERS, ROS_OWN, ROS_OWN_PREFIXES,
                         check_value, descriptor, fabric_parameters,
                         params_file_for_another_node, params_file_problem, ros_args_problem,
                         unknown_reason)
from .pipeline import CrowdPipeline, Periodic, SessionPipeline, session_topics, spread_phase
from .recording import NodeRecording
from .values import VALUE_NAMES, default_values
from .viewer import VIEWER_LIVE_QOS, VIEWER_QOS, Deliveries, read_viewer
from .warm import kernels_cached
from .warm import warm_kernels

if TYPE_CHECKING:           # for the annotations only
    from rclpy.publisher import Publisher


def keep_loaded_out_of_collections() -> None:
    """Move every object alive now out of the cyclic garbage collector's reach (gc.freeze).

    Called once a character is loaded: rclpy, numba's dispatchers and the models live as long
    as the node, and a full collection that walked them all paused every input behind it.
    """
    gc.freeze()


def tf_publisher(node: Node) -> 'Publisher':
    """Return ``node``'s /tf publisher (the jacket node's, and its floor's in the lab).

    :param node: the node publishing.
    """
    return node.create_publisher(TFMessage, '/tf', TF_QOS)


def diagnostics_publisher(node: Node) -> 'Publisher':
    """Return ``node``'s /diagnostics publisher, without QoS event handlers.

    :param node: the node publishing.
    """
    return node.create_publisher(DiagnosticArray, '/diagnostics', 10,
                                 event_callbacks=NO_PUB_EVENTS)


class JacketClothNode(Node):
    """Runs the fixed-step jacket and hood simulation of each character on its JointStates.

    Either way every character runs the same code (ros/character.py and
    :meth:`on_joint_states`). A recording write error stops the recording, not the node.

    :param crowd: False: ``jacket_cloth_node``, one character whose parameters are the node's
        (NODE_PARAMETERS and ``fabric.*``, changed live, the wind also by ``~/wind``), its
        topics relative to the node's namespace. True: ``jacket_cloth_crowd``, the characters
        of the file in its ``characters`` parameter (CROWD_PARAMETERS), each under its own
        namespace.
    :param exiting: a refused start leaves its rclpy node to the process's end, which comes at
        once (the executables): destroying it now and then crashed rclpy (a segfault after
        the refusal's line). False: destroyed before the refusal is raised, for a process
        that goes on.
    :param kwargs: rclpy Node's keyword arguments (context, parameter_overrides...).
    """

    def __init__(self, crowd: bool = False, exiting: bool = False, **kwargs: object):
        self.program = 'jacket_cloth_crowd' if crowd else 'jacket_cloth_node'
        super().__init__(self.program, **kwargs)
        try:
            self._set_up(crowd)
        except BaseException:
            # A refused start takes down what it made while rclpy still runs: left to the
            # interpreter's exit, after rclpy's shutdown, the half-made node crashed it there.
            if hasattr(self, 'recording'):
                self.close()
            if not exiting:
                self.destroy_node()
            raise

    def _set_up(self, crowd):
        """Everything the node holds beyond rclpy's Node; ConfigError where a start is refused."""
        # Before anything is opened: a file for another node set nothing (rcl says nothing).
        problem = params_file_for_another_node(sys.argv, self.get_fully_qualified_name())
        if problem:
            raise ConfigError(problem)
        self._viewer = None             # the last accepted ~/viewer: (raw, stamp)
        self._last_stamp = None         # the last accepted input's, for recording after it
        self._log_times = {}            # the node's own warnings (each character has its own)
        self._models = {}               # (URDF, rig file) -> (skeleton, rig), shared read-only
        self._fabrics = {}              # fabrics file -> its presets
        self._told_compiling = False
        self._every = 1                 # the characters of the file (a crowd slices them)
        # False: the watchdog's diagnostics are recorded when they say something new (the
        # stamp left out); True: when they differ at all, the stamp too, so an idle node's are
        # recorded every tick, as before issue 48 (benchmarks/idle_recording.py compares).
        self.record_repeated_diagnostics = False
        # The watchdog and the robot_description fallback run on wall time: with use_sim_time
        # a simulator not started or paused stops the node's clock, and they must not stop.
        self._wall = Clock(clock_type=ClockType.STEADY_TIME)
        self._clock_watch = ClockWatch(self._say_clock)
        guard_clock(self, self._warn)
        # Messages on the other subscriptions, and those of them refused (undecodable, invalid).
        self.received = dict.fromkeys(('wind', 'viewer', 'robot_description'), 0)
        self.refused = dict.fromkeys(('wind', 'viewer', 'robot_description'), 0)
        guard_parameter_services(self, self._log_times)
        # The characters first: a parameter or a characters file refused stops the node here.
        if crowd:
            self.characters, urdfs = self._crowd_characters()
        else:
            self.characters, urdfs = self._own_character()
        self.tf = tf_publisher(self)
        self.diagnostics = diagnostics_publisher(self)
        # Recorded under the names the topics have in the graph (resolved once).
        topics = session_topics(viewer=self._subscribe_viewer())
        node_wide = ['tf', 'diagnostics', 'viewer']
        if not crowd:               # the wind, and parameter changes, of the one character
            self.create_subscription(Vector3Stamped, '~/wind', self._on_wind, 10, raw=True,
                                     event_callbacks=NO_SUB_EVENTS)
            topics['wind'] = (self.resolve_topic_name('~/wind'), *topics['wind'][1:])
            node_wide += ['wind', 'parameter_events']
        self._topics = {k: topics[k] for k in node_wide}
        self.crowd = CrowdPipeline(self._p('threads') if crowd else 1)
        # Looked up at each call: a harness may wrap the node's on_joint_states.
        self._inputs = CrowdInputs(self.default_callback_group,
                                   lambda taken: self.on_joint_states(taken))
        self.add_waitable(self._inputs)
        self.recording = NodeRecording(self._topics, self.characters, self.get_logger(),
                                       program=self.program, alive=self.context.ok)
        self._record_to(self._p('record'))
        for c, (urdf, source) in zip(self.characters, urdfs):
            if urdf is not None:        # a file named, even an empty one: never the topic's
                try:
                    self._load(c, urdf, source)
                except ConfigError as e:
                    raise ConfigError(f'{c.label}{e}') from None
            else:
                c.wait_for_description(self, self._on_description, self._use_shipped,
                                       self._wall)
        # Diagnostics keep their own rate when inputs stop or nothing else is published.
        self._watchdog_tick = time.monotonic()
        self._diag_timer = self.create_timer(1.0 / self._diagnostics_rate(),
                                             self._diagnostics_watchdog, clock=self._wall)
        if crowd:
            self.get_logger().info(
                f'{len(self.characters)} of {self._every} characters (slice '
                f'{self._p("slice_index")} of {self._p("slice_count")}), steps on '
                f'{self.crowd.steps.threads} thread(s)')

    # -- set-up -------------------------------------------------------------------------------
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

    def _refuse_unknown(self):
        """Refuse a parameter given (a params file, -p) but not declared, which rclpy drops."""
        declared = set(self.list_parameters([], 0).names)
        for name in sorted(self._parameter_overrides):
            if name not in declared and name not in ROS_OWN and \
                    not name.startswith(ROS_OWN_PREFIXES):
                raise ConfigError(unknown_reason(name, declared, self.get_name()))

    def _p(self, name):
        return self.get_parameter(name).value

    def _own_character(self):
        """jacket_cloth_node's one character: the node's parameters, its topics relative."""
        for name, spec in NODE_PARAMETERS.items():
            self._declare(name, spec)
        fabric_file = self._p('fabric_file') or None
        fabrics = self._fabrics_of(fabric_file)
        preset = self._p('fabric_preset')
        if preset not in fabrics:
            raise ConfigError(f'parameter fabric_preset: {preset!r} is not a preset '
                              f'(presets: {", ".join(fabrics)})')
        for name, spec in fabric_parameters(fabrics[preset]).items():
            self._declare(name, spec)
        self._refuse_unknown()
        self.add_on_set_parameters_callback(self._validate_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)
        try:
            values = default_values(fabrics[preset], preset).with_changes(self._values())
        except ValueError as e:     # within rclpy's tolerance of a range, outside it
            raise ConfigError(f'parameter {e}') from None
        spec = CharacterSpec(self.get_name(), None, self._p('rig_file') or None, fabric_file,
                             values)
        # Relative, as robot_state_publisher publishes it: under a namespace the node hears
        # its own character's description, not another's.
        names = {'joint_states': 'joint_states', 'robot_description': 'robot_description',
                 'markers': '~/markers'}
        recorded = {k: self.resolve_topic_name(names[k]) for k in ('joint_states', 'markers')}
        urdf = self._p('robot_description') or None         # empty: the topic's
        return [Character(spec, names, recorded)], [(urdf, 'the robot_description parameter')]

    def _crowd_characters(self):
        """jacket_cloth_crowd's characters: its slice of the characters file."""
        for name, spec in CROWD_PARAMETERS.items():
            self._declare(name, spec)
        self._refuse_unknown()
        self.add_on_set_parameters_callback(self._validate_parameters)
        path = self._p('characters')
        if not path:
            raise ConfigError('parameter characters: give the characters file '
                              '(-p characters:=crowd.yaml)')
        every = load_characters(path)
        self._every = len(every)
        characters, urdfs = [], []
        for spec in crowd_slice(every, self._p('slice_index'), self._p('slice_count')):
            ns = spec.namespace
            names = {'joint_states': f'{ns}/joint_states',
                     'robot_description': f'{ns}/robot_description',
                     'markers': f'{ns}/jacket_cloth_node/markers'}
            # Recorded under its own names, whatever the remapping: a crowd's replay finds
            # each character's inputs by its name.
            characters.append(Character(spec, names, names, f'{spec.name}: ', spec.name))
            urdfs.append((read_text(spec.urdf, 'URDF'), spec.urdf) if spec.urdf
                         else (None, None))
        return characters, urdfs

    def _fabrics_of(self, path):
        if path not in self._fabrics:
            self._fabrics[path] = load_fabrics(path)
        return self._fabrics[path]

    def _values(self, params=None):
        """Return a character's parameters by name, arrays as lists: rclpy's, or ``params``.

        Only the character's (VALUE_NAMES), not rclpy's own (``use_sim_time``...).
        """
        if params is None:
            params = [self.get_parameter(n) for n in VALUE_NAMES if self.has_parameter(n)]
        return {p.name: list(p.value) if p.type_ == Parameter.Type.DOUBLE_ARRAY else p.value
                for p in params if p.name in _CHARACTER_NAMES}

    def _diagnostics_rate(self):
        return max((c.values.diagnostics_rate for c in self.characters), default=1.0)

    # -- characters ---------------------------------------------------------------------------
    def _on_description(self, c, raw):
        self.received['robot_description'] += 1
        if c.pipeline is not None:
            return
        topic = c.description.topic_name
        try:
            msg = cdr.deserialize(raw, String)
        except cdr.DECODE_ERRORS as e:
            self.refused['robot_description'] += 1
            c.warn(self.get_logger(), 'description_decode', f'a {topic} that does not decode '
                   f'({e}): message dropped')
            return
        try:
            self._load(c, msg.data, f'the {topic} topic')
        except ConfigError as e:
            self.refused['robot_description'] += 1
            # Someone publishes this character's URDF: a corrected one is waited for, not
            # replaced by the shipped character, and diagnostics say why nothing runs.
            c.fallback.cancel()
            c.waiting = cut_line(f'{topic} rejected: {e}')
            self.get_logger().error(cut_line(f'{c.label}{c.waiting}; waiting for a corrected '
                                             'one'))

    def _use_shipped(self, c):
        c.fallback.cancel()             # once, even if the shipped one fails to load
        if c.pipeline is not None:
            return
        try:
            self._load(c, shipped_character_urdf(),
                       'the shipped character (config/character.urdf)')
        except ConfigError as e:
            # A rig naming links the shipped character lacks is another robot's, whose URDF
            # may come late (the node started before robot_state_publisher): waited for.
            if len(self.characters) == 1 and not isinstance(e, MissingLink):
                raise                   # the node has nothing else to run: one line, exit 1
            # One character's set-up must not stop the others: it waits for its topic.
            c.waiting = cut_line(f'no URDF on {c.description.topic_name} yet, and the '
                                 f'shipped character could not be set up in its place ({e})')
            self.get_logger().error(f'{c.label}{c.waiting}: waiting for the topic')

    def _load(self, c, urdf, source):
        if not self._told_compiling and not kernels_cached(crowd=len(self.characters) > 1):
            self._told_compiling = True
            self.get_logger().info(
                'compiling the simulation kernels into numba\'s cache: a first start after an '
                'install or an edit of a kernel takes about half a minute (`jacket_cloth warm` '
                'does it ahead)')
        spec = c.spec
        c.read_setup()
        # Characters of one URDF and rig share them (read-only): loaded once, not per copy.
        key = (urdf, spec.rig)
        if key not in self._models:
            skeleton = Skeleton(urdf)
            self._models[key] = (skeleton, load_rig(skeleton, spec.rig))
        skeleton, rig = self._models[key]
        pipeline = SessionPipeline(skeleton, rig,
                                   c.values, self._diagnostics_owner(c), timing=True,
                                   output_phase=spread_phase(len(self.crowd.pipelines)))
        # frame_prefix goes on bones and links alike, so only the rig's names can clash.
        clash = set(pipeline.sim.bone_names) & set(skeleton.link_names)
        if clash:
            raise ConfigError(f'bone frame(s) {", ".join(sorted(clash))} would republish URDF '
                              'links: rename them in the rig (name, below_name)')
        # jacket_cloth_node listens on after a URDF from its topic or the shipped one, to say
        # that a different one later is not taken; a crowd's characters do not (one reader
        # each).
        c.attach(self, pipeline, self.crowd.add(pipeline), urdf, self._markers_wanted,
                 None if self.program == 'jacket_cloth_crowd' else
                 self._inputs.taken_elsewhere)
        c.source = source
        for line in pipeline.sim.faults.rig:        # the rig's own, before any input
            self.get_logger().warning(c.label + line)
        if c.values.publish_world_tf and pipeline.root_is_world_frame():
            self.get_logger().info(
                f'{c.label}the URDF root {pipeline.root_frame()!r} is world_frame itself: '
                'publish_world_tf publishes no transform to it (the world is not its own child)')
        self.recording.add_character(c)
        keep_loaded_out_of_collections()
        # Subscribed only now: a publisher that waits for us knows we can simulate.
        c.subscription = self._inputs.subscribe(self, c, c.names['joint_states'])
        self.get_logger().info(
            f'{c.label}character {skeleton.name!r} from {source}: '
            f'{len(skeleton.joint_names)} joints, cloth {rig.cols}x{rig.rows}, '
            f'{len(pipeline.sim.bone_names)} bones under {skeleton.link_names[0]!r}')

    def _diagnostics_owner(self, c: Character) -> str:
        """Return what a character's diagnostics status name starts with, unique in the graph.

        The node's fully qualified name (two namespaced nodes are two names), and in a crowd the
        character's name after it.
        """
        owner = self.get_fully_qualified_name()
        return f'{owner}: {c.spec.name}' if c.config_name else owner

    # -- parameters (jacket_cloth_node: its character's) --------------------------------------
    def _validate_parameters(self, params):
        for p in params:
            # rclpy lets an empty name through as undeclared (its check tests names for truth).
            if not self.has_parameter(p.name):
                return SetParametersResult(successful=False,
                                           reason=f'parameter {shown(p.name)} is not declared')
            if p.name == 'wind' and p.type_ != Parameter.Type.DOUBLE_ARRAY:
                return SetParametersResult(successful=False,
                                           reason='wind must be 3 finite numbers [x, y, z]')
            reason = check_value(p.name, p.value) or \
                (self.recording.refusal(p.value) if p.name == 'record' else '')
            if reason:
                return SetParametersResult(successful=False, reason=reason)
        if self.program == 'jacket_cloth_node':
            # The bundle the change makes must be one (_apply_parameters makes it, after the
            # change is taken): its checks are those above, so it refuses nothing more.
            try:
                self.characters[0].values.with_changes(self._values(params))
            except ValueError as e:
                return SetParametersResult(successful=False, reason=str(e))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, params):
        """Apply valid changes from the next step; they never reset the cloth."""
        names = {p.name for p in params}
        c = self.characters[0]
        # The character's bundle made anew from rclpy's values (checked by
        # _validate_parameters), handed whole to its pipeline once it has one; before a new
        # file opens, whose set-up holds them.
        c.set_values(c.values.with_changes(self._values(params)))
        if 'record' in names and self.recording.needs_open(self._p('record')):
            self._record_to(self._p('record'))
        if 'diagnostics_rate' in names:
            self._diag_timer.timer_period_ns = int(1e9 / self._diagnostics_rate())
        if c.pipeline is None:
            return
        # Recorded at the last input's stamp: a replay applies them after the same input.
        stamp = self._last_input_stamp(0)
        self.recording.write(self._topics['parameter_events'][0], cdr.parameter_event(
            stamp, self.get_fully_qualified_name(), [p.to_parameter_msg() for p in params]),
            stamp)

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
        self.recording.write(self._topics['wind'][0], raw, self._last_input_stamp(header))

    # -- recording (ros/recording.py) --------------------------------------------------------
    def _record_to(self, path):
        """Record to ``path`` from now ('' : no more); a new file starts with the last viewer."""
        if self.recording.open(path, compression=self._p('record_compression')):
            self._record_viewer()

    def _markers_wanted(self, publisher: 'Publisher') -> bool:
        """Tell whether markers due now have a reader: a subscriber or the recording.

        Unread, building them was a large share of each input (docs/crowd.md); their cadence
        goes on either way, so a viewer that subscribes gets them on the same ticks.
        """
        return self.recording.recorder is not None or publisher.get_subscription_count() > 0

    def close(self) -> None:
        """Close the recording, if any."""
        self.recording.close()

    # -- the viewer (one for the node, whatever the characters) ------------------------------
    def _warn(self, code, text, period=5.0):
        """One line per kind of bad input to the node itself per ``period`` seconds."""
        throttled(self.get_logger(), self._log_times, code, text, period)

    def _subscribe_viewer(self) -> str:
        """Subscribe ``~/viewer``; returns its name in the graph, the one it is recorded under.

        Twice (ros/viewer.py): latched, so a viewer published once before the node started
        reaches it; volatile, so a default publisher (``ros2 topic pub``) does too.
        """
        self._viewer_deliveries = Deliveries()
        for qos in (VIEWER_QOS, VIEWER_LIVE_QOS):
            latched = qos is VIEWER_QOS
            self.create_subscription(
                PointStamped, '~/viewer',
                lambda raw, info, latched=latched: self._on_viewer_delivery(raw, info, latched),
                qos, raw=True, event_callbacks=NO_SUB_EVENTS)
        return self.resolve_topic_name('~/viewer')

    def _on_viewer_delivery(self, raw: bytes, info: dict, latched: bool = False) -> None:
        """Take a ``~/viewer`` message once, whichever of its subscriptions brings it first.

        A latched one stamped before the viewer taken is a latched publisher's old message,
        delivered late (its history): dropped. Its live messages come on the volatile
        subscription too, so they are taken whatever their stamps.
        """
        if latched and self._viewer is not None and \
                0 < read_viewer(raw, '').stamp_ns < self._viewer[1]:
            return
        if self._viewer_deliveries.first(info):
            self._on_viewer(raw)

    def _on_viewer(self, raw):
        """~/viewer: the viewer's world position for the level of detail, from the next input.

        Each character's level goes by its own distance to it, if the viewer is in its world
        frame. Recorded as an input at the last input's stamp: a replay applies it at the same
        point.
        """
        self.received['viewer'] += 1
        frames = sorted({c.values.world_frame for c in self.characters})
        readings = [read_viewer(raw, frame) for frame in frames]
        if all(r.position is None for r in readings):
            self.refused['viewer'] += 1
            self._warn('viewer', f'~/viewer rejected: {readings[0].reason}; the last viewer '
                       'is kept')
            return
        self._viewer = (bytes(raw), readings[0].stamp_ns)
        for frame, reading in zip(frames, readings):
            if reading.position is None:
                continue
            for c in self.characters:
                if c.values.world_frame == frame:
                    c.viewer = reading.position
                    if c.pipeline is not None:
                        c.pipeline.set_viewer(reading.position)
        self._record_viewer()

    def _record_viewer(self):
        """Record the last accepted viewer, if any; a file opened after it starts with it."""
        if self._viewer is not None:
            raw, stamp = self._viewer
            self.recording.write(self._topics['viewer'][0], raw, self._last_input_stamp(stamp))

    def _last_input_stamp(self, default):
        return default if self._last_stamp is None else self._last_stamp

    # -- the inputs ---------------------------------------------------------------------------
    @signals.whole          # an input's /tf goes out, then it is recorded, even on a Ctrl-C
    def on_joint_states(self, batch: list) -> None:
        """Process (character, raw bytes, message info) JointStates together, as one batch.

        CrowdInputs hands it every input of an executor wake-up, each character's backlog
        included. Public so a harness can feed the node without DDS, as the lab does. An
        input's latency counts from its info's ``received_timestamp`` (ns, system clock: the
        rmw's receive time, so time queued behind other callbacks is in it), else from now.

        :param batch: (character, raw CDR bytes, rmw message info) of each input, in order.
        """
        try:
            if len(batch) == 1 and len(self.crowd.pipelines) == 1:
                self._alone(*batch[0])
            else:       # a backlog, or a crowd: every input counted and stepped, then sent
                self._joint_states(batch)
        finally:
            signals.raise_held()

    def _alone(self, c, raw, info):
        """Process a lone character's one input; a steady one's /tf goes out before the rest.

        Straight from its bytes (SessionPipeline.steady_tf), its bookkeeping after; any other
        input the crowd's way for one.
        """
        arrived = info.get('received_timestamp') or time.time_ns()
        pipeline = c.pipeline
        status, stamp, sent = pipeline.steady_tf(raw)
        if sent is not None:
            self.tf.publish(sent)
            pipeline.note_latency(time.time_ns() - arrived)
        c.count_lost(info)
        if status != NOT_STEADY:
            report, tf = pipeline.after_steady(status, stamp, sent)
            later = Periodic(pipeline, report, stamp)
        else:
            msg = self._read(c, raw)
            if msg is None:
                return
            stamp = msg.stamp_ns
            report, tf, later = self.crowd.alone(msg, True)
        if sent is None and tf:
            for _, out in tf:
                self.tf.publish(out)
            pipeline.note_latency(time.time_ns() - arrived)
        c.inputs += 1
        self._record_inputs([(c, raw, stamp, report, tf, later)])

    def _read(self, c, raw):
        """Return a JointState's content, or None (counted and said) if it does not decode."""
        try:
            return c.pipeline.reader.read(raw)
        except cdr.DECODE_ERRORS as e:
            c.pipeline.note_undecodable()
            c.warn(self.get_logger(), 'decode', f'a JointState that does not decode ({e}): '
                   'message dropped')
            return None

    def _joint_states(self, batch):
        """Process a crowd's inputs, or a backlog: stepped together, all /tf out first."""
        now = time.time_ns()
        entries = []
        for c, raw, info in batch:
            c.count_lost(info)
            msg = self._read(c, raw)
            if msg is None:
                continue
            c.inputs += 1
            entries.append((c, raw, msg, info.get('received_timestamp') or now))
        if not entries:
            return
        results = self.crowd.step_and_tf([(c.index, msg) for c, _, msg, _ in entries])
        # Every character's /tf first: a listener waits for it, not for markers or diagnostics.
        # Latency, once per input: arrival to its last /tf handed to DDS (publish_world_tf
        # sends two).
        for (c, _, _, arrived), (_, tf, _) in zip(entries, results):
            if tf:
                for _, out in tf:
                    self.tf.publish(out)
                c.pipeline.note_latency(time.time_ns() - arrived)
        self._record_inputs([(c, raw, msg.stamp_ns, *result)
                             for (c, raw, msg, _), result in zip(entries, results)])

    def _record_inputs(self, entries):
        """After a batch's /tf: each input recorded, its warnings said, its other outputs sent.

        :param entries: (character, raw bytes, stamp ns, report, /tf outputs, later) each.
        """
        logger = self.get_logger()
        for c, raw, stamp_ns, report, tf, later in entries:
            if report.accepted:
                self._last_stamp = stamp_ns
            periodic = later()
            self.recording.write(c.topics['joint_states'][0], raw, stamp_ns)
            for code, text in input_problems(report, bool(tf)):
                c.warn(logger, code, text)
            for _, out in tf:
                self.recording.write(self._topics['tf'][0], out, stamp_ns)
            for key, out in periodic:
                if key == 'markers':
                    c.markers.publish(out)
                    self.recording.write(c.topics['markers'][0], out, stamp_ns)
                else:
                    self.diagnostics.publish(out)
                    c.diag_wall = time.monotonic()
                    c.diag_recorded = None
                    self.recording.write(self._topics['diagnostics'][0], out, stamp_ns)

    def _diagnostics_watchdog(self):
        """Diagnostics of each character whose inputs' own have not gone out since the last tick.

        On wall time (its timer's clock), as is what else it looks at once a tick: the node's
        clock (simulated time), a late URDF, the recording's file.
        """
        now = time.monotonic()
        since, self._watchdog_tick = self._watchdog_tick, now
        clock_ns = self.get_clock().now().nanoseconds
        self._clock_watch.tick(now, self.get_clock().ros_time_is_active, clock_ns)
        tick = self._diag_timer.timer_period_ns * 1e-9
        for c in self.characters:
            if c.pipeline is None and c.waiting:
                out = messages.diagnostics(
                    clock_ns, self._diagnostics_owner(c), {},
                    messages.ERROR, f'no character: {c.waiting}; waiting for its topic')
                self.diagnostics.publish(out)
                continue
            if c.pipeline is None:
                continue
            late = c.late_description()
            if late is not None:
                self._on_late_description(c, late)
            # Due when none went out since the last tick and its own period is (nearly) over:
            # 1.2 periods since the last ones halved the rate (each tick came one period on).
            if c.diag_wall > since or \
                    now - c.diag_wall < 1.0 / c.values.diagnostics_rate - tick / 2:
                continue
            last = c.sim.last
            stamp_ns = last.stamp_ns if last else clock_ns
            out = c.pipeline.diagnostics_now(stamp_ns)
            self.diagnostics.publish(out)
            c.diag_wall = now
            # Recorded when they say something new: without inputs they repeat at one stamp
            # (an idle crowd's filled a file by the hour). The stamp is the first 8 bytes.
            said = out if self.record_repeated_diagnostics else out[_DIAG_STAMP_END:]
            if said != c.diag_recorded:
                c.diag_recorded = said
                self.recording.write(self._topics['diagnostics'][0], out, stamp_ns)
        self.recording.check_file()

    def _say_clock(self, level, line):
        # rclpy's logger takes one severity per line of code: a call each.
        if level == 'warn':
            self.get_logger().warning(line)
        else:
            self.get_logger().info(line)

    def _on_late_description(self, c, raw):
        """Tell of a URDF on a loaded character's topic: nothing if the same, else one line."""
        self.received['robot_description'] += 1
        topic = c.description.topic_name
        try:
            text = cdr.deserialize(raw, String).data
        except cdr.DECODE_ERRORS as e:
            self.refused['robot_description'] += 1
            c.warn(self.get_logger(), 'description_decode', f'a {topic} that does not decode '
                   f'({e}): message dropped')
            return
        told = hash(text)
        if text == c.urdf:          # the one it runs after all: nothing wrong any more
            self._character_problem(c, '')
            return
        if told == c.told_description[0]:      # said once: the diagnostics say it again
            self._character_problem(c, c.told_description[1])
            return
        self.refused['robot_description'] += 1
        try:        # a restart would refuse one that does not load: not the advice to give
            Skeleton(text)
            line = (f'a different URDF came on {topic}: not taken, the node keeps the '
                    f'character it runs (from {c.source}); restart the node to take it')
        except ConfigError as e:
            line = cut_line(f'a URDF that does not load came on {topic} ({e}): not taken, the '
                            f'node keeps the character it runs (from {c.source})')
        c.told_description = (told, line)
        self.get_logger().warning(c.label + line)
        self._character_problem(c, line)

    @staticmethod
    def _character_problem(c, line):
        """Let the character's diagnostics say ``line`` while it holds ('' : nothing)."""
        if c.pipeline is not None:
            c.pipeline.character_problem = line


_CHARACTER_NAMES = frozenset(VALUE_NAMES)
# CDR encapsulation (4 bytes) and the header's stamp (8): what follows is what diagnostics say.
_DIAG_STAMP_END = 12


def main(args: list[str] | None = None) -> int:
    """Run the jacket_cloth_node node until it is stopped; its exit code.

    :param args: the command line with its ROS arguments; None: the process's.
    """
    argv = sys.argv if args is None else args
    parser = argparse.ArgumentParser(
        prog='jacket_cloth_node',
        description='Jacket and hood secondary motion: subscribes joint_states '
        '(sensor_msgs/JointState), publishes bones on /tf, ~/markers and /diagnostics. '
        'Parameters are set with --ros-args -p name:=value (see README).')
    problem = ros_args_problem(argv)
    if problem:                 # rcl's own error is a traceback
        print(f'jacket_cloth_node: {problem}', file=sys.stderr)
        return 1
    parser.parse_args(rclpy.utilities.remove_ros_args(argv)[1:])
    return run('jacket_cloth_node', functools.partial(JacketClothNode, exiting=True), argv,
               crowd=False)


def run(program: str, make_node: Callable[[], Node], argv: list[str], crowd: bool) -> int:
    """Compile the kernels if need be, then spin ``make_node()`` until shutdown; the exit code.

    Shared by jacket_cloth_node and jacket_cloth_crowd.

    :param program: the executable's name, which its messages start with.
    :param make_node: makes the node, after rclpy.init.
    :param argv: the command line with its ROS arguments.
    :param crowd: whether the node is a crowd's: its one call is compiled too.
    """
    # A signal before the node runs ends it with one line (jacket_cloth_ros.signals); the
    # kernels are compiled here, before rclpy takes SIGINT: in a callback, Ctrl-C only shut
    # the context down and the compile ran on for half a minute.
    signals.guard(program)
    problem = params_file_problem(argv)
    if problem:                 # before the compile: a typo is told at once
        print(f'{program}: {problem}', file=sys.stderr)
        return 1
    if not kernels_cached(crowd=crowd):
        # Stopped at once: numba writes each cache file whole or not at all. Named before it
        # is said, so a signal on the line's heels is told as the compile's.
        signals.doing('compiling the kernels')
        print(f'{program}: compiling the simulation kernels into numba\'s cache (a first '
              'start after an install or an edit of a kernel; about a minute; '
              '`jacket_cloth warm` does it ahead)', file=sys.stderr)
        warm_kernels(crowd=crowd)
        signals.doing('starting')
    rclpy.init(args=argv)
    node = None
    refused = False
    try:
        node = make_node()
        signals.running()
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except ConfigError as e:
        print(f'{program}: {e}', file=sys.stderr)
        if node is None:
            # Refused while made: nothing was written, and neither the half-made node nor
            # rclpy is torn down (see JacketClothNode's ``exiting``).
            sys.stderr.flush()
            os._exit(1)
        refused = True
    except Exception:
        if rclpy.ok():
            raise
        # A signal shut the context down while a callback was still working: stopping.
    finally:
        signals.stopping()
        if node is not None:
            node.close()
            node.destroy_node()
        rclpy.try_shutdown()
    if refused:
        # Nothing is left to tear down, and the interpreter's teardown of rclpy's extension
        # modules now and then crashed a refused start after its line (a segfault, exit -11).
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(1)
    return 0


if __name__ == '__main__':
    sys.exit(main())
