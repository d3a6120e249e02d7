# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""What the node does with each JointState, without the node: one path for live and replay.

The live node feeds it what arrives and publishes what it returns; ``jacket_cloth replay``
feeds it a recording and writes what it returns. Same input, same parameters: same messages.
Only wall-clock step costs differ between runs, so they go into diagnostics only when
``timing`` is on (live), keeping a replay's output file byte-identical run after run.
"""

import functools
import math
import time
import types
from typing import TYPE_CHECKING

import numpy as np

from ..core.compiled import FixedTypes
from ..core.crowd import CrowdSteps, stepped
from ..core.simulation import JacketSimulation, StageTimer, StepReport
from ..core.stepping import NOT_STEADY
from ..recording.writer import qos_profile_yaml
from . import messages, steady_lane
from .cdr import DECODE_ERRORS, JointStateReader, Undecodable

if TYPE_CHECKING:           # for the annotations only
    from collections.abc import Callable, Sequence

    from ..core.rig import Rig
    from ..core.skeleton import Skeleton
    from .cdr import JointStateContent
    from .values import NodeValues


def session_topics(joint_states: str = '/joint_states', wind: str = '/jacket_cloth_node/wind',
                   markers: str = '/jacket_cloth_node/markers',
                   viewer: str = '/jacket_cloth_node/viewer') -> dict[str, tuple[str, str, str]]:
    """Return a session's topics by key: (name, type, offered QoS as rosbag2 records it).

    Inputs (JointState, wind, viewer, parameter changes) and outputs (/tf, markers,
    diagnostics): the node records them all, a replay reads the inputs and writes them all again.

    :param joint_states: the JointState input topic.
    :param wind: the wind input topic.
    :param markers: the markers output topic.
    :param viewer: the viewer input topic.
    """
    return {
        'joint_states': (joint_states, 'sensor_msgs/msg/JointState',
                         qos_profile_yaml(reliable=False)),
        'wind': (wind, 'geometry_msgs/msg/Vector3Stamped', qos_profile_yaml()),
        'viewer': (viewer, 'geometry_msgs/msg/PointStamped',
                   qos_profile_yaml(transient_local=True, depth=1)),
        'parameter_events': ('/parameter_events', 'rcl_interfaces/msg/ParameterEvent',
                             qos_profile_yaml(depth=1000)),
        'tf': ('/tf', 'tf2_msgs/msg/TFMessage', qos_profile_yaml(depth=100)),
        'markers': (markers, 'visualization_msgs/msg/MarkerArray', qos_profile_yaml()),
        'diagnostics': ('/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray',
                        qos_profile_yaml()),
    }


# The diagnostics' owner when a recording does not name one: the node with its default name.
DEFAULT_NODE = '/jacket_cloth_node'
# What a pipeline's ``stage_timer`` is given, in the order they run for an input (``skinning``,
# the jacket skinned into the markers, runs within ``markers``).
TIMED_STAGES = ('prepare', 'step', 'complete', 'bones', 'tf', 'markers', 'skinning',
                'diagnostics')


class SessionPipeline:
    """A simulation plus the cadence and content of its output messages."""

    def __init__(self, skeleton: 'Skeleton', rig: 'Rig', values: 'NodeValues',
                 node_name: str = DEFAULT_NODE, timing: bool = True,
                 output_phase: float = 0.0, stage_timer: StageTimer | None = None):
        """Set up the simulation.

        :param skeleton: the character's skeleton.
        :param rig: its rig.
        :param values: the character's parameter values: the simulation runs on their
            SimParams and Fabric.
        :param node_name: starts the diagnostics status name (``<node_name>: cloth
            simulation``): the node's fully qualified name, and in a crowd the character's
            name after it.
        :param timing: whether wall-clock step costs go into the diagnostics (live; not in a
            replay, whose output file stays byte-identical).
        :param output_phase: staggers markers and diagnostics: after the first of each, they
            come this share (0 to 0.9) of their period earlier than they would; a crowd gives
            its characters spread phases, so their markers and diagnostics do not all fall on
            one input's tick.
        :param stage_timer: a profiler's hook (jacket_cloth_lab.profile): called once per
            stage of :data:`TIMED_STAGES` with its name and callable, once the pipeline is set
            up; what it returns runs in the stage's place, in this pipeline only (the /tf
            template and the outfit that pipelines share stay as they are). None (the node,
            replay): the stages are called directly, nothing is added to an input's work.
        """
        if not 0.0 <= output_phase <= 0.9:
            raise ValueError(f'output_phase {output_phase} is not in [0, 0.9]')
        self.output_phase = output_phase
        # Held here once (ros/values.py); apply() replaces it whole.
        self.values = values
        self.node_name = node_name
        self.timing = timing
        self.sim = JacketSimulation(skeleton, rig, values.fabric, values.sim,
                                    values.world_joint)
        self.inputs = 0
        self.dropped = 0
        self.undecodable = 0        # JointStates that did not decode (the node counts them)
        self.lost = 0               # JointStates their publisher numbered that never arrived
        self.published = 0          # inputs that put bones on /tf (finite ones)
        self.last_reset_reason = ''
        # Why the first JointState the simulation refused was refused ('' until one was): a
        # tool says it when the simulation took none (tools.session.took_nothing).
        self.first_refusal = ''
        # Why the recording the values name is not being written ('' when it is, or none):
        # asked of the live node's recording (ros/recording.py), which holds it once.
        self.recording_problem: 'Callable[[], str]' = _no_recording_problem
        # What the node knows is wrong with the character it runs (another URDF came on its
        # description topic and was not taken): said in the diagnostics while it holds.
        self.character_problem = ''
        self._unmatched = ''        # the last names of which none was a joint of the URDF
        self._matched_ns = self._latest_ns = None   # stamps: the last input moving a joint, any
        self._reset_streak = 0
        self._window = dict.fromkeys(_WINDOW, 0)
        # The simulation's collapse and restless lines (Faults) the diagnostics have said.
        self._said = {'collapse': 0, 'restless': 0, 'under_floor': 0}
        self._costs = []
        self._latencies = []
        # The grid each periodic output is due on, per clock the stamps come on (most recent
        # first): two sources on different clocks each keep the rate, not every input.
        self._marker_clocks = []
        self._diag_clocks = []
        self._finite = False        # the last accounted input's bones (account_tf)
        self._marker_reset = True
        # Asked when markers are due; False: not built this time (the live nodes: no
        # subscriber and no recording). None: always built, as a replay writes them.
        self.markers_wanted: 'Callable[[], bool] | None' = None
        self._stage_timer = None
        self._marker_array = messages.marker_array
        # The character's JointStates are read here, node and replay alike: a steady input's
        # bytes are recognised by its name list's (steady_tf).
        self.reader = JointStateReader()
        self._lane = FixedTypes(steady_lane.steady_tf)
        self._lane_ns = 0           # the last steady_tf's compiled call took, for its step cost
        self._tf = self._tf_template()
        self._world_tf = None
        # Load the encoders' compiled parts now rather than on the first input's outputs, and
        # the steady lane's call (bytes too short to read move nothing) before its first input.
        self._tf.encode(self.sim.bones().poses, 0)
        self._lane(np.frombuffer(b'', dtype=np.uint8), self.reader.name_code,
                   self.sim.steps.lane, self._template.layout)
        # The URDF's own visuals are read once: `auto` asks on every markers message.
        self._has_visuals = '<visual' in self.sim.skeleton.urdf_xml
        messages.marker_array(self.sim, 0, self.sim.skeleton.link_names[0], reset=True,
                              debug=self.values.markers_debug,
                              body=self.draws_body())
        if stage_timer is not None:
            self._time_stages(stage_timer)

    def _tf_template(self):
        # Held here: looking it up by its 68 names and parents was half of each /tf's encoding.
        template = messages.tf_template(tuple(self.sim.bone_names),
                                        tuple(self.sim.bone_parents), self.values.frame_prefix)
        # Where steady_tf lays its /tf out; not with a second /tf (the world's) to follow.
        self._template = template
        self._world_tf_due = self.values.publish_world_tf and not self.root_is_world_frame()
        if self._stage_timer is None:
            return template
        # Timed for this pipeline alone: the template is shared by every pipeline of its bones.
        return types.SimpleNamespace(encode=self._stage_timer('tf', template.encode))

    def _time_stages(self, timer):
        """Put ``timer`` around each of TIMED_STAGES (see ``stage_timer``), once set up."""
        self._stage_timer = timer
        self.sim.time_stages(timer)
        self._lane = timer('step', self._lane)
        self._lane.entry = None         # every call through the timer
        self._tf = self._tf_template()
        draw_jacket = timer('skinning', messages.outfit(self.sim.rig).draw_jacket)
        self._marker_array = timer('markers', functools.partial(messages.marker_array,
                                                                draw_jacket=draw_jacket))
        self._diagnostics = timer('diagnostics', self._diagnostics)

    def draws_body(self) -> bool:
        """Tell whether the markers carry the body: ``markers_body``, auto without visuals."""
        return self.values.draws_body(self._has_visuals)

    def root_frame(self) -> str:
        """Return the frame of the URDF root link as published: ``frame_prefix`` in front."""
        return self.values.frame_prefix + self.sim.skeleton.link_names[0]

    def root_is_world_frame(self) -> bool:
        """Tell whether the URDF root, as published, is ``world_frame`` itself.

        A robot description bolted to a massless ``world`` link: world_frame -> root would
        publish the world as a child of itself (issue 47 item 3), so it is not published.
        """
        return self.root_frame() == self.values.world_frame

    def apply(self, values: 'NodeValues') -> None:
        """Take changed parameter values, acting from the next step; never a reset.

        The simulation takes the bundle's SimParams and Fabric when they are new objects
        (``NodeValues.with_changes`` makes one only when one of its values is given).

        :param values: the character's values now, made from the ones held
            (:meth:`NodeValues.with_changes`).
        """
        old, self.values = self.values, values
        if values.sim is not old.sim:
            self.sim.set_params(values.sim)
        if values.fabric is not old.fabric:
            self.sim.set_fabric(values.fabric)
        if values.world_joint != old.world_joint:
            self.sim.parser.set_world_joint(values.world_joint)
        if (values.frame_prefix != old.frame_prefix
                or values.publish_world_tf != old.publish_world_tf
                or values.world_frame != old.world_frame):
            self._tf = self._tf_template()

    def set_viewer(self, position: 'np.ndarray | None') -> None:
        """Set the viewer's world position for the level of detail, from the next input on.

        :param position: the viewer's world position, (3,) metres; None: no viewer, full detail.
        """
        self.sim.set_viewer(position)

    def note_latency(self, ns: int) -> None:
        """Note the live node's time from a JointState's arrival to its /tf going out.

        :param ns: the time, ns.
        """
        self._latencies.append(ns)

    def note_undecodable(self) -> None:
        """Count a JointState that did not decode as a dropped input."""
        self.undecodable += 1
        self._window['dropped'] += 1

    def note_lost(self, count: int) -> None:
        """Count JointStates lost before they reached the node.

        :param count: how many were lost.
        """
        self.lost += count
        self._window['lost'] += count

    def steady_tf(self, raw: bytes) -> tuple[int, int, 'bytes | None']:
        """Step a steady input from its bytes in one compiled call (ros/steady_lane.py).

        The armed intake's input (core/stepping.py): the name list the reader last read, and
        nothing JacketSimulation.process would say a word about. Its /tf comes back to be
        published at once; :meth:`after_steady` then does the input's bookkeeping.

        :param raw: the JointState's CDR bytes.
        :returns: (status, stamp ns, /tf bytes or None). NOT_STEADY: nothing moved, the input
            goes the reader's and :meth:`on_joint_state`'s way. Else the input is stepped; its
            /tf is None when it waits for :meth:`after_steady` (a cloth reset first).
        """
        sim, reader, template = self.sim, self.reader, self._template
        steps = sim.steps
        # Bytes only: another buffer (a bytearray, a view) would type the kernel anew. The key
        # is JacketSimulation.steady_key's, made here: calling it would take the callback's
        # way to the /tf publish through one more module.
        if self._world_tf_due or type(raw) is not bytes or sim.lod.viewer is not None or \
                not steps.armed_for((reader.names, sim.tuning, sim.parser.world_joint,
                                     sim.last)):
            return NOT_STEADY, 0, None
        started = time.perf_counter_ns()
        status, stamp, laid = (self._lane.entry or self._lane)(
            np.frombuffer(raw, dtype=np.uint8), reader.name_code, steps.lane, template.layout)
        # The call's own time: the step cost leaves out whatever the caller does before
        # after_steady (the node's publish).
        self._lane_ns = time.perf_counter_ns() - started
        if status == NOT_STEADY:
            steps.armed = None          # as the intake's own refusal disarms it
            return status, stamp, None
        return status, stamp, template.u8.tobytes() if laid else None

    def after_steady(self, status: int, stamp_ns: int,
                     tf: 'bytes | None') -> tuple[StepReport, list[tuple[str, bytes]]]:
        """Finish and count an input :meth:`steady_tf` stepped: its report and /tf outputs.

        :param status: what steady_tf returned.
        :param stamp_ns: the input's stamp, ns.
        :param tf: its /tf as steady_tf laid it out, or None: made here (:meth:`account_tf`).
        :returns: (report, [('tf', bytes)]), the /tf steady_tf gave among them.
        """
        report = self.sim.took_steady(stamp_ns, self.reader.names, status,
                                      time.perf_counter_ns() - self._lane_ns)
        return report, self.account_tf(report, stamp_ns, tf)

    def on_raw(self, raw: bytes) -> tuple[StepReport, list[tuple[str, bytes]]]:
        """Process one JointState's CDR bytes as the node does: (report, outputs).

        A steady input by :meth:`steady_tf`, any other read and processed by
        :meth:`on_joint_state`; the outputs are the same to the byte either way.

        :param raw: the serialized JointState.
        :raises cdr.Undecodable: bytes that do not decode as a JointState.
        """
        status, stamp, tf = self.steady_tf(raw)
        if status != NOT_STEADY:
            report, out = self.after_steady(status, stamp, tf)
            return report, out + self.periodic_outputs(report, stamp)
        try:
            msg = self.reader.read(raw)
        except DECODE_ERRORS as e:
            raise Undecodable(str(e)) from None
        return self.on_joint_state(msg, msg.stamp_ns)

    def on_joint_state(self, msg: 'JointStateContent',
                       stamp_ns: int) -> tuple[StepReport, list[tuple[str, bytes]]]:
        """Process one JointState; returns (StepReport, [(output key, CDR bytes), ...]).

        :param msg: the JointState's content.
        :param stamp_ns: the input's stamp, ns, which its outputs carry.
        """
        report = self.sim.process(stamp_ns, msg.name, msg.position)
        return report, self.account(report, stamp_ns)

    def account(self, report: StepReport, stamp_ns: int) -> list[tuple[str, bytes]]:
        """Count a processed input and return its outputs ([(output key, CDR bytes), ...]).

        Its /tf (:meth:`account_tf`), then its markers and diagnostics when due
        (:meth:`periodic_outputs`).

        :param report: the input's step report.
        :param stamp_ns: the input's stamp, ns, which its outputs carry.
        """
        return self.account_tf(report, stamp_ns) + self.periodic_outputs(report, stamp_ns)

    def account_tf(self, report: StepReport, stamp_ns: int,
                   encoded: 'bytes | None' = None) -> list[tuple[str, bytes]]:
        """Count a processed input and return its /tf outputs (none for a non-finite pose).

        The part after the simulation that a listener waits for: a crowd (CrowdPipeline)
        sends every character's /tf before any character's markers and diagnostics.

        :param report: the input's step report.
        :param stamp_ns: the input's stamp, ns, which its outputs carry.
        :param encoded: its bones' /tf, laid out already (:meth:`steady_tf`); None: made here.
        """
        self.inputs += 1
        self._window['inputs'] += 1
        if not report.accepted:
            self.dropped += 1
            self._window['dropped'] += 1
            if not self.first_refusal:
                self.first_refusal = '; '.join(text for _, text in report.warnings) or 'refused'
            return []
        self._window['accepted'] += 1
        unmatched = self.sim.parser.unmatched
        if unmatched:       # said while no input has moved a joint for a second of stamps
            self._unmatched = unmatched
        else:
            self._matched_ns = stamp_ns
        self._latest_ns = stamp_ns
        if report.reset:            # a merged input's too: its world pose may jump
            self._note_reset(report.reset)
        if report.merged:           # another source's joints, in the last pose: nothing new
            self._window['merged'] += 1
            return []
        if report.skipped_steps:
            self._window['skipped'] += report.skipped_steps
        self._window['steps'] += report.steps
        bones = self.sim.bones()        # checked where the steps ended (check_bones)
        self._reset_streak = self._reset_streak + 1 \
            if report.reset and report.reset != 'first sample' else 0
        # The first input places the cloth, loading what it first needs: no step's cost.
        if report.reset != 'first sample':
            self._costs.append(report.step_cost_ns)
        self._finite = bones.finite
        if not bones.finite:     # never a NaN on /tf (left so by check_bones' reset)
            return []
        if encoded is None:
            encoded = self._tf.encode(bones.poses, stamp_ns)
        out = [('tf', encoded)]
        if self._world_tf_due:
            out.append(('tf', self._world_transform(stamp_ns)))
        self.published += 1
        self._window['published'] += 1
        return out

    def _note_reset(self, reason):
        """Count a reset of the cloth: said in diagnostics, the markers drawn anew."""
        self.last_reset_reason = reason
        self._marker_reset = True
        if reason != 'first sample':
            self._window['resets'] += 1

    def periodic_outputs(self, report: StepReport,
                         stamp_ns: int) -> list[tuple[str, bytes]]:
        """Return an accounted input's markers and diagnostics, those that are due.

        Right after its :meth:`account_tf`, before the simulation takes another input.

        :param report: the input's step report.
        :param stamp_ns: the input's stamp, ns, which its outputs carry.
        """
        if not report.accepted or report.merged:
            return []
        out = []
        rate = self.values.markers_rate
        if self._finite and rate > 0 and self._due(self._marker_clocks, stamp_ns, rate):
            if self.markers_wanted is None or self.markers_wanted():
                out.append(('markers', self._marker_array(
                    self.sim, stamp_ns, self.root_frame(), reset=self._marker_reset,
                    debug=self.values.markers_debug, body=self.draws_body())))
                self._marker_reset = False
        # Diagnostics go out when nothing else does: a failing node must not fall silent.
        if self._due(self._diag_clocks, stamp_ns, self.values.diagnostics_rate):
            out.append(('diagnostics', self._diagnostics(stamp_ns)))
        return out

    def _due(self, clocks: list, stamp_ns: int, rate: float) -> bool:
        """Tell whether an output at ``rate`` is due at ``stamp_ns``; if so, step its grid.

        ``clocks``: the last due stamp of each clock seen lately, most recent first. A stamp is
        on the clock it follows most closely (within the reset gap, or two periods); else a
        stamp ahead of the latest continues it (a gap keeps the phase), and one behind every
        clock starts a new one, due at once (a restarted source), as does the first.
        """
        period = 1e9 / rate
        if len(clocks) == 1 and 0 <= stamp_ns - clocks[0] < 0.95 * period:
            return False        # one source, not due yet: what the rest would say, unchanged
        span = max(self.values.sim.reset_gap * 1e9, 2 * period)
        ahead = [(stamp_ns - last, k) for k, last in enumerate(clocks)
                 if 0 <= stamp_ns - last <= span]
        k = min(ahead)[1] if ahead else 0 if clocks and stamp_ns >= clocks[0] else None
        last = None if k is None else clocks.pop(k)
        # 5% slack: stamps rounded to whole ns must not turn every 2nd input into every 3rd.
        due = last is None or stamp_ns - last >= 0.95 * period
        clocks.insert(0, self._phased(last, stamp_ns, rate) if due else last)
        del clocks[_CLOCKS:]
        return due

    def _phased(self, last, stamp_ns, rate):
        """Return the stamp the next period counts from, on this pipeline's grid of periods.

        The first one is moved back by the phase. Later ones step whole periods from the last
        (at least one, at most to the input), so a gap keeps the phase: counting from the
        input's stamp put every character of a crowd that came through a backlog of inputs
        (several inputs a character, some lost) on the same input, and their markers and
        diagnostics all fell on one tick again (docs/crowd.md). Inputs whose interval divides
        the period get the cadence they had (30 Hz markers on every 4th input at 120 Hz);
        others now get the rate set on average (30 Hz markers from 50 Hz inputs: gaps of 20
        and 40 ms, 25 Hz before).
        """
        period = 1e9 / rate
        if last is None or stamp_ns < last:
            return stamp_ns - int(self.output_phase * period)
        whole = max(1.0, (stamp_ns - last + 0.05 * period) // period)
        return min(last + round(whole * period), stamp_ns)

    def _world_transform(self, stamp_ns):
        """Encode world_frame -> the URDF root: the input's own world_joint variables.

        Not the last step's root: with inputs off the step grid that lags the input, and the
        skeleton's links (robot_state_publisher) are at the input's pose. The root carries
        ``frame_prefix``; ``world_frame`` is taken as given, the world the characters share.
        """
        root = self.root_frame()
        key = (self.values.world_frame, root)
        if self._world_tf is None or self._world_tf[0] != key:
            self._world_tf = (key, messages.tf_template((root,), (key[0],), ''))
        last = self.sim.last
        pose = np.concatenate([last.root[:3, 3], last.root_quat])
        return self._world_tf[1].encode(pose[None], stamp_ns)

    def diagnostics_now(self, stamp_ns: int) -> bytes:
        """Diagnostics whatever the stamps: the live node's own rate, when inputs stop.

        :param stamp_ns: the array's stamp, ns.
        """
        return self._diagnostics(stamp_ns)

    def _viewer_distance(self):
        """Return the viewer's distance to the root at the last input ('' without a viewer)."""
        viewer, last = self.sim.lod.viewer, self.sim.last
        if viewer is None or last is None:
            return ''
        return f'{math.dist(viewer, last.root[:3, 3]):.2f}'

    def _status(self, slow, recording):
        """Level and message of the inputs since the last diagnostics."""
        w = self._window
        if w['accepted'] > w['merged'] and not w['published']:
            return messages.ERROR, 'nothing published: the bone pose is not finite'
        if self._reset_streak >= 3:
            return messages.ERROR, (f'the cloth resets on every input ({self._reset_streak} '
                                    f'in a row: {self.last_reset_reason})')
        if w['dropped'] and not w['accepted']:
            return messages.ERROR, 'every input dropped'
        problems = []
        if recording:
            problems.append(f'recording failed: {recording}')
        if slow:
            problems.append('step cost above one step of real time')
        if w['resets']:
            problems.append(f'{w["resets"]} reset(s), the last: {self.last_reset_reason}')
        if w['dropped'] or w['lost']:
            problems.append(f'{w["dropped"]} input(s) dropped, {w["lost"]} lost')
        if w['skipped']:
            # The cloth then lives less time than the body: gravity and swing slow down.
            ran = w['steps'] / (w['steps'] + w['skipped'])
            problems.append(f'{w["skipped"]} step(s) skipped over max_steps_per_input '
                            f'({self.sim.params.max_steps_per_input} an input): the cloth ran '
                            f'{ran:.0%} of the inputs\' time')
        lying = self.sim.lying_without_world_pose()
        if lying:
            problems.append(lying)
        if self.character_problem:
            problems.append(self.character_problem)
        if w['accepted'] and (self._matched_ns is None
                              or self._latest_ns - self._matched_ns > _UNMATCHED_NS):
            problems.append(f'no name of the JointState is a joint of the URDF '
                            f'({self._unmatched}): the body stays as it is')
        held = self.sim.parser.held(self._latest_ns, _UNMATCHED_NS) \
            if self._latest_ns is not None else ''
        if held:
            problems.append(held)
        if self.sim.parser.world_incomplete:
            problems.append(f'incomplete {self.sim.parser.world_joint}/* pose: the root keeps '
                            'its last world pose')
        # No silent collapse, no cloth that never rests: said while it lasts, and once after.
        watches = self.sim.watches
        for kind, lasts in (('collapse', watches.collapse.collapsed),
                            ('restless', watches.restless.restless),
                            ('under_floor', watches.floor.sunk)):
            said = getattr(self.sim.faults, kind)
            if lasts or len(said) > self._said[kind]:
                problems.append(said[-1])
        if problems:
            return messages.WARN, '; '.join(problems)
        return messages.OK, 'ok' if w['inputs'] else 'no input'

    def _diagnostics(self, stamp_ns):
        sim = self.sim
        recording = self.recording_problem()
        vert, horiz = sim.strain()
        values = {}
        slow = False
        if self.timing:
            costs = sorted(self._costs or [0])
            values['step_cost_us_median'] = f'{quantile(costs, 0.5) * 1e-3:.1f}'
            values['step_cost_us_max'] = f'{costs[-1] * 1e-3:.1f}'
            slow = costs[-1] * 1e-3 > 1e6 / sim.params.sim_rate
            if self._latencies:
                lat = sorted(self._latencies)
                values['latency_us_p99'] = f'{quantile(lat, 0.99) * 1e-3:.1f}'
                values['latency_us_max'] = f'{lat[-1] * 1e-3:.1f}'
        self._costs = []
        self._latencies = []
        values.update({
            'overruns': sim.faults.overruns,
            'resets': sim.resets,
            'nonfinite_inputs': sim.faults.nonfinite,
            'last_reset': self.last_reset_reason,
            'worst_vertical_strain': f'{vert:.4f}',
            'worst_horizontal_strain': f'{horiz:.4f}',
            'inputs': self.inputs,
            'dropped_inputs': self.dropped + self.undecodable,
            'undecodable_inputs': self.undecodable,
            'lost_inputs': self.lost,
            'sim_steps': sim.steps_total,
            'retried_steps': sim.faults.retried,
            'lod_level': sim.lod.level,
            'viewer_distance_m': self._viewer_distance(),
            'recording': (f'failed: {recording}' if recording else self.values.record),
        })
        level, message = self._status(slow, recording)
        self._window = dict.fromkeys(_WINDOW, 0)
        self._said = {kind: len(getattr(sim.faults, kind)) for kind in self._said}
        return messages.diagnostics(stamp_ns, self.node_name, values, level, message)


