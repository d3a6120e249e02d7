# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""How many of the package's functions one steady input passes through before its /tf goes out.

The node is fed as its subscription feeds it (``JacketClothNode.on_joint_states``) and a
profile hook notes every Python call into the package until the first /tf publish. The hops
are the deepest chain of the package's own calls on the way; the files, every package module
a call ran in. Compiled kernels are one call, as they are to Python.
"""

import os
import sys

from jacket_cloth_ros.core.skeleton import Skeleton

HOPS_AT_MOST = 4
FILES_AT_MOST = 3


def hop_count(skeleton: Skeleton, warm_inputs: int = 3) -> dict:
    """Return the hops from the JointState callback to the /tf publish of one steady input.

    :param skeleton: the character the walk moves.
    :param warm_inputs: inputs fed before the one measured (the first resets the cloth).
    :returns: ``chain`` (the deepest chain, as ``module:function``), ``hops`` (its length),
        ``files`` (the package's modules run before the publish) and ``functions`` (how many
        distinct package functions ran).
    """
    import rclpy
    from rclpy.parameter import Parameter

    import jacket_cloth_ros
    from jacket_cloth_ros.core.skeleton import shipped_character_urdf
    from jacket_cloth_ros.motion.clips import joint_state_content
    from jacket_cloth_ros.ros import cdr
    from jacket_cloth_ros.ros.node import JacketClothNode
    from .. import lab_domain
    package = os.path.dirname(jacket_cloth_ros.__file__)
    raw = []
    # The package's encoder, whose string padding is zeros: rclpy's serialisation leaves it
    # as the buffer held it, and the reader knows a name list again by its bytes, padding too,
    # so two of rclpy's messages of one list may not be one list to it.
    for k in range(warm_inputs + 1):
        names, pos = joint_state_content(skeleton.joint_names, 'walk', k / 60.0)
        raw.append(cdr.joint_state(10 ** 10 + int(round(k * 1e9 / 60.0)), names, pos))
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=lab_domain('profile'))     # a profile of one path
    node = JacketClothNode(context=ctx, parameter_overrides=[
        Parameter('robot_description', value=shipped_character_urdf())])
    try:
        character = node.characters[0]
        for content in raw[:-1]:
            node.on_joint_states([(character, content, {})])
        _say_if_not_steady(character.pipeline)
        return _traced(node, character, raw[-1], package)
    finally:
        node.destroy_node()
        rclpy.shutdown(context=ctx)


def _say_if_not_steady(pipeline):
    """Raise, saying why, if the next input of the walk would not go the steady way.

    A count of another path would read as the steady path's grown longer.
    """
    sim = pipeline.sim
    armed = sim.steps.armed_for(sim.steady_key(pipeline.reader.names))
    world_tf = pipeline.values.publish_world_tf and not pipeline.root_is_world_frame()
    if armed and not world_tf and sim.lod.viewer is None:
        return
    raise RuntimeError(
        f'the input to measure would not go the steady way: intake armed {armed}, a world '
        f'/tf {world_tf}, a viewer {sim.lod.viewer is not None}, the last reset '
        f'{pipeline.last_reset_reason!r}, {sim.steps.steady_inputs} steady inputs so far, '
        f'faults {sim.faults}')


def _traced(node, character, content, package):
    """Feed one input under a profile hook; the package's calls until its first /tf."""
    stack, deepest, seen, done = [], [], set(), []
    publish = node.tf.publish

    def published(msg):
        done.append(True)
        return publish(msg)

    def hook(frame, event, arg):
        if event == 'call':
            path = frame.f_code.co_filename
            ours = path.startswith(package)
            stack.append((os.path.relpath(path, package), frame.f_code.co_name) if ours
                         else None)
            if ours and not done:
                chain = [s for s in stack if s]
                seen.add(chain[-1])
                if len(chain) > len(deepest):
                    deepest[:] = chain
        elif event == 'return' and stack:
            stack.pop()
    node.tf.publish = published
    sys.setprofile(hook)
    try:
        node.on_joint_states([(character, content, {})])
    finally:
        sys.setprofile(None)
        node.tf.publish = publish
    if not done:
        raise RuntimeError('the input measured put nothing on /tf')
    return {'chain': [f'{f}:{name}' for f, name in deepest], 'hops': len(deepest),
            'files': sorted({f for f, _ in seen}), 'functions': len(seen)}
