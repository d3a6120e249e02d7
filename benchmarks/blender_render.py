# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Open an exported session in Blender (the ``bpy`` module), say what came in, render frames.

    python -m venv /tmp/bpy && /tmp/bpy/bin/pip install bpy
    /tmp/bpy/bin/python benchmarks/blender_render.py session.glb out/blender --frames 130,260

Blender's own glTF importer reads the file with its defaults, as File > Import does; the
script prints the armature, the meshes (vertices, faces, vertex groups, parent), the action's
frame range and the jacket's centre at the first, middle and last frame, then renders each
frame asked with Cycles on the CPU, the camera on the jacket. ``bpy`` is a large wheel (Blender
itself), so neither the Makefile nor the tests install it.
"""

import argparse
import math
import sys

import bpy
import mathutils

SAMPLES = 16            # Cycles samples: enough to see the jacket, seconds a frame


def main() -> int:
    """Import, report and render; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('glb', help='the exported session (jacket_cloth export)')
    parser.add_argument('out', help='the PNGs written: OUT_<frame>.png')
    parser.add_argument('--frames', default='130', help='frames to render, comma separated')
    args = parser.parse_args()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=args.glb)
    scene = bpy.context.scene
    armatures = [o for o in bpy.data.objects if o.type == 'ARMATURE']
    meshes = [o for o in bpy.data.objects if o.type == 'MESH' and o.parent in armatures]
    print('armature', [(o.name, len(o.data.bones)) for o in armatures])
    for m in meshes:
        print('mesh', m.name, 'vertices', len(m.data.vertices), 'faces', len(m.data.polygons),
              'vertex groups', len(m.vertex_groups), 'parent', m.parent.name)
    print('actions', [(a.name, tuple(a.frame_range)) for a in bpy.data.actions])
    jacket = next(o for o in meshes if o.name == 'jacket')
    end = int(max(a.frame_range[1] for a in bpy.data.actions))
    for frame in (1, end // 2, end):
        print('frame', frame, 'jacket centre', [round(c, 3) for c in _centre(jacket, frame)])
    for o in bpy.data.objects:
        o.hide_render = o.type == 'MESH' and o not in meshes      # the importer's bone shape
    camera = _stage(scene)
    for frame in (int(f) for f in args.frames.split(',')):
        centre = _centre(jacket, frame)
        camera.location = centre + mathutils.Vector((2.2, -2.2, 0.3))
        camera.rotation_euler = (centre - camera.location).to_track_quat('-Z', 'Y').to_euler()
        scene.render.filepath = f'{args.out}_{frame}.png'
        bpy.ops.render.render(write_still=True)
        print('rendered', scene.render.filepath)
    return 0


def _centre(obj, frame):
    """Return the mean of a skinned mesh's vertices at ``frame``, in the world."""
    bpy.context.scene.frame_set(frame)
    posed = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = posed.to_mesh()
    points = [posed.matrix_world @ v.co for v in mesh.vertices]
    posed.to_mesh_clear()
    return sum(points, mathutils.Vector()) / len(points)


def _stage(scene):
    """Cycles on the CPU, a camera, a sun and a grey sky; returns the camera."""
    scene.render.engine = 'CYCLES'
    scene.cycles.device = 'CPU'
    scene.cycles.samples = SAMPLES
    scene.render.resolution_x, scene.render.resolution_y = 480, 640
    camera = bpy.data.objects.new('camera', bpy.data.cameras.new('camera'))
    scene.collection.objects.link(camera)
    scene.camera = camera
    sun = bpy.data.objects.new('sun', bpy.data.lights.new('sun', 'SUN'))
    sun.data.energy = 4.0
    sun.rotation_euler = (math.radians(40), 0.0, math.radians(30))
    scene.collection.objects.link(sun)
    scene.world = bpy.data.worlds.new('sky')
    scene.world.use_nodes = True
    scene.world.node_tree.nodes['Background'].inputs[1].default_value = 0.6
    return camera


if __name__ == '__main__':
    sys.exit(main())
