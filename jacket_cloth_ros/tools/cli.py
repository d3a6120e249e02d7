# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``jacket_cloth``: motion sources, capture import, the demo and session pictures.

Every failure ends in one readable line on stderr and a non-zero exit, never a traceback.
"""

import argparse
import os
import signal
import subprocess
import sys
import threading
import time
from typing import TYPE_CHECKING

from .. import signals
from ..core.config import ConfigError, regular_file_or_refuse, shipped
from ..core.rig import load_rig
from ..motion.clips import (ALL_CLIPS, clip_length, segment_at,
                            showcase_highlights)
from ..motion.messages import clip_messages
from .live import SourceError, Stopped, play_live

if TYPE_CHECKING:           # for the annotations only
    from collections.abc import Callable

    from ..core.rig import Rig
    from ..core.skeleton import Skeleton


# Each number option's allowed range and unit, checked before any work is done: a stamp's
# seconds fit a header stamp (int32) with a long session after it; moments are frames drawn.
OPTION_RANGES = {
    'start': (0.0, 2.0e9, 's'), 'rate': (0.1, 1000.0, 'Hz'), 'duration': (0.0, 3600.0, 's'),
    'wait': (0.0, 3600.0, 's'), 'moments': (1, 24, 'frames'), 'scale': (1e-6, 1e6, ''),
}


class ToolError(Exception):
    """A failure to report in one line."""


def check_numbers(args: argparse.Namespace) -> None:
    """Refuse a number option outside its range (OPTION_RANGES) in one line naming it.

    :param args: a command's parsed options; those it lacks are not checked.
    """
    for name, (low, high, unit) in OPTION_RANGES.items():
        value = getattr(args, name, None)
        if value is not None and not low <= value <= high:      # NaN too
            raise ToolError(f'--{name.replace("_", "-")} {value:g} is outside [{low:g}, '
                            f'{high:g}]{" " + unit if unit else ""}')


def _skeleton(urdf_path=None):
    from ..core.skeleton import load_skeleton
    path = urdf_path or shipped('character.urdf')
    return load_skeleton(path), path


def cmd_motion(args: argparse.Namespace) -> int:
    """Play a built-in clip live on joint_states (with its URDF), or write it to a recording.

    A skeleton without the clip's joints gets the clip retargeted through its body parts.

    :param args: the ``motion`` command's options.
    """
    skeleton, urdf_path = _skeleton(args.urdf)
    retarget = _retarget_if_needed(args.clip, skeleton, urdf_path)
    duration = args.duration if args.duration is not None else clip_length(args.clip)
    if args.output:
        return _motion_to_file(args, skeleton, duration, retarget)
    with open(urdf_path, encoding='utf-8') as f:
        urdf = f.read()
    inputs = ((stamp, msg.name, msg.position) for stamp, msg in clip_messages(
        skeleton, args.clip, args.rate, duration, 0, args.world_joint, retarget))
    play_live('jacket_cloth_motion', urdf, inputs, args.ros_args, args.best_effort, args.wait,
              lambda log, verb: log.info(f'{verb} {args.clip!r} for {duration:.1f} s at '
                                         f'{args.rate} Hz'))
    return 0


def cmd_play(args: argparse.Namespace) -> int:
    """Publish a recording's JointStates live at their pace, and its URDF.

    :param args: the ``play`` command's options.
    """
    from .play import recorded_inputs
    urdf, inputs, what = recorded_inputs(args.input, args.topic, args.urdf)
    if urdf is None:
        print(f'jacket_cloth play: {args.input} holds no URDF and no --urdf was given: '
              'robot_description is not published', file=sys.stderr)
    sent = play_live('jacket_cloth_play', urdf, inputs, args.ros_args, args.best_effort,
                     args.wait, lambda log, verb: log.info(f'{verb} {what}'))
    print(f'played {sent} JointState messages of {args.input}')
    return 0


def _retarget_if_needed(clip, skeleton, urdf_path):
    """Return the clip retargeted onto a skeleton unlike the clips' (said in one line).

    None for the character the clips are made for: every joint the clip moves, each turning
    as the shipped character's does (motion.retarget.unlike_the_clips_character).
    """
    from ..motion.retarget import Retarget, unlike_the_clips_character
    unlike = unlike_the_clips_character(skeleton, clip)
    if not unlike:
        return None
    retarget = Retarget(skeleton)            # a skeleton without a body refuses in one line
    print(f'jacket_cloth motion: {urdf_path} {unlike}: retargeted '
          f'through its body parts ({retarget.roles()}), standing upright in the world',
          file=sys.stderr)
    return retarget


def _motion_to_file(args, skeleton, duration, retarget):
    from ..recording.writer import SessionRecorder, qos_profile_yaml
    from ..ros.cdr import joint_state
    from .outputs import replacing
    _check_output(args.output, args.force, [args.urdf], recording=True)
    with replacing(args.output, recording=True, force=args.force) as tmp:
        rec = SessionRecorder(tmp, final_name=os.path.basename(os.path.normpath(args.output)),
                              exclusive=False)
        rec.add_topic('/joint_states', 'sensor_msgs/msg/JointState', qos_profile_yaml())
        count = 0
        for stamp, msg in clip_messages(skeleton, args.clip, args.rate, duration,
                                        int(args.start * 1e9), args.world_joint,
                                        retarget):
            rec.write('/joint_states', joint_state(stamp, msg.name, msg.position), stamp)
            count += 1
        rec.close()
    print(f'wrote {count} JointState messages of {args.clip!r} to {args.output}')
    return 0


def cmd_import(args: argparse.Namespace) -> int:
    """Turn a BVH capture (or, with --urdf, a DeepMimic clip) into a JointState recording.

    :param args: the ``import`` command's options.
    """
    from ..motion.bvh import BvhError, height_warning, joint_state_content, load_capture, \
        stamps_ns
    from ..motion.deepmimic import ClipError, load_clip
    from ..recording.writer import SessionRecorder, qos_profile_yaml
    from ..ros.cdr import joint_state
    from .outputs import replacing
    if args.urdf and args.urdf_out:
        raise ToolError('--urdf-out is for a BVH capture; a DeepMimic clip moves the --urdf given')
    if args.urdf_out and os.path.abspath(args.urdf_out) == os.path.abspath(args.output):
        raise ToolError('--urdf-out and -o are the same file')
    _check_output(args.output, args.force, [args.input, args.urdf], recording=True)
    if args.urdf_out:
        _check_output(args.urdf_out, args.force, [args.input, args.output])
    if os.path.lexists(args.input):        # a FIFO would block the first read
        regular_file_or_refuse(args.input, 'input')
    if not args.urdf and _looks_like_json(args.input):
        raise ToolError(f'{args.input} is JSON, not BVH: a DeepMimic clip needs --urdf (the '
                        "humanoid it moves, pybullet's humanoid.urdf)")
    try:
        capture = load_clip(args.input, args.urdf, args.scale) if args.urdf else \
            load_capture(args.input, args.scale)
    except (BvhError, ClipError) as e:
        raise ToolError(str(e)) from None
    warning = None if args.urdf else height_warning(capture)
    if warning:
        print(f'jacket_cloth import: {args.input}: {warning}', file=sys.stderr)
    if not args.urdf and capture.renamed:       # a BVH capture's (a DeepMimic clip has none)
        joined = ', '.join(f'{a!r} as {b!r}' for a, b in capture.renamed[:3]) + (
            f' and {len(capture.renamed) - 3} more' if len(capture.renamed) > 3 else '')
        print(f'jacket_cloth import: {args.input}: warning: joint names with spaces, their words '
              f'joined by _: {joined}', file=sys.stderr)
    stamps = stamps_ns(capture, int(round(args.start * 1e9)))
    with replacing(args.output, recording=True, force=args.force) as tmp:
        rec = SessionRecorder(tmp, final_name=os.path.basename(os.path.normpath(args.output)),
                              exclusive=False)
        rec.add_topic('/joint_states', 'sensor_msgs/msg/JointState', qos_profile_yaml())
        for k, stamp in enumerate(stamps):
            names, positions = joint_state_content(capture, k, args.world_joint)
            rec.write('/joint_states', joint_state(int(stamp), names, positions), int(stamp))
        rec.close()
    if args.urdf_out:
        with replacing(args.urdf_out, force=args.force) as tmp:
            with open(tmp, 'w', encoding='utf-8') as f:
                f.write(capture.urdf)
    if args.urdf:
        print(f'wrote {capture.frames} JointState messages at {1.0 / capture.frame_time:.6g} Hz '
              f'to {args.output} ({len(capture.joint_names)} joints of {args.urdf}, root '
              f'positions times {capture.scale:g})')
        return 0
    print(f'wrote {capture.frames} JointState messages at {1.0 / capture.frame_time:.6g} Hz '
          f'to {args.output}' + (f' and the URDF to {args.urdf_out}' if args.urdf_out else '')
          + f' ({len(capture.joint_names)} joints, scale {capture.scale:g} m per unit, '
          f'{capture.height_m:.2f} m tall)')
    return 0


def _looks_like_json(path):
    try:
        with open(path, 'rb') as f:
            return f.read(64).lstrip().startswith(b'{')
    except OSError:
        return False            # the reader says what is wrong with it


def _check_output(path, force, inputs=(), recording=False):
    from .outputs import check_output
    check_output(path, force, inputs, recording)


def cmd_picture(args: argparse.Namespace) -> int:
    """Draw a filmstrip PNG of a recorded session.

    :param args: the ``picture`` command's options.
    """
    from ..tools.picture import render_filmstrip
    from .outputs import OutputError, check_picture, replacing_all, same_name
    from .session import recorded_character
    _check_output(args.output, args.force, [args.input, args.urdf, args.rig])
    check_picture(args.output)
    gif = os.path.splitext(args.output)[0] + '.gif' if args.animate else None
    if gif and same_name(gif, args.output):
        raise OutputError(f'--animate writes the animation to {gif}, the filmstrip\'s own '
                          'name: give the filmstrip another extension (.png)')
    if gif:
        _check_output(gif, args.force, [args.input, args.urdf, args.rig, args.output])
    skeleton, rig = recorded_character(args.input, args.urdf, args.rig)
    # The filmstrip and its animation are put in place together: one that fails leaves
    # neither, not a filmstrip a second run would refuse to overwrite.
    with replacing_all([args.output] + ([gif] if gif else []), force=args.force) as (
            tmp, *animation):
        render_filmstrip(args.input, tmp, skeleton, moments=args.moments, rig=rig,
                         style=args.style)
        if gif:
            from .animation import render_animation
            frames = render_animation(args.input, animation[0], skeleton, rig,
                                      style=args.style)
    print(args.output)
    if gif:
        print(f'{gif} ({frames} frames)')
    return 0


def _session(args, listed=None):
    from .session import load_session
    session = load_session(args.input, topic=args.topic, urdf=args.urdf, rig=args.rig,
                           fabric=args.fabric, overrides=args.param or (), listed=listed)
    for line in session.warnings:
        print(f'jacket_cloth {args.command}: warning: {args.input}: {line}', file=sys.stderr)
    if not session.recording.complete:
        print(f'jacket_cloth {args.command}: warning: {args.input} is cut short; using its '
              'readable part', file=sys.stderr)
    return session


def _warn_rig(args: argparse.Namespace, lines: list[str]) -> None:
    """Print what the simulation found wrong: the rig at load and first input, a collapse."""
    for line in lines:
        print(f'jacket_cloth {args.command}: warning: {args.input}: {line}', file=sys.stderr)


def cmd_replay(args: argparse.Namespace) -> int:
    """Run a recording (a crowd's too) through the simulation again into a new recording.

    :param args: the ``replay`` command's options.
    """
    from .replay import replay
    _check_output(args.output, args.force, [args.input, args.urdf, args.rig], recording=True)
    from ..recording.reader import read_recording
    from .crowd_replay import is_crowd
    from .session import NO_MESSAGES
    # Its topics and set-ups tell a crowd's and which inputs to keep; then the messages, in
    # one more pass. One pass would hold every JointState topic's inputs until the set-up
    # records, which may come anywhere in the file, said which are wanted.
    listed = read_recording(args.input, NO_MESSAGES)
    if is_crowd(listed):
        return _replay_crowd(args)
    session = _session(args, listed)
    pipeline, took = replay(session, args.output, args.force)
    sim = pipeline.sim
    _warn_rig(args, sim.faults.rig + sim.faults.collapse + sim.faults.restless
              + sim.faults.under_floor)
    first, last = session.stamp_range()
    span = (last - first) * 1e-9
    print(f'{args.output}: {pipeline.inputs} JointState ({pipeline.dropped} dropped), '
          f'{sim.steps_total} steps, {sim.resets} resets; {span:.1f} s of session in '
          f'{took:.2f} s ({span / max(took, 1e-9):.0f}x real time)')
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    """Write a recorded session as glTF 2.0 binary: skeleton and jacket layer, meshes, motion.

    :param args: the ``export`` command's options.
    """
    from ..recording.reader import read_recording
    from .crowd_replay import is_crowd
    from .session import NO_MESSAGES
    try:
        from .export import export
    except ImportError as e:        # pygltflib has no rosdep key: a ROS install may lack it
        raise ToolError(f'{e}: export needs pygltflib (pip install pygltflib)') from None
    if not args.output.lower().endswith('.glb'):
        # What it writes is binary glTF: under another name (session.mcap out of a replay's
        # habit, .gltf, which is JSON) a viewer or a tool would misread it.
        raise ToolError(f'{args.output}: export writes binary glTF; end the name in .glb')
    _check_output(args.output, args.force, [args.input, args.urdf, args.rig])
    listed = read_recording(args.input, NO_MESSAGES)
    if is_crowd(listed):
        raise ToolError(f'{args.input} is a crowd\'s recording: export takes one character\'s '
                        'session (a jacket_cloth_node recording, or a JointState recording with '
                        '--urdf and --rig)')
    session = _session(args, listed)
    done = export(session, args.output, args.force)
    _warn_rig(args, done.rig_warnings)
    if done.restarts:
        print(f'jacket_cloth export: warning: {args.input}: the stamps went back {done.restarts} '
              'time(s) (the simulation reset); those inputs are keyed on after the last',
              file=sys.stderr)
    size = os.path.getsize(args.output)
    print(f'{args.output}: {done.frames} frames of {done.inputs} JointState, '
          f'{done.joints} joints ({done.links} links, {done.bones} bones), '
          f'{done.vertices} vertices, {size / 1e6:.1f} MB in {done.seconds:.2f} s')
    return 0


def _replay_crowd(args):
    """Replay a crowd's recording: every character with its recorded set-up."""
    from .crowd_replay import replay_crowd
    given = [o for o, v in (('--urdf', args.urdf), ('--rig', args.rig), ('--fabric', args.fabric),
                            ('--topic', args.topic), ('-p', args.param)) if v]
    if given:
        raise ConfigError(f'{args.input} is a crowd\'s recording: it replays with each '
                          f'character\'s recorded set-up ({", ".join(given)} not taken)')
    characters, took = replay_crowd(args.input, args.output, args.force)
    for c in characters.values():
        for line in c.warnings:
            print(f'jacket_cloth {args.command}: warning: {args.input}: {c.name}: {line}',
                  file=sys.stderr)
    inputs = sum(c.pipeline.inputs for c in characters.values())
    print(f'{args.output}: {len(characters)} characters, {inputs} JointState in {took:.2f} s')
    return 0


def cmd_analyze(args: argparse.Namespace) -> int:
    """Write the figures, charts and filmstrips of recorded sessions; print the summary line.

    :param args: the ``analyze`` command's options.
    """
    from .analyze import output_names, summary_line
    from .outputs import check_output_folder
    if len(args.input) > 1 and not args.compare:
        raise ToolError('several sessions: add --compare to lay them side by side')
    check_output_folder(args.out, output_names(len(args.input)), args.force,
                        list(args.input) + [args.urdf, args.rig])
    sessions = []
    for path in args.input:
        sessions.append(_session(argparse.Namespace(**{**vars(args), 'input': path})))
    report = _analyze_into(args.out, args.force, sessions, args.moments)
    for r in report.get('sessions', [report]):
        _warn_rig(argparse.Namespace(**{**vars(args), 'input': r['file']}),
                  r['rig_warnings'] + r['collapsed'] + r.get('restless', [])
                  + r.get('under_floor', []))
    print(f'{os.path.join(args.out, "report.json")}: {summary_line(report)}')
    return 0


def _analyze_into(out: str, force: bool, sessions: list, moments: int) -> dict:
    """Run ``analyze`` into a scratch folder in ``out``, then move its files into ``out``.

    The files are placed all or none (outputs.place_all): without --force, a file made in
    ``out`` while the sessions ran is refused, not overwritten, and nothing new is left beside it.
    """
    import shutil
    import tempfile
    from .analyze import analyze
    from .outputs import place_all
    os.makedirs(out, exist_ok=True)
    scratch = tempfile.mkdtemp(prefix='.analyze.', suffix='.partial', dir=out)
    try:
        report = analyze(sessions, scratch, moments=moments)
        names = sorted(os.listdir(scratch))
        place_all(scratch, names, [os.path.join(out, name) for name in names], force)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return report


def cmd_demo(args: argparse.Namespace) -> int:
    """Node + motion source live over real DDS for the showcase clip, then a filmstrip.

    :param args: the ``demo`` command's options.
    """
    from ..tools.picture import render_filmstrip
    os.makedirs(args.out, exist_ok=True)
    session = os.path.join(args.out, 'session.mcap')
    picture = os.path.join(args.out, 'filmstrip.png')
    for path in (session, picture):
        _check_output(path, True)           # a device or folder there is refused, not removed
        if os.path.exists(path):
            os.remove(path)
    # The node (a child) and the motion source (this process) meet in one local domain.
    os.environ.setdefault('ROS_DOMAIN_ID', str(args.domain_id))
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    # The ROS arguments go to both, so a namespace or a remap keeps them talking.
    node = subprocess.Popen(
        [*signals.node_command(), *args.ros_args, '--ros-args', '-p', f'record:={session}'])
    try:
        time.sleep(2.0)
        if node.poll() is not None:
            raise ToolError(f'jacket_cloth_node exited early with code {node.returncode}')
        motion = argparse.Namespace(clip='showcase', rate=60.0, duration=None, urdf=None,
                                    output=None, best_effort=False, wait=30.0,
                                    world_joint='world_joint', force=False,
                                    ros_args=args.ros_args)
        print(f'demo: playing the showcase clip ({clip_length("showcase"):.0f} s) live ...')
        cmd_motion(motion)
        time.sleep(0.5)
    finally:
        node.send_signal(signal.SIGINT)
        try:
            node.wait(timeout=15)
        except subprocess.TimeoutExpired:
            node.kill()
    if not os.path.exists(session):
        raise ToolError('the node wrote no recording')
    skeleton, _ = _skeleton()
    highlights = [h for h in showcase_highlights() if h[1] != 'idle']
    render_filmstrip(session, picture, skeleton, times=[t for t, _ in highlights],
                     labels=lambda dt: segment_at('showcase', dt * 1e-9)[0],
                     rig=load_rig(skeleton))
    print(f'demo: session recording  {os.path.abspath(session)}')
    print(f'demo: picture            {os.path.abspath(picture)}')
    return 0


def cmd_rig(args: argparse.Namespace) -> int:
    """Propose a rig for a URDF: say which links and why, write commented YAML, a picture.

    :param args: the ``rig`` command's options.
    """
    import yaml
    from ..core.rig import Rig
    from ..core.skeleton import load_skeleton
    from ..rigging.propose import propose, to_yaml
    from .outputs import OutputError, check_picture, replacing_all, same_name
    if args.topic and not args.motion:
        raise ToolError(f'--topic {args.topic} names a JointState topic of --motion: give '
                        '--motion too')
    _check_output(args.output, args.force, [args.urdf, args.motion])
    if args.picture:
        if same_name(args.picture, args.output):
            raise OutputError(f'--picture {args.picture} is the rig\'s own name: give the '
                              'picture another')
        _check_output(args.picture, args.force, [args.urdf, args.output, args.motion])
        check_picture(args.picture)
    skeleton = load_skeleton(args.urdf)
    for line in skeleton.warnings:
        print(f'jacket_cloth rig: warning: {args.urdf}: {line}', file=sys.stderr)
    forward = _vector(args.forward, '--forward') if args.forward else None
    first = _first_pose(args.motion, skeleton, args.world_joint, args.topic) \
        if args.motion else None
    rig, lines, body = propose(skeleton, forward)

    def load(rig):
        text = to_yaml(rig, lines, os.path.basename(args.urdf), body)
        try:
            return text, Rig(yaml.safe_load(text), skeleton, where=args.output)
        except ConfigError as e:
            # Named by its keys alone: the file the error would name is not written.
            detail = str(e).removeprefix(f'{args.output}.')
            hint = (f'; --forward {args.forward} may not be the way the character faces (without '
                    'it, that is inferred from its toes)' if args.forward else '')
            raise ToolError(f'the proposed rig does not load ({detail}){hint}') from None
    text, loaded = _clear_of_colliders(rig, lines, load)
    if first is not None:
        # As the simulation judges a first input; gravity and the floor stay the world's.
        tilt = loaded.body_tilt(skeleton.forward(first[0]), first[1])
        if tilt is not None:
            up = ', '.join(f'{v:g}' for v in loaded.world_up)
            lines.append(f'{"first pose":>15}: the body lies {tilt[1]:.0f} deg from the world\'s '
                         f'up [{up}]; gravity and the floor stay the world\'s')
            text, loaded = load(rig)
    # Both files are written before either is put in place: a picture that fails (a full
    # disk) leaves no rig beside it that a second run would refuse to overwrite.
    with replacing_all([args.output] + ([args.picture] if args.picture else []),
                       force=args.force) as (tmp, *picture):
        with open(tmp, 'w', encoding='utf-8') as f:
            f.write(text)
        if picture:
            from ..rigging.picture import draw_rig
            draw_rig(loaded, body.up, body.forward, picture[0],
                     title=f'{os.path.basename(args.urdf)}: the proposed rig at rest')
    for line in lines:
        print(line)
    print(f'wrote {args.output} ({body.height:.2f} m tall'
          + (f', up {rig["up"]}' if 'up' in rig else '') + ')')
    if args.picture:
        print(f'wrote {args.picture}')
    return 0


def _clear_of_colliders(rig: dict, lines: list,
                        load: 'Callable[[dict], tuple[str, Rig]]') -> tuple[str, 'Rig']:
    """Widen a proposed cloth until it starts outside its colliders, as the node checks it.

    The simulation names a rest cloth inside the body at load (TALOS's proposal was inside
    its pelvis): the radii grow by that depth until the check passes, a few rounds at most,
    and a line says by how much, and where the cloth is still inside if it is (a warning).

    :param rig: the proposed rig (propose's mapping), its radii changed in place.
    :param lines: the proposal's lines, one added if the radii grow.
    :param load: ``load(rig) -> (YAML text, Rig)``.
    """
    from ..core.simulation import INSIDE_AT_REST, deepest_at_rest as deepest
    shape = rig['cloth']['shape']
    proposed = list(shape['radii'])
    text, loaded = load(rig)
    first = worst = deepest(loaded)
    for _ in range(4):
        if worst.value <= INSIDE_AT_REST:
            break
        shape['radii'] = [round(r + worst.value + INSIDE_AT_REST, 3) for r in shape['radii']]
        text, loaded = load(rig)
        worst = deepest(loaded)
    if worst is first:
        return text, loaded
    line = (f'{"cloth radii":>15}: widened from {proposed} to {shape["radii"]}: the rest '
            f'cloth was {first.value * 1e3:.0f} mm inside collider {first.collider!r}')
    if worst.value > INSIDE_AT_REST:
        line += (f', and is still {worst.value * 1e3:.0f} mm inside {worst.collider!r}: widen '
                 'cloth.shape.radii or shrink that collider')
        print(f'jacket_cloth rig: warning: {line.strip()}', file=sys.stderr)
    lines.append(line)
    return load(rig)


def _first_pose(path: str, skeleton: 'Skeleton', world_joint: str,
                topic: str | None = None) -> tuple:
    """Return (joint values, root's world rotation) of a recording's first JointState.

    Of its JointState topic as replay picks it: ``topic``, else the only one (a crowd's
    recording has one per character, each another skeleton's).
    """
    from ..core.inputs import InputParser, InputRejected
    from ..recording.reader import read_recording
    from ..ros.cdr import DECODE_ERRORS, JointStateReader
    from .session import NO_MESSAGES, joint_state_topic
    topic = joint_state_topic(read_recording(path, NO_MESSAGES), topic)
    recording = read_recording(path, topics=(topic,))
    first = next(iter(recording.messages), None)
    if first is None:
        raise ToolError(f'--motion {path}: no message on {topic}')
    try:
        msg = JointStateReader().read(first.data)
        parser = InputParser(skeleton, world_joint)
        sample = parser.parse(msg.stamp_ns, msg.name, msg.position)
    except DECODE_ERRORS as e:
        raise ToolError(f'--motion {path}: its first {first.topic} does not decode as '
                        f'JointState ({e})') from None
    except InputRejected as e:
        raise ToolError(f'--motion {path}: its first {first.topic}: {e}') from None
    # A message of the world pose alone is the node's too; joints none of the URDF's are not.
    joints = set(msg.name) - set(parser.world_names)
    if joints and not joints & set(skeleton.joint_names):
        raise ToolError(f'--motion {path}: none of the {len(joints)} joint names of its first '
                        f'{first.topic} is the URDF\'s: it moves another skeleton')
    # Names the URDF lacks or a world pose under another prefix change the verdict: said.
    for _, text in sample.warnings:
        print(f'jacket_cloth rig: warning: --motion {path}: its first {first.topic}: {text}',
              file=sys.stderr)
    return sample.q, sample.root[:3, :3]


def _vector(text, what):
    try:
        v = [float(t) for t in text.replace(',', ' ').split()]
    except ValueError:
        v = []
    if len(v) != 3 or not all(abs(x) < 1e6 for x in v) or not any(v):
        raise ToolError(f'{what}: expected three numbers such as 1,0,0, got {text!r}')
    return v


def cmd_warm(args: argparse.Namespace) -> int:
    """Compile the node's kernels into numba's cache now (or load them); say how long it took.

    :param args: the ``warm`` command's options (none of its own).
    """
    from ..ros.warm import warm_kernels
    took, cached = warm_kernels()
    print(f'kernels {"loaded from the cache" if cached else "compiled and cached"} in '
          f'{took:.1f} s')
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog='jacket_cloth', description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest='command', required=True)
    m = sub.add_parser('motion', help='play a built-in clip live on joint_states or to MCAP')
    m.add_argument('--clip', default='showcase', choices=ALL_CLIPS)
    m.add_argument('--rate', type=float, default=60.0, help='JointState rate in Hz')
    m.add_argument('--duration', type=float, default=None, help='s (default: the clip)')
    m.add_argument('--output', '-o', default=None,
                   help='write a recording instead: an MCAP file (.mcap), else a bag folder')
    m.add_argument('--start', type=float, default=1000.0, help='first stamp (s) in a file')
    m.add_argument('--urdf', default=None, help='the character (default: shipped)')
    m.add_argument('--world-joint', default='world_joint')
    m.add_argument('--best-effort', action='store_true', help='publish best effort')
    m.add_argument('--wait', type=float, default=1.0,
                   help='s to wait for a joint_states subscriber before the clip starts')
    m.add_argument('--force', action='store_true', help='overwrite the output file')
    m.set_defaults(func=cmd_motion)
    y = sub.add_parser('play', help="publish a recording's JointState live at its pace (and its "
                       'URDF on robot_description), to drive the node, RViz or Foxglove')
    y.add_argument('input', help='an MCAP file or a rosbag2 bag directory (MCAP storage)')
    y.add_argument('--topic', default=None,
                   help='JointState topic (default: the only one in the file)')
    y.add_argument('--urdf', default=None,
                   help='the character for robot_description (default: the recorded one)')
    y.add_argument('--best-effort', action='store_true', help='publish best effort')
    y.add_argument('--wait', type=float, default=1.0,
                   help='s to wait for a joint_states subscriber before the first message')
    y.set_defaults(func=cmd_play)
    d = sub.add_parser('demo', help='node + motion live, recording and a picture')
    d.add_argument('--out', default='out/demo')
    d.add_argument('--domain-id', type=int, default=232,
                   help='ROS_DOMAIN_ID if not set (tests use 20-223, the lab 224-231)')
    d.set_defaults(func=cmd_demo)
    f = sub.add_parser('picture', help='filmstrip PNG of a recorded session')
    f.add_argument('input')
    f.add_argument('-o', '--output', required=True)
    f.add_argument('--moments', type=int, default=6)
    f.add_argument('--urdf', default=None,
                   help='the character (default: the recorded one; required without it)')
    f.add_argument('--rig', default=None,
                   help='rig YAML of the session (default: the recorded one, else shipped)')
    f.add_argument('--animate', action='store_true',
                   help='also write the session as a GIF beside the picture (OUTPUT.gif)')
    f.add_argument('--style', choices=('jacket', 'debug'), default='jacket',
                   help='jacket: the shaded jacket and hood on the body; debug: the stick '
                        'figure, cloth grid, pendulum and bones (recorded with markers_debug)')
    f.add_argument('--force', action='store_true')
    f.set_defaults(func=cmd_picture)
    r = sub.add_parser('replay', help='run a recording through the simulation again')
    r.add_argument('input', help='an MCAP file or a rosbag2 bag directory (MCAP storage)')
    r.add_argument('-o', '--output', required=True,
                   help='the recording: an MCAP file (.mcap), else a rosbag2 bag folder')
    _session_options(r)
    r.add_argument('--force', action='store_true', help='overwrite the output file')
    r.set_defaults(func=cmd_replay)
    a = sub.add_parser('analyze', help='figures, charts and a filmstrip of recorded sessions')
    a.add_argument('input', nargs='+', help='MCAP files or rosbag2 bag directories')
    a.add_argument('--out', required=True, help='folder for report.json, summary.md, PNGs')
    a.add_argument('--compare', action='store_true', help='lay several sessions side by side')
    a.add_argument('--moments', type=int, default=6, help='filmstrip frames per session')
    _session_options(a)
    a.add_argument('--force', action='store_true', help='overwrite an existing report')
    a.set_defaults(func=cmd_analyze)
    e = sub.add_parser('export', help='a recorded session as glTF 2.0 binary (.glb): the '
                       'skeleton and jacket bones as one skin, the jacket, hood and body meshes, '
                       'the motion as an animation (Blender, three.js)')
    e.add_argument('input', help='an MCAP file or a rosbag2 bag directory (MCAP storage)')
    e.add_argument('-o', '--output', required=True, help='the .glb file to write')
    _session_options(e)
    e.add_argument('--force', action='store_true', help='overwrite the output file')
    e.set_defaults(func=cmd_export)
    i = sub.add_parser('import', help='a BVH motion capture, or a DeepMimic clip, as a '
                       'JointState recording (and a BVH skeleton as a URDF)')
    i.add_argument('input', help='a .bvh file, or a DeepMimic clip (humanoid3d_*.txt) with --urdf')
    i.add_argument('-o', '--output', required=True,
                   help='the recording: an MCAP file (.mcap), else a rosbag2 bag folder')
    i.add_argument('--urdf-out', default=None, help="write the capture's skeleton as a URDF")
    i.add_argument('--urdf', default=None,
                   help="the humanoid a DeepMimic clip moves (pybullet's humanoid.urdf)")
    i.add_argument('--scale', type=float, default=None,
                   help='BVH: metres per unit (default: m, cm, mm or in, whichever makes the '
                   'rest skeleton\'s largest span nearest 1.7 m); DeepMimic: URDF lengths per '
                   'clip length (default 4: pybullet loads the humanoid at a quarter)')
    i.add_argument('--start', type=float, default=1000.0, help='first stamp (s)')
    i.add_argument('--world-joint', default='world_joint')
    i.add_argument('--force', action='store_true', help='overwrite the output files')
    i.set_defaults(func=cmd_import)
    g = sub.add_parser('rig', help='propose a jacket rig for a URDF skeleton (and a picture)')
    g.add_argument('--urdf', required=True, help='the character')
    g.add_argument('-o', '--output', required=True, help='the rig YAML to write')
    g.add_argument('--picture', default=None, help='also draw the rig at rest into this PNG')
    g.add_argument('--forward', default=None,
                   help="the character's forward in the URDF root frame (default: where the "
                   'toes point, else from the left and right names, else 1,0,0); a negative '
                   'one as --forward=-1,0,0')
    g.add_argument('--motion', default=None,
                   help='a recording of the character: says whether the body lies down at its '
                   "first JointState (gravity and the floor stay the world's up, +z)")
    g.add_argument('--topic', default=None,
                   help='its JointState topic (with --motion; default: the only one, or '
                   '/joint_states)')
    g.add_argument('--world-joint', default='world_joint',
                   help='the world joint the recording names (with --motion)')
    g.add_argument('--force', action='store_true', help='overwrite the output files')
    g.set_defaults(func=cmd_rig)
    w = sub.add_parser('warm', help="compile the node's kernels into numba's cache now, so its "
                       'first start takes seconds (make runs it; after colcon build, once)')
    w.set_defaults(func=cmd_warm)
    return p


