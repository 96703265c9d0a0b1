#!/usr/bin/env python3
"""The path tracer against Blender's Cycles on a closed Cornell box (a bench: needs Blender 3.4,
`apt-get install -y blender`, and a built `treelight`).

    xvfb-run -a python3 tools/scripts/cycles_cornell.py [--out DIR] [--spp 256] [--cycles-spp 1024]
        [--bounces 16] [--cycles-bounces N]

Writes the scene (tools/scripts/cornell_scene.py), renders it at 320 x 200 through its camera:
Cycles with the glTF importer's physical light units, each material a Diffuse BSDF of its base
colour (the file's are Lambertian; the Principled BSDF's diffuse is Burley's), a box pixel
filter a pixel wide (as treelight's), the same bounces
of every kind as treelight (16, `render`'s default, unless told), no clamp, no denoiser, the Standard view transform, into linear EXR; treelight twice (seeds 0 and 1, no
denoiser, no indirect clamp, no default sun) into EXR of exposed radiance. Then, in Blender's
Python (which reads EXR), compares the images in 8 x 5 blocks of 40 x 40 pixels: each block's
mean luminance, treelight's over Cycles' divided by the units' expected ratio, and the block's
noise from treelight's two seeds. Prints a Markdown table and the whole image's ratio.

The importer gives a point light a 25 cm radius; the script makes it 0, a point as glTF's is.
Units: a glTF point light of I cd imports as I 4π / 683 W, which Cycles renders as radiance in
W / (m² sr), 1/683 of a nit; treelight writes nits times the camera's exposure, 1 / (1.2 · 2^EV100)
at Bevy's default EV100 of 9.7. So equal radiance reads 683 / (1.2 · 2^9.7) ≈ 0.6843 as much in
treelight's EXR as in Cycles'.
"""

import argparse
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SIZE = (320, 200)
BLOCK = 40
EXPECTED = 683.0 / (1.2 * 2.0 ** 9.7)

BLENDER_RENDER = r"""
import bpy, sys
import numpy
# Blender 3.4's glTF importer uses numpy.bool, gone since numpy 1.24 (Debian 12's).
numpy.bool = bool
gltf, out, spp, bounces = sys.argv[-4], sys.argv[-3], int(sys.argv[-2]), int(sys.argv[-1])
for o in list(bpy.data.objects):
    bpy.data.objects.remove(o, do_unlink=True)
bpy.ops.import_scene.gltf(filepath=gltf)
scene = bpy.context.scene
scene.camera = next(o for o in scene.objects if o.type == 'CAMERA')
# The file's materials are Lambertian (no specular lobe). Cycles' Principled BSDF would add its
# Burley diffuse's retro-reflection at roughness 1, so each becomes a Diffuse BSDF (roughness 0:
# Lambert's) of its base colour.
for m in bpy.data.materials:
    if not m.node_tree or m.users == 0:
        continue
    nodes, links = m.node_tree.nodes, m.node_tree.links
    principled = next((n for n in nodes if n.type == 'BSDF_PRINCIPLED'), None)
    output = next((n for n in nodes if n.type == 'OUTPUT_MATERIAL'), None)
    if principled is None or output is None:
        continue
    colour = tuple(principled.inputs['Base Color'].default_value)
    diffuse = nodes.new('ShaderNodeBsdfDiffuse')
    diffuse.inputs['Color'].default_value = colour
    diffuse.inputs['Roughness'].default_value = 0.0
    links.new(diffuse.outputs['BSDF'], output.inputs['Surface'])
    print('material', m.name, 'Lambert', [round(c, 4) for c in colour[:3]],
          'specular was', round(principled.inputs['Specular'].default_value, 4))
for o in scene.objects:
    if o.type == 'LIGHT':
        # The importer leaves a new light's 25 cm radius; a glTF punctual light is a point.
        o.data.shadow_soft_size = 0.0
        print('light', o.name, o.data.type, 'power W', o.data.energy)
world = scene.world or bpy.data.worlds.new('World')
scene.world = world
world.use_nodes = True
world.node_tree.nodes['Background'].inputs['Strength'].default_value = 0.0
scene.render.engine = 'CYCLES'
scene.cycles.device = 'CPU'
scene.cycles.samples = spp
scene.cycles.use_adaptive_sampling = False
scene.cycles.use_denoising = False
scene.cycles.max_bounces = bounces
scene.cycles.diffuse_bounces = bounces
scene.cycles.glossy_bounces = bounces
scene.cycles.transmission_bounces = bounces
scene.cycles.transparent_max_bounces = bounces
scene.cycles.sample_clamp_direct = 0.0
scene.cycles.sample_clamp_indirect = 0.0
scene.cycles.caustics_reflective = True
scene.cycles.caustics_refractive = True
scene.cycles.blur_glossy = 0.0
# One sample's light to one pixel, as treelight's box filter gives it (Cycles' default spreads it
# over 1.5 pixels, moving light across the blocks' edges where an edge runs along them).
scene.cycles.pixel_filter_type = 'BOX'
scene.cycles.filter_width = 1.0
scene.render.resolution_x, scene.render.resolution_y = %d, %d
scene.render.resolution_percentage = 100
scene.view_settings.view_transform = 'Standard'
scene.view_settings.look = 'None'
scene.view_settings.exposure = 0.0
scene.view_settings.gamma = 1.0
scene.render.image_settings.file_format = 'OPEN_EXR'
scene.render.image_settings.color_depth = '32'
scene.render.filepath = out
bpy.ops.render.render(write_still=True)
""" % SIZE

