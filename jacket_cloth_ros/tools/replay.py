# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``jacket_cloth replay``: a recording through the live node's pipeline, as fast as it runs.

Writes what the node would have recorded: the input JointState (and wind, viewer and
parameter changes) as they were, and the /tf, markers and diagnostics the simulation gives
now. Same input and set-up: a byte-identical file (no wall-clock figure goes into it).
"""

import os
import time
from typing import TYPE_CHECKING

from ..recording.writer import SessionRecorder
from .outputs import replacing
from .session import ReplayError, SessionInput, output_topics, run_session, took_nothing

if TYPE_CHECKING:           # for the annotations only
    from ..ros.pipeline import SessionPipeline


def replay(session: SessionInput, out_path: str,
           force: bool = False) -> tuple['SessionPipeline', float]:
    """Write the replay of ``session`` to ``out_path``; returns (pipeline, seconds taken).

    :param session: the recording's input and set-up.
    :param out_path: the replay's recording, replaced only once it is whole.
    :param force: whether a recording at ``out_path`` is replaced.
    """
    topics = output_topics(session)
    # A failed replay leaves no output.
    with replacing(out_path, recording=True, force=force) as tmp:
        recorder = SessionRecorder(tmp, final_name=os.path.basename(os.path.normpath(out_path)),
                                   background=True,
                                   compression=session.setup.values.record_compression,
                                   exclusive=False)
        try:
            for name, kind, qos in topics.values():
                recorder.add_topic(name, kind, qos)
            setup = session.setup
            recorder.add_session_config(setup.urdf, setup.rig_yaml, setup.fabrics_yaml,
                                        setup.values.by_name(), node_name=setup.node_name)
            started = time.perf_counter()
            pipeline = run_session(
                session, sink=lambda key, data, stamp: recorder.write(topics[key][0], data,
                                                                      stamp))
            recorder.close()                # the writer thread's backlog is part of the time
            took = time.perf_counter() - started
            problem = took_nothing(pipeline)
            if problem:
                raise ReplayError(f'{session.recording.path}: {problem}; nothing written')
        finally:
            recorder.close()
    return pipeline, took
