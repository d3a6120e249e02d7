# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Show a recorded ``~/markers`` message in RViz and take a screenshot of it.

    apt-get install rviz xvfb python3-rospy python3-rosmaster python3-visualization-msgs \
        x11-apps imagemagick
    python benchmarks/rviz_render.py out/demo/session.mcap docs/images/rviz_markers.png

RViz 2 is not in the package registries; Debian's ``rviz`` is RViz 1 (ROS 1), whose marker
display draws a ``TRIANGLE_LIST`` as RViz 2's does (both sides, the per-vertex colours unlit).
The script takes one markers message of the recording (``--at``: the share of the way through
it), publishes it on ROS 1 from Debian's Python (``rosmaster`` on a free port, the message
rebuilt field by field), starts RViz in a virtual X display with a Marker display on it and
saves the screen. None of it is installed by the Makefile or used by the tests.
"""

import argparse
import json
import os
import socket
import subprocess
import sys
import tempfile
import time

PUBLISHER = '''
import json, sys, rospy
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray
rospy.init_node('jacket_markers')
pub = rospy.Publisher('/markers', MarkerArray, queue_size=1, latch=True)
out = MarkerArray()
for d in json.load(open(sys.argv[1])):
    m = Marker(ns=d['ns'], id=d['id'], type=d['type'], action=d['action'])
    m.header.frame_id = d['frame']
    p, q = m.pose.position, m.pose.orientation
    p.x, p.y, p.z, q.x, q.y, q.z, q.w = d['pose']
    m.scale.x, m.scale.y, m.scale.z = d['scale']
    m.color = ColorRGBA(*d['color'])
    m.points = [Point(*v) for v in d['points']]
    m.colors = [ColorRGBA(*c) for c in d['colors']]
    out.markers.append(m)
rate = rospy.Rate(2)
while not rospy.is_shutdown():
    for m in out.markers:
        m.header.stamp = rospy.Time.now()
    pub.publish(out)
    rate.sleep()
'''

CONFIG = '''Panels: []
Visualization Manager:
  Class: ""
  Displays:
    - {Class: rviz/Grid, Name: Grid, Enabled: true, Plane: XY, Cell Size: 0.5}
    - {Class: rviz/MarkerArray, Name: Jacket, Enabled: true, Marker Topic: /markers,
       Queue Size: 100}
  Global Options: {Background Color: 235; 235; 235, Fixed Frame: FRAME, Frame Rate: 30}
  Enabled: true
  Name: root
  Views:
    Current: {Class: rviz/Orbit, Distance: 3.0, Focal Point: {X: 0.0, Y: 0.0, Z: 0.2},
              Pitch: 0.25, Yaw: 0.6, Name: Current View, Target Frame: <Fixed Frame>}
Window Geometry: {Height: 700, Width: 900, Hide Left Dock: true, Hide Right Dock: true}
'''


def recorded_markers(path: str, at: float) -> list[dict]:
    """Return one recorded MarkerArray's markers as plain values, the one ``at`` through it.

    :param path: the recording.
    :param at: where in it, a share of its markers messages (0 to 1).
    """
    from rclpy.serialization import deserialize_message
    from visualization_msgs.msg import MarkerArray
    from jacket_cloth_ros.recording.reader import read_messages
    found = read_messages(path, ['/jacket_cloth_node/markers'])[0]
    if not found:
        raise SystemExit(f'{path}: no /jacket_cloth_node/markers message')
    array = deserialize_message(found[min(int(at * len(found)), len(found) - 1)].data,
                                MarkerArray)
    return [{'frame': m.header.frame_id, 'ns': m.ns, 'id': m.id, 'type': m.type,
             'action': m.action,
             'pose': [m.pose.position.x, m.pose.position.y, m.pose.position.z,
                      m.pose.orientation.x, m.pose.orientation.y, m.pose.orientation.z,
                      m.pose.orientation.w],
             'scale': [m.scale.x, m.scale.y, m.scale.z],
             'color': [m.color.r, m.color.g, m.color.b, m.color.a],
             'points': [[p.x, p.y, p.z] for p in m.points],
             'colors': [[c.r, c.g, c.b, c.a] for c in m.colors]} for m in array.markers]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(('localhost', 0))
        return s.getsockname()[1]


def main() -> int:
    """Publish, show and save; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('recording', help='an MCAP recording with ~/markers')
    parser.add_argument('png', help='the screenshot written')
    parser.add_argument('--at', type=float, default=0.4, help='share of the way through it')
    parser.add_argument('--wait', type=float, default=15.0, help='s for RViz to draw')
    args = parser.parse_args()
    markers = recorded_markers(args.recording, args.at)
    port, display = _free_port(), ':97'
    env = dict(os.environ, ROS_MASTER_URI=f'http://localhost:{port}', DISPLAY=display,
               LIBGL_ALWAYS_SOFTWARE='1')
    env.pop('PYTHONPATH', None)         # Debian's Python and its ROS 1 modules
    with tempfile.TemporaryDirectory() as tmp:
        data, code, config = (os.path.join(tmp, n) for n in ('m.json', 'pub.py', 'v.rviz'))
        with open(data, 'w', encoding='utf-8') as f:
            json.dump(markers, f)
        with open(code, 'w', encoding='utf-8') as f:
            f.write(PUBLISHER)
        with open(config, 'w', encoding='utf-8') as f:
            f.write(CONFIG.replace('FRAME', markers[0]['frame']))
        quiet = {'stdout': subprocess.DEVNULL, 'stderr': subprocess.DEVNULL, 'env': env}
        procs = [subprocess.Popen(['Xvfb', display, '-screen', '0', '1000x800x24'], **quiet),
                 subprocess.Popen(['rosmaster', '--core', '-p', str(port)], **quiet)]
        try:
            time.sleep(3)
            procs.append(subprocess.Popen(['/usr/bin/python3', code, data], **quiet))
            procs.append(subprocess.Popen(['rviz', '-d', config], **quiet))
            time.sleep(args.wait)
            shot = subprocess.run(['xwd', '-root', '-silent'], env=env, capture_output=True,
                                  check=True).stdout
            subprocess.run(['convert', 'xwd:-', '-crop', '900x700+0+0', args.png],
                           input=shot, check=True)
        finally:
            for p in reversed(procs):
                p.terminate()
                p.wait(timeout=10)
    print(f'{args.png}: {len(markers)} markers, {len(markers[0]["points"])} jacket corners')
    return 0


if __name__ == '__main__':
    sys.exit(main())
