# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""One character of a jacket node, and how the node takes every character's JointStates.

A ``Character`` is what one jacketed character has of its own in the node (ros/node.py), alone
(jacket_cloth_node) or in a crowd (jacket_cloth_crowd): its set-up, its pipeline once its URDF
is known, its ``joint_states`` subscription, its ``robot_description`` wait and the shipped
character's fallback, its markers publisher, its counts of lost inputs, its throttled warnings
and its channels in the recording. ``CrowdInputs`` takes the JointStates of all of them.
"""

import time
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING

from rclpy.callback_groups import CallbackGroup
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.qos import (
    DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data)
from rclpy.waitable import NumberOfEntities, Waitable
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from visualization_msgs.msg import MarkerArray

from ..core.config import read_text, shipped
from .characters import CharacterSpec
from .pipeline import session_topics

if TYPE_CHECKING:           # for the annotations only
    from rclpy.clock import Clock
    from rclpy.impl.rcutils_logger import RcutilsLogger
    from rclpy.node import Node
    from rclpy.subscription import Subscription

    from ..core.simulation import JacketSimulation, StepReport
    from ..recording.writer import SessionRecorder
    from .pipeline import SessionPipeline
    from .values import NodeValues

TF_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.VOLATILE, history=HistoryPolicy.KEEP_LAST)
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
# rclpy gives each publisher and subscription two QoS event handlers (incompatible QoS, type),
# and its executor visits every one on every wake-up. /tf keeps its own, as a mismatch there
# must be heard; the rest go without (the peer's side warns too), which lowers the node's CPU
# per message (docs/performance.md). joint_states is best effort and volatile: it matches
# every publisher's QoS.
NO_PUB_EVENTS = PublisherEventCallbacks(use_default_callbacks=False)
NO_SUB_EVENTS = SubscriptionEventCallbacks(use_default_callbacks=False)


# A log line about an input is cut to this: what a client sends may be megabytes.
MAX_LINE = 1000


def throttled(logger: 'RcutilsLogger', log_times: dict, code: str, text: str,
              period: float = 5.0) -> None:
    """Warn ``text`` at most once per ``period`` seconds per ``code`` of ``log_times``.

    :param logger: the node's logger.
    :param log_times: each code's last warning (monotonic s), updated here.
    :param code: the kind of warning.
    :param text: the line.
    :param period: the least time between two warnings of one code, s.
    """
    now = time.monotonic()
    if now - log_times.get(code, -1e9) >= period:
        log_times[code] = now
        logger.warning(cut_line(text))


def cut_line(text: str) -> str:
    """Return ``text`` cut to ``MAX_LINE`` characters, saying so.

    :param text: a log line.
    """
    return text if len(text) <= MAX_LINE else f'{text[:MAX_LINE]}... (cut)'


class Character:
    """One character of a jacket node: its set-up, and its pipeline once its URDF is known.

    :param spec: its set-up, as the characters file (or the node's parameters) gives it.
    :param names: its topics in the graph (``joint_states``, ``robot_description``,
        ``markers``).
    :param recorded: the names its JointStates and markers are recorded under.
    :param label: what its log lines start with (its name in a crowd).
    :param config_name: the name of its set-up in the recording ('' alone: the single session
        a replay reads).
    """

    def __init__(self, spec: CharacterSpec, names: dict[str, str], recorded: dict[str, str],
                 label: str = '', config_name: str = ''):
        self.spec = spec
        self.names = names
        self.topics = session_topics(recorded['joint_states'], markers=recorded['markers'])
        self.label = label
        self.config_name = config_name
        self.index = -1                 # in the node's CrowdPipeline, once loaded
        self.pipeline: 'SessionPipeline | None' = None
        self.viewer = None              # the last ~/viewer in its world frame, for a late load
        self.urdf = None
        self.setup_texts = ('', '')     # its rig's and fabrics' texts, read at its load
        self.subscription = None        # joint_states, once loaded
        self.markers = None             # its markers publisher, once loaded
        self.description = self.fallback = None     # while it waits for its URDF
        self.source = ''                # where its URDF came from, for the log
        # The hash of the last late URDF said to be ignored, and what was said.
        self.told_description: tuple = (None, '')
        self.waiting = ''               # why it still waits: the URDF its topic gave, refused
        self.inputs = 0
        self.log_times = {}             # its throttled warnings: code -> when last logged
        self.diag_wall = 0.0            # when its diagnostics last went out (monotonic)
        self.diag_recorded = None       # what the watchdog's last recorded ones said
        self._sequences = {}            # publisher gid -> the last sequence number it sent

    @property
    def values(self) -> 'NodeValues':
        """Return its parameter values: its pipeline's once loaded, else its set-up's."""
        return self.spec.values if self.pipeline is None else self.pipeline.values

    def set_values(self, values: 'NodeValues') -> None:
        """Take changed parameter values: its pipeline's from the next input, once loaded.

        :param values: its values now, made from :attr:`values`.
        """
        if self.pipeline is None:
            self.spec = replace(self.spec, values=values)
        else:
            self.pipeline.apply(values)

    @property
    def sim(self) -> 'JacketSimulation | None':
        return self.pipeline.sim if self.pipeline else None

    def warn(self, logger: 'RcutilsLogger', code: str, text: str, period: float = 5.0) -> None:
        """One line per kind of bad input of this character per ``period`` seconds.

        :param logger: the node's logger.
        :param code: the kind of bad input.
        :param text: the line, after the character's label.
        :param period: the least time between two lines of one kind, s.
        """
        throttled(logger, self.log_times, code, self.label + text, period)

    def count_lost(self, info: dict) -> None:
        """Count a gap in a publisher's numbering as JointStates lost before they came.

        :param info: the message's rmw message info (publisher gid, sequence number).
        """
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

    def wait_for_description(self, node: 'Node', on_description: Callable,
                             on_timeout: Callable, wall: 'Clock') -> None:
        """Subscribe its robot_description, and fall back on the shipped one after its timeout.

        Raw: bytes that are no String reach ``on_description``, which says so, not the executor.

        :param node: the node subscribing.
        :param on_description: called with (character, raw bytes) when a description comes.
        :param on_timeout: called with the character when its timeout passes first.
        :param wall: the clock the timeout runs on: wall time, which a simulator not started
            (``use_sim_time`` without /clock) does not stop.
        """
        self.description = node.create_subscription(
            String, self.names['robot_description'], lambda raw: on_description(self, raw),
            LATCHED, raw=True)
        self.fallback = node.create_timer(self.values.robot_description_timeout,
                                          lambda: on_timeout(self), clock=wall)

    def late_description(self) -> 'bytes | None':
        """Return the last robot_description that came since the character loaded, raw, if any.

        Only while it listens on (``attach``'s ``listen``): the subscription is never in the
        executor's wait set, and the node's watchdog asks here once a tick.
        """
        got, last = self.description is not None and self.pipeline is not None, None
        for _ in range(CrowdInputs.DRAIN if got else 0):
            taken = self.description.handle.take_message(String, True)
            if taken is None:
                break
            last = taken[0]
        return last

    def read_setup(self) -> None:
        """Read its rig and fabrics files as they are now, for every recording it joins.

        At its load, before its pipeline joins the node's: the files may change or go while
        it runs, and a recording must hold what runs; one gone since the start is a
        ConfigError for this character alone.
        """
        spec = self.spec
        self.setup_texts = (read_text(spec.rig or shipped('jacket_rig.yaml'), 'rig'),
                            read_text(spec.fabric_file or shipped('fabrics.yaml'), 'fabrics'))

    def attach(self, node: 'Node', pipeline: 'SessionPipeline', index: int, urdf: str,
               markers_wanted: Callable[['Node'], bool],
               listen: 'CallbackGroup | None' = None) -> None:
        """Take its loaded pipeline (``index`` in the node's crowd); stop waiting for a URDF.

        :param node: the node, which makes its markers publisher.
        :param pipeline: its pipeline, loaded.
        :param index: its place in the node's CrowdPipeline.
        :param urdf: the URDF text it was loaded with.
        :param markers_wanted: tells whether markers due now on a publisher have a reader.
        :param listen: if it waited for its topic, a group the executor never runs: its
            robot_description stays subscribed there, so a later, different URDF is told
            (``late_description``) at no cost to the executor; None: unsubscribed.
        """
        self.pipeline, self.index, self.urdf = pipeline, index, urdf
        if self.viewer is not None:     # it came before the character
            pipeline.set_viewer(self.viewer)
        # Done waiting: every entity left in the node is work for each executor wake-up.
        if self.description is not None:
            node.destroy_subscription(self.description)
            node.destroy_timer(self.fallback)
            self.description = self.fallback = None
            if listen is not None:
                self.description = node.create_subscription(
                    String, self.names['robot_description'], _never_called, LATCHED,
                    raw=True, callback_group=listen, event_callbacks=NO_SUB_EVENTS)
        self.markers = node.create_publisher(MarkerArray, self.names['markers'], 10,
                                             event_callbacks=NO_PUB_EVENTS)
        pipeline.markers_wanted = lambda: markers_wanted(self.markers)
        self.diag_wall = time.monotonic()

    def add_to_recording(self, recorder: 'SessionRecorder') -> None:
        """Add its channels and its set-up (character, rig, fabrics, parameters) to a recording.

        So a replay needs only the file.

        :param recorder: the node's recording.
        """
        for key in ('joint_states', 'markers'):
            recorder.add_topic(*self.topics[key])
        recorder.add_session_config(
            self.urdf, *self.setup_texts, self.values.by_name(), self.config_name,
            self.pipeline.output_phase, self.pipeline.node_name, self.pipeline.inputs)


def input_problems(report: 'StepReport', published: bool) -> list[tuple[str, str]]:
    """Return (code, text) of what went wrong with an input, for its throttled warnings.

    :param report: what the input did.
    :param published: whether its bones went out on /tf.
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


class _TakenElsewhere(CallbackGroup):
    """A callback group the executor never runs: its subscriptions' messages are taken by hand.

    CrowdInputs takes the characters' JointStates; the node's watchdog a late URDF.
    """

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

    :param callback_group: the group the waitable itself runs in (the node's default).
    :param on_inputs: takes the messages of a wake-up, [(character, raw bytes, message info)].
    """

    DRAIN = 16                      # the sensor-data queue is 5 deep; more only while taking

    def __init__(self, callback_group: CallbackGroup,
                 on_inputs: Callable[[list], None]) -> None:
        super().__init__(callback_group)
        self._on_inputs = on_inputs
        self._subs = []             # (character, subscription handle, its pointer)
        self._ready = []
        self.taken_elsewhere = _TakenElsewhere()

    def subscribe(self, node: 'Node', character: object, topic: str) -> 'Subscription':
        """Subscribe ``node`` to ``topic`` (raw JointStates, sensor data QoS) for ``character``.

        The subscription is taken here, never by the executor, and has no QoS event handlers
        (2 per character per wake-up); a publisher with incompatible QoS is still warned on
        its own side. Returns the subscription.

        :param node: the node subscribing.
        :param character: what its messages are handed to ``on_inputs`` with.
        :param topic: its joint_states topic.
        """
        subscription = node.create_subscription(
            JointState, topic, _never_called, qos_profile_sensor_data, raw=True,
            callback_group=self.taken_elsewhere, event_callbacks=NO_SUB_EVENTS)
        handle = subscription.handle
        self._subs.append((character, handle, handle.pointer))
        return subscription

    def __enter__(self) -> None:
        pass

    def __exit__(self, *exc: object) -> None:
        """Leave the waitable's context; nothing to release.

        :param exc: the exception's type, value and traceback, if one ended it.
        """
        pass

    def get_num_entities(self) -> NumberOfEntities:
        return NumberOfEntities(len(self._subs))

    def add_to_wait_set(self, wait_set: object) -> None:
        """Add every character's subscription to the executor's wait set.

        :param wait_set: the executor's wait set.
        """
        for _, handle, _ in self._subs:
            wait_set.add_subscription(handle)

    def is_ready(self, wait_set: object) -> bool:
        """Tell whether any subscription has messages; note which, for ``take_data``.

        :param wait_set: the executor's wait set, after its wait.
        """
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
        """Hand a wake-up's messages to ``on_inputs``.

        :param taken: what ``take_data`` took, [(character, raw bytes, message info)].
        """
        self._on_inputs(taken)


def _never_called(raw: bytes) -> None:
    """Do nothing: its messages are taken by hand, the executor never calls this."""