BLENDER_COMPARE = r"""
import bpy, sys
paths = sys.argv[sys.argv.index('--') + 1:]
W, H, B, EXPECTED = %d, %d, %d, %r
def blocks(path):
    img = bpy.data.images.load(path)
    px = list(img.pixels)
    assert (img.size[0], img.size[1]) == (W, H), (path, tuple(img.size))
    out = []
    for by in range(H // B):
        row = []
        for bx in range(W // B):
            s = 0.0
            for y in range(by * B, (by + 1) * B):
                # Blender's rows run bottom up: block row 0 is the image's top.
                base = ((H - 1 - y) * W) * 4
                for x in range(bx * B, (bx + 1) * B):
                    i = base + 4 * x
                    s += 0.2126 * px[i] + 0.7152 * px[i + 1] + 0.0722 * px[i + 2]
            row.append(s / (B * B))
        out.append(row)
    return out
cycles, ours0, ours1 = (blocks(p) for p in paths)
print('| block row | ' + ' | '.join('col %%d' %% c for c in range(W // B)) + ' |')
print('|---|' + '---|' * (W // B))
worst = 0.0
total_c = total_o = 0.0
for r in range(H // B):
    cells = []
    for c in range(W // B):
        o = 0.5 * (ours0[r][c] + ours1[r][c])
        ratio = o / (cycles[r][c] * EXPECTED)
        noise = abs(ours0[r][c] - ours1[r][c]) / (2.0 * o) if o > 0 else 0.0
        worst = max(worst, abs(ratio - 1.0))
        total_c += cycles[r][c]
        total_o += o
        cells.append('%%.3f ±%%.3f' %% (ratio, noise))
    print('| %%d | ' %% r + ' | '.join(cells) + ' |')
print('whole image, treelight / (Cycles x %%.4f): %%.4f; the largest block difference %%.1f%%%%'
      %% (EXPECTED, total_o / (total_c * EXPECTED), 100.0 * worst))
""" % (SIZE[0], SIZE[1], BLOCK, EXPECTED)


def blender(script, *args):
    """Runs a Python script in Blender without its UI, returning its output."""
    # Blender's embedded Python takes its prefix from the `python3` first on PATH: a pyenv or
    # virtualenv one there hides the system's packages (numpy, which the glTF importer needs).
    env = dict(os.environ)
    env["PATH"] = os.pathsep.join(p for p in env.get("PATH", "").split(os.pathsep)
                                  if ".pyenv" not in p and "virtualenv" not in p)
    env.pop("VIRTUAL_ENV", None)
    done = subprocess.run(["blender", "--factory-startup", "-b", "--python-exit-code", "1",
                           "--python-expr", script, "--",
                           *args], capture_output=True, text=True, env=env)
    if done.returncode != 0:
        sys.exit(f"blender failed:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}")
    return done.stdout


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="/tmp/treelight-cycles-cornell")
    parser.add_argument("--spp", type=int, default=256)
    parser.add_argument("--cycles-spp", type=int, default=1024)
    parser.add_argument("--bounces", type=int, default=16,
                        help="bounces after the primary hit, both renderers (render's default)")
    parser.add_argument("--cycles-bounces", type=int,
                        help="Cycles' bounces when they differ from treelight's")
    target = os.environ.get("CARGO_TARGET_DIR", str(ROOT / "target"))
    parser.add_argument("--binary", default=str(Path(target) / "debug" / "treelight"))
    args = parser.parse_args()
    out = Path(args.out)
    subprocess.run([sys.executable, str(ROOT / "tools/scripts/cornell_scene.py"), str(out)],
                   check=True)
    gltf = out / "cornell.gltf"
    cycles_bounces = args.cycles_bounces or args.bounces
    cycles = out / f"cycles-{args.cycles_spp}-b{cycles_bounces}.exr"
    if not cycles.exists():
        log = blender(BLENDER_RENDER, str(gltf), str(cycles), str(args.cycles_spp),
                      str(cycles_bounces))
        print("\n".join(f"<!-- {l} -->" for l in log.splitlines()
                        if l.startswith(("material", "light"))))
    ours = []
    for seed in (0, 1):
        image = out / f"treelight-{args.spp}-b{args.bounces}-seed{seed}.exr"
        if not image.exists():
            subprocess.run([args.binary, "render", str(gltf), "--camera", "Camera", "--out",
                            str(image), "--width", str(SIZE[0]), "--height", str(SIZE[1]),
                            "--spp", str(args.spp), "--denoise", "off", "--seed", str(seed),
                            "--indirect-clamp", "0", "--default-sun", "off", "--bounces",
                            str(args.bounces)], check=True,
                           capture_output=True)
        ours.append(image)
    print("Each block: treelight's mean luminance over Cycles' times the units' ratio, ± half "
          "the relative difference of treelight's two seeds.\n")
    report = blender(BLENDER_COMPARE, str(cycles), *map(str, ours))
    print("\n".join(l for l in report.splitlines() if l.startswith(("|", "whole"))))


if __name__ == "__main__":
    main()
