# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A recorded session as input to the simulation: its inputs, its set-up, and a runner.

The replay and the analysis both run a recording through :class:`SessionPipeline`, the same
per-input path as the live node. The set-up (URDF, rig, fabrics, parameters) comes from the
recording when the node wrote it, and can be overridden; foreign recordings (a rosbag2 bag or a
plain MCAP file with ``sensor_msgs/msg/JointState``) need at least the URDF, and a rig unless
the shipped one fits the skeleton.
"""

import json
import struct
from collections.abc import Callable, Iterable
from dataclasses import dataclass, fields

from rcl_interfaces.msg import ParameterEvent
from rclpy.parameter import Parameter
from rclpy.serialization import deserialize_message

from ..core.config import MAX_YAML_BYTES, ConfigError, parse_yaml, read_text, shipped, shown
from ..core.fabric import FABRIC_RANGES, Fabric, fabrics_from_data
from ..core.rig import Rig
from ..core.simulation import StepReport
from ..core.skeleton import Skeleton, shipped_character_urdf, skeleton_from
from ..recording.reader import NO_MESSAGES, Recording, RecordingError, read_recording
from ..recording.writer import SESSION_CONFIG
from ..ros.cdr import DECODE_ERRORS, JointStateReader, Undecodable
from ..ros.parameters import from_recording, parse_override, typed_value
from ..ros.pipeline import DEFAULT_NODE, SessionPipeline, session_topics
from ..ros.values import VALUE_NAMES, NodeValues, default_values
from ..ros.viewer import VIEWER_TYPE, read_viewer

JOINT_STATE = 'sensor_msgs/msg/JointState'
PARAMETER_EVENT = 'rcl_interfaces/msg/ParameterEvent'
WIND = 'geometry_msgs/msg/Vector3Stamped'


@dataclass
class SessionSetup:
    urdf: str
    rig_yaml: str
    fabrics_yaml: str
    values: NodeValues
    skeleton: Skeleton
    rig: Rig
    fabrics: dict
    node_name: str = DEFAULT_NODE   # what the recorded node's diagnostics names started with


@dataclass
class SessionInput:
    recording: object            # reader.Recording
    topic: str                   # the JointState topic
    events: list                 # (stamp_ns, order, kind, bytes): what the simulation is fed
    setup: SessionSetup
    warnings: list = None        # one line each, for the user

    def stamp_range(self) -> tuple[int, int]:
        """(first, last) JointState header stamp in ns: the span the session covers."""
        stamps = [e[0] for e in self.events if e[2] == 'joint_states']
        return min(stamps), max(stamps)


def joint_state_topic(recording: Recording, topic: str | None = None) -> str:
    """Return the recording's JointState topic: the one asked for, else the only one there is.

    :param recording: the recording read.
    :param topic: the topic asked for; None: the recording's only JointState topic.
    """
    listed = ', '.join(f'{t} ({k or "no schema"})' for t, k in sorted(recording.topics.items()))
    if topic is not None:
        if topic not in recording.topics:
            raise RecordingError(
                f'{recording.path}: no topic {topic} (topics: {listed or "none"})')
        if recording.topics[topic] != JOINT_STATE:
            raise RecordingError(f'{recording.path}: {topic} is {recording.topics[topic]!r}, '
                                 f'not {JOINT_STATE}')
        return topic
    found = [t for t, k in recording.topics.items() if k == JOINT_STATE]
    if not found:
        raise RecordingError(f'{recording.path}: no {JOINT_STATE} topic (topics: '
                             f'{listed or "none"})')
    if len(found) > 1:
        if '/joint_states' in found:
            return '/joint_states'
        raise RecordingError(f'{recording.path}: several JointState topics ({", ".join(found)});'
                             ' choose one with --topic')
    return found[0]


def input_topics(recording: Recording, topic: str) -> list[str]:
    """Return the topics a session's simulation is fed: JointState, parameters, wind, viewer.

    :param recording: the recording (its topics; messages are not needed).
    :param topic: its JointState topic.
    """
    fed = {PARAMETER_EVENT, WIND, VIEWER_TYPE}
    return [topic] + sorted(t for t, kind in recording.topics.items() if kind in fed)


def load_session(path: str, topic: str | None = None, urdf: str | None = None,
                 rig: str | None = None, fabric: str | None = None,
                 overrides: Iterable[str] = (),
                 listed: Recording | None = None) -> SessionInput:
    """Read a recording and settle its set-up: recorded values, then the options given.

    :param path: the recording, an MCAP file or a bag folder.
    :param topic: its JointState topic; None: the only one there is.
    :param urdf: a URDF file instead of the recorded character.
    :param rig: a rig YAML file instead of the recorded rig.
    :param fabric: a fabric preset instead of the recorded one.
    :param overrides: ``name:=value`` parameter settings (``-p``), applied last.
    :param listed: the recording read with ``NO_MESSAGES`` already, if it was.
    """
    # First its topics, then only what the simulation is fed: a session's /tf and markers
    # are most of its bytes.
    listed = listed or read_recording(path, NO_MESSAGES)
    topic = joint_state_topic(listed, topic)
    recording = read_recording(path, input_topics(listed, topic))
    recorded = recording.metadata.get(SESSION_CONFIG, {})
    where = f'{path}: the recorded'
    if urdf:        # a file given: its own errors, an empty one too, never the shipped one
        urdf_text = read_text(urdf, 'URDF')
        skeleton = skeleton_from(urdf_text, f'URDF {urdf}')
    elif recorded.get('urdf'):
        urdf_text = recorded['urdf']
        skeleton = skeleton_from(urdf_text, f'{where} URDF')
    else:
        urdf_text = shipped_character_urdf()
        skeleton = Skeleton(urdf_text)
    rig_yaml = read_text(rig, 'rig') if rig else recorded.get('rig_yaml') or read_text(
        shipped('jacket_rig.yaml'), 'rig')
    rig_where = rig or (f'{where} rig' if recorded.get('rig_yaml') else 'rig')
    rig_obj = Rig(parse_yaml(rig_yaml, rig_where), skeleton, where=rig_where)
    fabrics_yaml = recorded.get('fabrics_yaml') or read_text(shipped('fabrics.yaml'), 'fabrics')
    fabrics_where = f'{where} fabrics' if recorded.get('fabrics_yaml') else 'fabrics'
    fabrics = fabrics_from_data(parse_yaml(fabrics_yaml, fabrics_where), fabrics_where)
    ignored = []
    recorded_values = recorded_parameters(recorded, f'{where} parameter', ignored)
    preset = fabric or recorded_values.get('fabric_preset', 'tweed_jacket')
    if preset not in fabrics:
        raise ConfigError(f'fabric {preset!r} is not a preset (presets: {", ".join(fabrics)})')
    if fabric is not None:      # a preset asked for: its fabric.*, the recording's others
        recorded_values = {k: v for k, v in recorded_values.items() if not k.startswith('fabric')}
    values = default_values(fabrics[preset], preset).with_changes(recorded_values)
    known = values.by_name()        # -p names them: typed at this boundary
    given = dict(parse_override(text, known) for text in overrides)
    chosen = given.get('fabric_preset')
    if chosen is not None:      # a preset named with -p seeds fabric.*, as --fabric does
        if chosen not in fabrics:
            raise ConfigError(f'-p fabric_preset: {chosen!r} is not a preset (presets: '
                              f'{", ".join(fabrics)})')
        values = values.with_changes({k: v for k, v in default_values(
            fabrics[chosen]).by_name().items() if k.startswith('fabric.')})
    values = values.with_changes(given)
    setup = SessionSetup(urdf_text, rig_yaml, fabrics_yaml, values, skeleton, rig_obj, fabrics,
                         recorded.get('node_name') or DEFAULT_NODE)
    session = SessionInput(recording, topic, _events(recording, topic), setup)
    session.warnings = setup_warnings(recorded, ignored) + _check_joints(session)
    return session


def recorded_character(path: str, urdf: str | None = None,
                       rig: str | None = None) -> tuple[Skeleton, Rig]:
    """Return the character and rig a tool draws a recording with: given, else recorded.

    Never the shipped character in their place (issue 47 item 5: ``picture`` of a recording
    made with another character drew the shipped skeleton beside its cloth): a recording
    without a set-up (not a node's or a replay's) needs ``--urdf``, and a rig unless the
    shipped one fits it.

    :param path: the recording, an MCAP file or a bag folder.
    :param urdf: a URDF file instead of the recorded character.
    :param rig: a rig YAML file instead of the recorded rig.
    """
    # The files given first: what is wrong with them is said whatever the recording holds.
    urdf_text = read_text(urdf, 'URDF') if urdf else None
    rig_yaml = read_text(rig, 'rig') if rig else None
    recorded = read_recording(path, NO_MESSAGES).metadata.get(SESSION_CONFIG, {})
    where = f'{path}: the recorded'
    if urdf_text is not None:
        skeleton = skeleton_from(urdf_text, f'URDF {urdf}')
    elif recorded.get('urdf'):
        skeleton = skeleton_from(recorded['urdf'], f'{where} URDF')
    else:
        raise RecordingError(f'{path}: no character recorded in it (only a node\'s or a '
                             "replay's recording has one): give --urdf, and --rig unless the "
                             'shipped rig fits it')
    rig_where = rig
    if rig_yaml is None and recorded.get('rig_yaml'):
        rig_yaml, rig_where = recorded['rig_yaml'], f'{where} rig'
    elif rig_yaml is None:
        rig_yaml, rig_where = read_text(shipped('jacket_rig.yaml'), 'rig'), 'rig'
    return skeleton, Rig(parse_yaml(rig_yaml, rig_where), skeleton, where=rig_where)


# The keys of a set-up record that the node and the replay write (writer.add_session_config).
SETUP_KEYS = frozenset({'urdf', 'rig_yaml', 'fabrics_yaml', 'parameters_json', 'node_name',
                        'output_phase', 'inputs_before'})


class _Twice(ValueError):
    """A name given twice in one JSON object: a JSON reader keeps the last."""


def _pairs_once(pairs):
    """Return a JSON object's pairs as a dict, refusing a name given twice."""
    out = {}
    for name, value in pairs:
        if name in out:
            raise _Twice(f'{shown(name)} is given twice, and a JSON reader keeps only the last')
        out[name] = value
    return out