def _session_options(parser):
    parser.add_argument('--topic', default=None,
                        help='JointState topic (default: the only one in the file)')
    parser.add_argument('--urdf', default=None,
                        help='URDF file (default: the recorded one, else the shipped character)')
    parser.add_argument('--rig', default=None,
                        help='rig YAML (default: the recorded one, else the shipped rig)')
    parser.add_argument('--fabric', default=None, help='fabric preset instead of the recorded')
    parser.add_argument('-p', '--param', action='append', metavar='NAME:=VALUE',
                        help='a node parameter, as with --ros-args -p (repeatable)')


def split_ros_args(argv: list[str]) -> tuple[list[str], list[str]]:
    """Split ``argv`` into the command's own arguments and the ROS ones (``--ros-args`` ...).

    A ROS block runs to a ``--`` or the end, as rcl reads it; there may be several.

    :param argv: the command line, without the program's name.
    """
    own, ros, inside = [], [], False
    for a in argv:
        if a == '--ros-args':
            inside = True
            ros.append(a)
        elif inside and a == '--':
            inside = False
        else:
            (ros if inside else own).append(a)
    return own, ros


def main(argv: list[str] | None = None) -> int:
    """Run a ``jacket_cloth`` command; a failure is one line on stderr and exit 1.

    :param argv: the arguments, without the program's name; None: the process's.
    """
    # ROS arguments (ros2 launch adds some to every executable) are for the commands that
    # start a node, motion, play and demo; the others have no node to give them to.
    own, ros = split_ros_args(sys.argv[1:] if argv is None else list(argv))
    args = build_parser().parse_args(own)
    args.ros_args = ros
    # SIGTERM stops a command as Ctrl-C does, its outputs' temporary files removed on the way
    # out: by default it ended the process where it stood and left them behind.
    main_thread = threading.current_thread() is threading.main_thread()   # where signals go
    previous = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)} \
        if main_thread else {}
    if main_thread:
        signal.signal(signal.SIGTERM, _terminated)
    try:
        check_numbers(args)
        return args.func(args)
    except (ToolError, SourceError, ConfigError, ValueError, OSError) as e:
        print(f'jacket_cloth {args.command}: {e}', file=sys.stderr)
        return 1
    except Stopped as e:
        print(f'jacket_cloth {args.command}: {e}', file=sys.stderr)
        return 128 + e.signum
    except KeyboardInterrupt:
        return 130
    finally:
        for signum, handler in previous.items():    # only what this run changed
            if handler is not None and signal.getsignal(signum) is not handler:
                signal.signal(signum, handler)


def _terminated(signum: int, frame: object) -> None:
    for other in (signal.SIGINT, signal.SIGTERM):    # a second one must not cut the clean-up
        signal.signal(other, signal.SIG_IGN)
    raise Stopped(signum)


if __name__ == '__main__':
    sys.exit(main())
