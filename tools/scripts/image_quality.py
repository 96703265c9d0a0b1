#!/usr/bin/env python3
"""The image-quality bench: each scene rendered plain and denoised at a few sample counts, measured
against a reference of many samples with `treelight compare`.

    xvfb-run -a python3 tools/scripts/image_quality.py [--out DIR] [--scenes a,b] [--spp 4,16]

Scenes: `default` (the editor's default scene), `helmet` (FlightHelmet), `sibenik` (the OBJ), and
`quality` (tools/scripts/quality_scene.py: fine textures, a fence of thin bars, glass). Each at
320 x 200 by `treelight render`, plain (`--denoise off`) and denoised, against a reference of 1024
samples with another seed (`--seed 1`, never denoised), kept in DIR and reused by later runs (delete
it when the renderer's picture changes). Prints one Markdown table: relative MSE of linear colour
and of display values, the display error over the reference's detail, and SSIM; and writes each
image's residual picture beside it (red: brighter than the reference, blue: darker).

One setting for every scene: the bench passes no option to the denoiser.
"""

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "scenes"
SCENES = {
    "default": [],
    "helmet": [str(SHARED / "gltf" / "FlightHelmet" / "FlightHelmet.gltf")],
    "sibenik": [str(SHARED / "obj" / "sibenik.obj")],
    "quality": None,  # generated into the output folder
}


def binary():
    target = os.environ.get("CARGO_TARGET_DIR", str(ROOT / "target"))
    return str(Path(target) / "debug" / "treelight")


def render(exe, scene_args, out, spp, denoise, seed, size):
    """Renders one image (replacing an earlier one), returning the seconds it took."""
    started = time.monotonic()
    command = [exe, "render", *scene_args, "--out", str(out), "--width", str(size[0]),
               "--height", str(size[1]), "--spp", str(spp), "--denoise", denoise, "--seed",
               str(seed), "--overwrite"]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{' '.join(command)} failed:\n{done.stderr[-3000:]}")
    return time.monotonic() - started


def compare(exe, reference, images, residuals):
    """`treelight compare`'s figures for each image: (linear, display, detail, ssim)."""
    for image in images:
        residual = residuals / f"{image.stem}-residual.png"
        if residual.exists():
            residual.unlink()
    done = subprocess.run([exe, "compare", str(reference), *map(str, images), "--residuals",
                           str(residuals)], capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"treelight compare failed:\n{done.stderr}")
    rows = [line.split() for line in done.stdout.splitlines() if not line.startswith("#")]
    return [tuple(float(v) for v in row[:4]) for row in rows]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="/tmp/treelight-image-quality")
    parser.add_argument("--scenes", default=",".join(SCENES))
    parser.add_argument("--spp", default="4,16,64,256")
    parser.add_argument("--reference-spp", type=int, default=1024)
    parser.add_argument("--binary", default=binary())
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    size = (320, 200)
    print("| scene | spp | plain: linear / display / detail / SSIM | denoised: linear / display / "
          "detail / SSIM | denoised ÷ plain, display | seconds plain / denoised |")
    print("|---|---|---|---|---|---|")
    for name in args.scenes.split(","):
        scene_args = SCENES[name]
        if scene_args is None:
            folder = out / "quality-scene"
            subprocess.run([sys.executable, str(ROOT / "tools/scripts/quality_scene.py"),
                            str(folder)], check=True, capture_output=True)
            scene_args = [str(folder / "quality.gltf"), "--camera", "Camera"]
        reference = out / f"{name}-reference-{args.reference_spp}.png"
        if not reference.exists():
            seconds = render(args.binary, scene_args, reference, args.reference_spp, "off", 1,
                             size)
            print(f"<!-- {name}: reference in {seconds:.0f} s -->", flush=True)
        for spp in [int(s) for s in args.spp.split(",")]:
            images, seconds = [], []
            for denoise in ("off", "on"):
                image = out / f"{name}-{spp}-{denoise}.png"
                seconds.append(render(args.binary, scene_args, image, spp, denoise, 0, size))
                images.append(image)
            plain, denoised = compare(args.binary, reference, images, out)
            figures = [" / ".join(f"{v:.6f}" if k < 3 else f"{v:.4f}" for k, v in enumerate(f))
                       for f in (plain, denoised)]
            print(f"| {name} | {spp} | {figures[0]} | {figures[1]} | "
                  f"{denoised[1] / plain[1]:.2f} | {seconds[0]:.0f} / {seconds[1]:.0f} |",
                  flush=True)


if __name__ == "__main__":
    main()