def recorded_parameters(setup: dict, where: str, ignored: list | None = None) -> dict:
    """Return a set-up record's parameters, each validated as a ``-p`` value (typed_value).

    A recording's set-up is input like any file: its types and ranges are checked as the
    node's parameters are, a name given twice is refused, and names no node has today are
    left out (listed in ``ignored``, for ``setup_warnings``).

    :param setup: the set-up metadata record (its ``parameters_json``).
    :param where: what starts the one-line errors (``<file>: the recorded parameter``).
    :param ignored: if given, the names left out are added to it.
    """
    text = setup.get('parameters_json', '{}')
    try:
        if len(text) > MAX_YAML_BYTES:
            raise ValueError(f'larger than {MAX_YAML_BYTES} bytes')
        data = json.loads(text, object_pairs_hook=_pairs_once)
    except _Twice as e:
        raise ConfigError(f'{where}s: {e}') from None
    except (ValueError, RecursionError) as e:
        raise ConfigError(f'{where}s: not JSON ({shown(str(e))})') from None
    if not isinstance(data, dict):
        raise ConfigError(f'{where}s: not a JSON object of names and values')
    known = default_values(Fabric(**{f.name: FABRIC_RANGES[f.name][0]
                                     for f in fields(Fabric)})).by_name()
    values = from_recording(data)
    if ignored is not None:
        ignored.extend(sorted(name for name in values if name not in known))
    return {name: typed_value(name, value, known[name], f'{where} {name}')
            for name, value in values.items() if name in known}


