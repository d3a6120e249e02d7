# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A crowd's recording (jacket_cloth_crowd) replayed: every character through its own pipeline.

The crowd node records, per character, its set-up (metadata ``jacket_cloth_session/<name>``)
and each input followed by its outputs, in the order it processed them. A character's outputs
depend on its own inputs only (the crowd's one compiled call gives each character the bits it
gets alone), so running each input through that character's pipeline, in file order, writes
the same messages in the same order: the recorded /tf, byte for byte. The crowd's ``~/viewer``
messages are inputs too: each goes, at its place in the file, to every character whose world
frame it is in, as the node applied it.
"""

import os
import time
from dataclasses import dataclass

from ..core.config import ConfigError, parse_yaml
from ..core.fabric import fabrics_from_data
from ..core.rig import Rig
from ..core.skeleton import skeleton_from
from ..recording.reader import Recording, RecordingError, read_recording
from ..recording.writer import SESSION_CONFIG, SessionRecorder
from ..ros.cdr import Undecodable
from ..ros.pipeline import SessionPipeline, session_topics
from ..ros.values import NodeValues, default_values
from ..ros.viewer import VIEWER_TYPE, read_viewer
from .outputs import replacing
from .session import (JOINT_STATE, ReplayError, recorded_parameters, setup_warnings,
                      took_nothing)

PREFIX = SESSION_CONFIG + '/'


@dataclass
class CrowdCharacter:
    name: str
    pipeline: SessionPipeline
    topics: dict
    setup: dict                 # the recorded metadata, written again into the replay
    warnings: list              # one line each: what its set-up holds that is not known

    @property
    def values(self) -> NodeValues:
        """Return its parameter values: its pipeline's, held there once."""
        return self.pipeline.values


def is_crowd(recording: Recording) -> bool:
    """Tell whether a recording is a crowd's (one set-up per character).

    :param recording: the recording read.
    """
    return any(name.startswith(PREFIX) for name in recording.metadata)


def load_crowd(path: str) -> tuple[Recording, dict[str, CrowdCharacter]]:
    """Read a crowd's recording; returns it and its characters by JointState topic.

    :param path: the crowd's recording, an MCAP file or a bag folder.
    """
    # Only what is fed (every character's inputs, the crowd's viewer): a crowd's /tf and
    # markers are most of its bytes, and a channel of another encoding is no input of it.
    recording = read_recording(path, kinds=(JOINT_STATE, VIEWER_TYPE))
    characters = {}
    for key, meta in recording.metadata.items():
        if not key.startswith(PREFIX):
            continue
        name = key[len(PREFIX):]
        where = f'{path}: {name}'
        missing = [k for k in ('urdf', 'rig_yaml', 'fabrics_yaml', 'parameters_json')
                   if not meta.get(k)]
        if missing:
            raise RecordingError(f'{where}: its recorded set-up has no {", ".join(missing)}')
        skeleton = skeleton_from(meta['urdf'], f'{where} URDF')
        rig = Rig(parse_yaml(meta['rig_yaml'], f'{where} rig'), skeleton, where=f'{where} rig')
        fabrics = fabrics_from_data(parse_yaml(meta['fabrics_yaml'], f'{where} fabrics'),
                                    f'{where} fabrics')
        ignored = []
        recorded = recorded_parameters(meta, f'{where} parameter', ignored)
        preset = recorded.get('fabric_preset')
        if preset not in fabrics:
            raise ConfigError(f'{where}: fabric_preset {preset!r} is not a preset')
        values = default_values(fabrics[preset]).with_changes(recorded)
        ns = '/' + name
        topics = session_topics(f'{ns}/joint_states', f'{ns}/jacket_cloth_node/wind',
                                f'{ns}/jacket_cloth_node/markers')
        try:
            phase = float(meta.get('output_phase', 0.0))
            # Older crowd recordings named the diagnostics by the character alone.
            pipeline = SessionPipeline(skeleton, rig, values,
                                       meta.get('node_name') or name, timing=False,
                                       output_phase=phase)
        except ValueError:
            raise ConfigError(f'{where}: output_phase {meta.get("output_phase")!r} is not a '
                              'number from 0 to 0.9') from None
        # The replay starts from the first input: a file that began mid-session says so of
        # itself, its replay not.
        setup = {k: v for k, v in meta.items() if k != 'inputs_before'}
        characters[topics['joint_states'][0]] = CrowdCharacter(
            name, pipeline, topics, setup, setup_warnings(meta, ignored))
    if not characters:
        raise RecordingError(f'{path}: not a crowd recording (no {PREFIX}<name> metadata)')
    return recording, characters


def replay_crowd(path: str, out_path: str,
                 force: bool = False) -> tuple[dict[str, CrowdCharacter], float]:
    """Write the replay of the crowd recording ``path``; returns (characters, seconds taken).

    :param path: the crowd's recording, an MCAP file or a bag folder.
    :param out_path: the replay's recording, replaced only once it is whole.
    :param force: whether a recording at ``out_path`` is replaced.
    """
    recording, characters = load_crowd(path)
    with replacing(out_path, recording=True, force=force) as tmp:
        recorder = SessionRecorder(tmp, final_name=os.path.basename(os.path.normpath(out_path)),
                                   background=True, compression='lz4', exclusive=False)
        try:
            first = next(iter(characters.values()))
            for key in ('tf', 'diagnostics'):
                recorder.add_topic(*first.topics[key])
            viewers = sorted(t for t, kind in recording.topics.items()
                             if kind == VIEWER_TYPE and t.endswith('/viewer'))
            for topic in viewers:
                recorder.add_topic(topic, *first.topics['viewer'][1:])
            for c in characters.values():
                for key in ('joint_states', 'markers'):
                    recorder.add_topic(*c.topics[key])
                recorder.add_metadata(PREFIX + c.name, c.setup)
            started = time.perf_counter()
            for m in recording.messages:
                c = characters.get(m.topic)
                if c is None:
                    if m.topic in viewers:
                        _apply_viewer(characters.values(), m.data)
                        recorder.write(m.topic, m.data, m.log_time)
                    continue
                try:
                    report, outputs = c.pipeline.on_raw(m.data)
                except Undecodable:
                    c.pipeline.note_undecodable()       # recorded only if it decoded: never
                    continue
                recorder.write(m.topic, m.data, report.stamp_ns)
                for key, data in outputs:
                    recorder.write(c.topics[key][0], data, report.stamp_ns)
            recorder.close()
            took = time.perf_counter() - started
            problems = {c.name: took_nothing(c.pipeline) for c in characters.values()}
            if not any(c.pipeline.published for c in characters.values()):
                name, first = next(((n, p) for n, p in problems.items() if p), (
                    '', 'the simulation took none of its JointState messages'))
                raise ReplayError(f'{path}: {name + ": " if name else ""}{first}, nor of any '
                                  'other character\'s; nothing written')
            for c in characters.values():       # the others replayed: said, not refused
                if problems[c.name]:
                    c.warnings.append(problems[c.name])
        finally:
            recorder.close()
    return characters, took


def _apply_viewer(characters, raw):
    """Set a recorded viewer on each character whose world frame it is in (as the node did)."""
    for c in characters:
        reading = read_viewer(raw, c.values.world_frame)
        if reading.position is not None:
            c.pipeline.set_viewer(reading.position)
