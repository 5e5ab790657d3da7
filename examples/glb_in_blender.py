"""Draw a moment of a ``twig export`` .glb with Blender, headless, and read its bones back.

A check that another program sees what twig simulated (docs/export.md): Blender's own
glTF importer loads the file, its own armatures pose it at a time, Cycles draws it from a
camera given as twig's ``--camera EX,EY,EZ@TX,TY,TZ`` (metres, Y up, 40 degrees high), and
the bone heads (the joints, back in Y-up metres) go to a JSON file to compare with the
nodes. Needs Blender as a Python module - ``pip install bpy`` into a separate folder, with
the numpy it asks for (bpy 5.0: numpy<2):

    pip install --target /tmp/bpyenv bpy "numpy<2" zstandard requests
    twig export schoolyard --seconds 6 -o yard.glb
    twig render schoolyard --seconds 6 -o ours.png --camera 3.5,2.0,-1.5@0.2,0.8,2.0 --size 960x540
    PYTHONPATH=/tmp/bpyenv python examples/glb_in_blender.py yard.glb 6.0 blender.png \\
        --camera 3.5,2.0,-1.5@0.2,0.8,2.0 --bones bones.json
"""

from __future__ import annotations

import argparse
import json
import math

import bpy  # Blender as a Python module (not a twig-ecs dependency)
from mathutils import Vector


def z_up(x: float, y: float, z: float) -> Vector:
    """A glTF / twig point (Y up) in Blender's axes (Z up), as Blender's glTF importer turns them."""
    return Vector((x, -z, y))


def main() -> None:
    """Import, pose at the time asked, save the bones, render."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("glb")
    parser.add_argument("time", type=float, help="seconds into the animation")
    parser.add_argument("png")
    parser.add_argument("--camera", default="3.5,2.0,-1.5@0.2,0.8,2.0", help="EX,EY,EZ@TX,TY,TZ (m, Y up)")
    parser.add_argument("--bones", help="write the bone heads (m, Y up) as JSON here")
    parser.add_argument("--size", default="960x540")
    parser.add_argument("--samples", type=int, default=16)
    args = parser.parse_args()

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.fps = 30  # the importer puts a key at t s on frame t * fps
    bpy.ops.import_scene.gltf(filepath=args.glb)
    start = min((action.frame_range[0] for action in bpy.data.actions), default=0.0)
    scene.frame_set(int(round(start + args.time * scene.render.fps)))

    if args.bones:
        heads = {}
        for ob in scene.objects:
            if ob.type == "ARMATURE":
                for bone in ob.pose.bones:
                    h = ob.matrix_world @ bone.head
                    heads[bone.name] = [h.x, h.z, -h.y]  # back to Y up
        with open(args.bones, "w") as f:
            json.dump(heads, f)

    eye, target = (tuple(map(float, part.split(","))) for part in args.camera.split("@"))
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    scene.collection.objects.link(camera)
    scene.camera = camera
    camera.location = z_up(*eye)
    camera.rotation_euler = (z_up(*target) - camera.location).to_track_quat("-Z", "Y").to_euler()
    camera.data.sensor_fit = "VERTICAL"
    camera.data.angle_y = math.radians(40.0)  # twig's camera
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    scene.collection.objects.link(sun)
    sun.rotation_euler = (math.radians(40.0), 0.0, math.radians(30.0))
    sun.data.energy = 3.0
    scene.world = bpy.data.worlds.new("sky")
    scene.world.color = (0.8, 0.82, 0.85)
    bpy.ops.mesh.primitive_plane_add(size=40.0)  # the ground (twig's is drawn, not exported)
    width, height = map(int, args.size.split("x"))
    scene.render.engine = "CYCLES"  # draws on the CPU: no display needed
    scene.cycles.device = "CPU"
    scene.cycles.samples = args.samples
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.filepath = args.png
    bpy.ops.render.render(write_still=True)


if __name__ == "__main__":
    main()