def _no_recording_problem() -> str:
    """Return '': a pipeline without a recording (a replay's) has no recording problem."""
    return ''


# Clocks a pipeline's periodic outputs keep a grid for (sources on different clocks).
_CLOCKS = 4
# What the inputs since the last diagnostics did, for its level.
_WINDOW = ('inputs', 'accepted', 'published', 'resets', 'dropped', 'lost', 'steps', 'skipped',
           'merged')
# How long in stamps no input may move a joint of the URDF before diagnostics say so: a
# second source of names the URDF lacks (a gripper's) comes between the body's inputs.
_UNMATCHED_NS = 1_000_000_000


def quantile(ordered: list, share: float) -> float:
    """Return the ``share`` quantile of sorted numbers, interpolated as numpy's default.

    Sorting a list of ints: numpy's percentile was a visible share of a crowd's diagnostics.

    :param ordered: the numbers, sorted ascending.
    :param share: the quantile, 0 to 1.
    """
    at = (len(ordered) - 1) * share
    lo = int(at)
    hi = min(lo + 1, len(ordered) - 1)
    return ordered[lo] + (ordered[hi] - ordered[lo]) * (at - lo)


def spread_phase(index: int) -> float:
    """Return the output phase of a crowd's ``index``-th character (0 for the first).

    Golden-ratio steps (scaled into [0, 0.9]) spread any number of characters evenly without
    knowing how many will come.

    :param index: the character's place in the crowd, from 0.
    """
    return 0.9 * ((index * 0.6180339887498949) % 1.0)