def setup_warnings(setup: dict, ignored: list[str]) -> list[str]:
    """Say, in one line, what a set-up record holds that this version does not know.

    Written by another version (older or newer) of the node: the replay runs without it, and
    says so rather than silently (a parameter the node would refuse is no input here).

    :param setup: the set-up metadata record.
    :param ignored: the parameter names ``recorded_parameters`` left out.
    """
    unknown = sorted(set(setup) - SETUP_KEYS)
    parts = ([f'key(s) {shown(", ".join(unknown))}'] if unknown else []) + \
        ([f'parameter(s) {shown(", ".join(ignored))}'] if ignored else [])
    out = [] if not parts else [
        'its recorded set-up holds what this version does not know (ignored): '
        + '; '.join(parts)]
    before = setup.get('inputs_before', '0')
    if before.isdigit() and int(before):
        out.append(f'it began {int(before)} inputs into the live session (record set live): '
                   'the cloth as it was then is not in the file, so its first inputs replay '
                   'from the skinned pose and their /tf differ from the recorded ones until '
                   'the cloth forgets its start')
    return out


def _check_joints(session):
    """Check that the JointState speaks of this skeleton.

    None known is an error, some unknown a warning (the node would ignore them too).
    """
    first = next(e for e in session.events if e[2] == 'joint_states')
    try:
        names = list(JointStateReader().read(first[3]).name)
    except DECODE_ERRORS as e:
        raise RecordingError(f'{session.recording.path}: {session.topic} does not decode as '
                             f'JointState ({e})') from None
    world = session.setup.values.world_joint + '/'
    joints = [n for n in names if not n.startswith(world)]
    known = set(session.setup.skeleton.joint_names)
    unknown = [n for n in joints if n not in known]
    if joints and len(unknown) == len(joints):
        raise RecordingError(
            f'{session.recording.path}: none of the joints in {session.topic} '
            f'({", ".join(joints[:4])}{", ..." if len(joints) > 4 else ""}) is in the URDF '
            f'{session.setup.skeleton.name!r}; give the matching --urdf (and --rig)')
    if unknown:
        return [f'{len(unknown)} joint(s) not in the URDF are ignored: '
                f'{", ".join(unknown[:4])}{", ..." if len(unknown) > 4 else ""}']
    return []


