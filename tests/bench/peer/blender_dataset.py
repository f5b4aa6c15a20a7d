# Blender's side of tests/bench/blender_vs_ours.sh: FaceCap imported with Blender's own glTF importer,
# N samples at SIZE² each with seeded shape key values (4 of the 52 active, their sum at most 1, as
# `facespace batch --sample uniform --active 4 --sum-at-most-one`), each rendered with the depth (Z) and
# normal passes written beside the picture as one multilayer EXR, as BlenderProc makes a labelled sample.
# ENGINE: BLENDER_WORKBENCH, BLENDER_EEVEE or CYCLES (CPU, 1 sample a pixel, no denoising: the cheapest
# picture Cycles makes). Prints one JSON line: the engine, the samples and the seconds of the loop (the
# import and the first render, which compiles shaders, not counted).
# usage: blender -b --factory-startup -P blender_dataset.py -- RIG.glb OUT_DIR N SIZE ENGINE
import json
import random
import sys
import time

import bpy
import numpy

# Debian's Blender 3.4.1 glTF importer still says np.bool, which Debian's NumPy 1.24 no longer has.
numpy.bool = bool

rig, out, n, size, engine = sys.argv[sys.argv.index("--") + 1:][:5]
n, size = int(n), int(size)

bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=rig)
scene = bpy.context.scene
meshes = [o for o in scene.objects if o.type == "MESH"]
keyed = [o for o in meshes if o.data.shape_keys]
keys = [k for o in keyed for k in o.data.shape_keys.key_blocks[1:]]

# A camera framing the head from the front (glTF's +z is Blender's -y), as our renders do.
corners = [o.matrix_world @ v.co for o in meshes for v in o.data.vertices]
lo = [min(c[i] for c in corners) for i in range(3)]
hi = [max(c[i] for c in corners) for i in range(3)]
centre = [(a + b) / 2 for a, b in zip(lo, hi)]
height = hi[2] - lo[2]
cam_data = bpy.data.cameras.new("camera")
cam_data.lens_unit = "FOV"
cam_data.angle = 0.5
cam = bpy.data.objects.new("camera", cam_data)
scene.collection.objects.link(cam)
cam.location = (centre[0], centre[1] - 1.4 * height / 0.5, centre[2])
cam.rotation_euler = (1.5708, 0.0, 0.0)
scene.camera = cam
sun = bpy.data.lights.new("key", "SUN")
sun.energy = 2.0  # W/m², a studio's key light (made from Python, a sun starts at 10: a white face burnt out).
light = bpy.data.objects.new("key", sun)
light.rotation_euler = (0.9, 0.0, -0.5)
scene.collection.objects.link(light)

scene.render.engine = engine
scene.render.resolution_x = scene.render.resolution_y = size
scene.render.resolution_percentage = 100
scene.render.image_settings.file_format = "OPEN_EXR_MULTILAYER"
scene.render.image_settings.color_depth = "32"
scene.render.image_settings.exr_codec = "ZIP"
layer = scene.view_layers[0]
layer.use_pass_z = True
layer.use_pass_normal = True
if engine == "CYCLES":
    scene.cycles.device = "CPU"
    scene.cycles.samples = 1
    scene.cycles.use_denoising = False
    scene.cycles.use_adaptive_sampling = False

rng = random.Random(1)


def sample(i):
    for k in keys:
        k.value = 0.0
    chosen = rng.sample(keys, 4)
    w = [rng.random() for _ in chosen]
    total = sum(w)
    for k, v in zip(chosen, w):
        k.value = v / max(total, 1.0)
    scene.render.filepath = f"{out}/v{i:06d}"
    bpy.ops.render.render(write_still=True)


sample(0)  # Shaders compiled, caches warm: not counted.
start = time.perf_counter()
for i in range(1, n + 1):
    sample(i)
seconds = time.perf_counter() - start
print(json.dumps({"engine": engine, "samples": n, "size": size, "seconds": seconds, "per_sample_ms": 1000 * seconds / n}))