class Periodic:
    """An accounted input's markers and diagnostics (periodic_outputs), made once, when due.

    Made when called, so that a live crowd sends every /tf first, or at once (``now``) when
    its character takes another input before they would be asked for. Asked for after that
    other input, they would describe its state instead: that is refused, not returned.

    :param pipeline: the input's character's pipeline, the input just accounted (account_tf).
    :param report: the input's step report.
    :param stamp_ns: the input's stamp, ns.
    :param now: make them now.
    """

    __slots__ = ('_pipeline', '_report', '_stamp_ns', '_inputs', '_last', '_made')

    def __init__(self, pipeline: SessionPipeline, report: StepReport, stamp_ns: int,
                 now: bool = False):
        self._pipeline, self._report, self._stamp_ns = pipeline, report, stamp_ns
        # Its character's inputs accounted, which the next input moves on, and its last
        # sample, which a next input the Python way replaces (a steady one moves it on in
        # place: the count tells).
        self._inputs, self._last = pipeline.inputs, pipeline.sim.last
        self._made = pipeline.periodic_outputs(report, stamp_ns) if now else None

    def __call__(self) -> list[tuple[str, bytes]]:
        """Return the outputs, made on the first call; the same ones on any later call."""
        if self._made is None:
            if (self._pipeline.inputs != self._inputs
                    or self._pipeline.sim.last is not self._last):
                raise RuntimeError('markers and diagnostics asked for after their character '
                                   'took another input')
            self._made = self._pipeline.periodic_outputs(self._report, self._stamp_ns)
        return self._made