def _header_stamp(raw):
    """Return the stamp (ns) of the std_msgs/Header that starts a CDR message.

    None if the bytes cannot hold one.
    """
    raw = bytes(raw[:12])
    if len(raw) < 12 or raw[0] != 0 or raw[1] not in (0, 1):
        return None
    sec, nanosec = struct.unpack_from('<iI' if raw[1] else '>iI', raw, 4)
    return sec * 1_000_000_000 + nanosec


def _events(recording, topic):
    """Return JointState, wind, viewer and parameter changes in recorded order.

    The order they were written, which is the order the node received them (log times can go
    back, or differ from the stamps). A JointState carries its header stamp, the time the node
    simulates to; the others their log time, for information only (run_session stamps them as
    the node does).
    """
    events = []
    for order, m in enumerate(recording.messages):
        if m.topic == topic:
            stamp = _header_stamp(m.data)
            events.append((m.log_time if stamp is None else stamp, order, 'joint_states',
                           m.data))
        elif m.type_name == PARAMETER_EVENT:
            events.append((m.log_time, order, 'parameter_events', m.data))
        elif m.type_name == WIND and m.topic.endswith('/wind'):
            events.append((m.log_time, order, 'wind', m.data))
        elif m.type_name == VIEWER_TYPE and m.topic.endswith('/viewer'):
            events.append((m.log_time, order, 'viewer', m.data))
    if not any(e[2] == 'joint_states' for e in events):
        raise RecordingError(f'{recording.path}: {topic} has no messages')
    return events


def _parameter_changes(data):
    """Return a recorded parameter event's changes to a character's values, by name."""
    event = deserialize_message(data, ParameterEvent)
    changes = {}
    for msg in list(event.new_parameters) + list(event.changed_parameters):
        p = Parameter.from_parameter_msg(msg)
        if p.name in _CHARACTER_NAMES and p.name != 'record':
            value = p.value
            changes[p.name] = [float(v) for v in value] if p.type_ == \
                Parameter.Type.DOUBLE_ARRAY else value
    return changes


_CHARACTER_NAMES = frozenset(VALUE_NAMES)


class ReplayError(ValueError):
    """A session whose replay would hold no simulation; the message is one line."""


def took_any(pipeline: SessionPipeline) -> bool:
    """Tell whether the simulation took at least one of the JointStates a pipeline was given.

    :param pipeline: the pipeline a session ran through.
    """
    return pipeline.inputs > pipeline.dropped


def took_nothing(pipeline: SessionPipeline) -> str:
    """Say that a session's JointStates gave no bones, and why; '' if one gave them.

    The simulation took none of them, or none it took gave finite bones: a replay or
    export of such a session would hold the inputs alone, and no failure may pass for one.
    '' too for a session of no JointState at all (a crowd's character that never had one).

    :param pipeline: the pipeline the session ran through.
    """
    seen = pipeline.inputs + pipeline.undecodable
    if pipeline.published or not seen:
        return ''
    if took_any(pipeline):
        return (f'none of the {pipeline.inputs - pipeline.dropped} JointState messages the '
                'simulation took gave the jacket finite bones')
    first = pipeline.first_refusal or 'it does not decode as JointState'
    return f'the simulation took none of its {seen} JointState messages (the first: {first})'


def run_session(session: SessionInput, sink: Callable[[str, bytes, int], None] | None = None,
                probe: Callable[[SessionPipeline, StepReport, int, list], None] | None = None,
                timing: bool = False) -> SessionPipeline:
    """Feed a session to a fresh pipeline; return the pipeline.

    :param session: the recording's input and set-up.
    :param sink: ``sink(key, bytes, stamp)`` receives every message the node would record,
        stamped in ns.
    :param probe: ``probe(pipeline, report, stamp, outputs)`` sees the state after each input
        (``report.step_cost_ns`` is the simulation's wall time for it).
    :param timing: whether step costs go into diagnostics as the live node does; a replay
        file then differs run to run.
    """
    setup = session.setup
    pipeline = SessionPipeline(setup.skeleton, setup.rig, setup.values, setup.node_name,
                               timing=timing)
    for stamp, _, kind, data in session.events:
        if kind == 'joint_states':
            try:        # as the node takes it: a steady input from its bytes in one call
                report, outputs = pipeline.on_raw(data)
            except Undecodable as e:
                raise RecordingError(f'{session.recording.path}: a {session.topic} message at '
                                     f'{stamp} ns does not decode as JointState ({e})') from None
            stamp = report.stamp_ns         # the node's time: the header stamp, never log time
            if sink:
                sink('joint_states', data, stamp)
                for key, out in outputs:
                    sink(key, out, stamp)
            if probe:
                probe(pipeline, report, stamp, outputs)
        else:
            # Stamped as the node records them: at the last accepted input's stamp.
            last = pipeline.sim.last
            if kind == 'parameter_events':
                pipeline.apply(pipeline.values.with_changes(_parameter_changes(data)))
                stamp = last.stamp_ns if last else 0
            elif kind == 'viewer':
                # The node recorded only viewers it took, and takes them as it does.
                reading = read_viewer(data, pipeline.values.world_frame)
                if reading.position is not None:
                    pipeline.set_viewer(reading.position)
                stamp = last.stamp_ns if last else reading.stamp_ns
            else:
                stamp = last.stamp_ns if last else _header_stamp(data) or 0
            if sink:
                sink(kind, data, stamp)
    return pipeline


def output_topics(session: SessionInput) -> dict[str, tuple[str, str, str]]:
    """Return the topics a replay writes, named as the node names them (inputs keep theirs).

    :param session: the recording's input and set-up.
    """
    topics = session_topics(joint_states=session.topic)
    for key, kind in (('wind', WIND), ('viewer', VIEWER_TYPE)):
        for m in session.recording.messages:
            if m.type_name == kind and m.topic.endswith('/' + key):
                topics[key] = (m.topic,) + topics[key][1:]
                break
    return topics