class CrowdPipeline:
    """The pipelines of many characters, their inputs' steps run together (core.crowd).

    Each character's outputs are those its pipeline gives alone, byte for byte. A crowd of one
    (jacket_cloth_node) steps its character alone, by its simulation's ``process``: for one
    input the crowd's compiled intake and call cost more than they save, and its kernels
    need not be loaded (they are once a second character comes).

    :param threads: how many threads the crowd's call spreads over (0: all cores).
    """

    def __init__(self, threads: int = 0):
        self.pipelines = []
        self.steps = CrowdSteps(threads)
        self._names = []            # each character's last name list, as stepped

    def add(self, pipeline: SessionPipeline) -> int:
        """Add a character's pipeline; returns its index.

        :param pipeline: a character's pipeline, stepped with the others from now on.
        """
        self.pipelines.append(pipeline)
        self._names.append(None)
        if len(self.pipelines) == 2:
            self.steps.add(self.pipelines[0].sim)
        if len(self.pipelines) >= 2:
            self.steps.add(pipeline.sim)
        return len(self.pipelines) - 1

    def on_joint_states(self, inputs: 'Sequence[tuple[int, JointStateContent]]') -> list[
            tuple[StepReport, list[tuple[str, bytes]]]]:
        """Process inputs; returns (report, outputs) of each, in order.

        :param inputs: (character index, JointState) each.
        """
        return [(r, tf + later()) for r, tf, later in self.step_and_tf(inputs)]

    def step_and_tf(self, inputs: 'Sequence[tuple[int, JointStateContent]]') -> list[
            tuple[StepReport, list[tuple[str, bytes]], Periodic]]:
        """Process inputs as :meth:`on_joint_states` does; (report, /tf outputs, later) of each.

        ``later()`` returns the input's markers and diagnostics: a live crowd sends every /tf
        at once, then calls each ``later``, so the last character's /tf waits for no
        character's markers or diagnostics. An input whose character has another input later
        in the batch has them made after its own round, before its state moves on.

        :param inputs: (character index, JointState) each.
        """
        if len(self.pipelines) == 1:
            return [self.alone(m, k == len(inputs) - 1) for k, (_, m) in enumerate(inputs)]
        out = [None] * len(inputs)

        def after_round(ks, reports, last):
            for k in ks:
                i, m = inputs[k]
                pipeline, report = self.pipelines[i], reports[k]
                tf = pipeline.account_tf(report, m.stamp_ns)
                out[k] = (report, tf, Periodic(pipeline, report, m.stamp_ns, now=not last))
        stepped(self.steps, [(i, m.stamp_ns, self._steady_names(i, m.name), m.position)
                             for i, m in inputs], after_round)
        return out

    def alone(self, msg: 'JointStateContent', last: bool) -> tuple[
            StepReport, list[tuple[str, bytes]], Periodic]:
        """Step the only character by its simulation's ``process``, as its pipeline alone.

        :param msg: the input.
        :param last: whether it is the last input of its batch; if not, its markers and
            diagnostics are made now.
        :returns: (report, /tf outputs, later), as :meth:`step_and_tf` gives each input.
        """
        pipeline = self.pipelines[0]
        report = pipeline.sim.process(msg.stamp_ns, msg.name, msg.position)
        tf = pipeline.account_tf(report, msg.stamp_ns)
        return report, tf, Periodic(pipeline, report, msg.stamp_ns, now=not last)

    def _steady_names(self, index, names):
        """Return a character's name list as the crowd's steady intake can take it on.

        That intake is armed for one name list object. An equal list in a new object (rclpy's
        own deserialisation makes one per message) is replaced by the one it was armed for,
        and a list that differs from the last goes as a list, which is never armed on
        (JacketSimulation.settle): arming on every input cost more than the input's steps.
        """
        last = self._names[index]
        if names is last:
            return names
        if names == last:
            return last
        self._names[index] = names
        return list(names)
