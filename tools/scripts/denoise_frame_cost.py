#!/usr/bin/env python3
"""What the viewport's denoiser costs the frames it runs in, in the editor itself.

Starts the editor on its default scene (1280x800, path traced at the default frame budget, the
denoiser on as it is by default) with `--samples N --state`, reads the state report every few
milliseconds and notes when each frame's report first appears and how many samples every pixel
had. The denoiser runs when the view's completed sweeps reach a power of two and at the sample
limit; the temporal pass runs in every frame that traces. So the frames around a rise of the
samples to a power of two (or to N) carry the denoiser, the others do not:

    denoiser's cost = (the frames around a rise) - (as many frames of the others, at their median)

and its share of the frame it runs in is cost / (median frame + cost). Run from the repository
under a display (a headless machine: `xvfb-run -a -s "-screen 0 1600x1000x24"`):

    python3 tools/scripts/denoise_frame_cost.py [--binary PATH] [--samples 64] [-- EDITOR ARGS]

The binary defaults to the dev build in $CARGO_TARGET_DIR (or target/).
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

from state_report import read_state

# Frames counted around a rise: the report of the frame that completed a sweep may come a frame
# before or after the render world's denoise (Bevy renders a frame while the next is simulated).
BEFORE, AFTER = 1, 2


def record(binary, samples, editor_args, timeout):
    """(time first seen, frame, samples) for every frame the report showed, until the view has
    its samples and the editor rests."""
    tmp = tempfile.mkdtemp(prefix="treelight-denoise-cost-")
    state = os.path.join(tmp, "state.ron")
    env = dict(os.environ, TREELIGHT_CONFIG_DIR=os.path.join(tmp, "config"),
               TREELIGHT_CACHE_DIR=os.path.join(tmp, "cache"))
    args = [binary, "--samples", str(samples), "--width", "1280", "--height", "800",
            "--state", state] + editor_args
    log = open(os.path.join(tmp, "editor.log"), "w")
    editor = subprocess.Popen(args, env=env, stdout=log, stderr=log)
    seen, start = [], time.monotonic()
    try:
        while time.monotonic() - start < timeout:
            if editor.poll() is not None:
                sys.exit(f"the editor exited ({editor.returncode}); its log: {log.name}")
            st = read_state(state)
            if st and (not seen or st["frame"] != seen[-1][1]):
                seen.append((time.monotonic(), st["frame"], st["samples"]))
                if st["samples"] >= samples and st["at_rest"]:
                    return seen
            time.sleep(0.004)
        sys.exit(f"the view did not reach {samples} samples in {timeout:.0f} s; log: {log.name}")
    finally:
        editor.kill()
        editor.wait()


def is_due(samples, limit):
    return samples > 0 and (samples & (samples - 1) == 0 or samples >= limit)


def main():
    parser = argparse.ArgumentParser()
    target = os.environ.get("CARGO_TARGET_DIR", "target")
    parser.add_argument("--binary", default=os.path.join(target, "debug", "treelight"))
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--timeout", type=float, default=900.0)
    parser.add_argument("editor_args", nargs="*")
    a = parser.parse_args()
    seen = record(a.binary, a.samples, a.editor_args, a.timeout)
    # Only consecutive frames give an interval; a missed frame (two between reads) is dropped.
    intervals = {f: t - t0 for (t0, f0, _), (t, f, _) in zip(seen, seen[1:]) if f == f0 + 1}
    traced = [i for i, (_, _, s) in enumerate(seen) if s > 0]
    if not traced:
        sys.exit("the view never traced a sample")
    rises = [seen[i][1] for i in traced
             if i > 0 and seen[i][2] != seen[i - 1][2] and is_due(seen[i][2], a.samples)]
    near = {f + d for f in rises for d in range(-BEFORE, AFTER + 1)}
    first = seen[traced[0]][1]
    plain = [dt for f, dt in intervals.items() if f > first + AFTER and f not in near]
    if len(plain) < 3:
        sys.exit(f"too few frames without the denoiser ({len(plain)}) to compare with")
    frame = statistics.median(plain)
    print(f"frames without the denoiser: {len(plain)}, median {frame * 1e3:.0f} ms "
          f"(the temporal pass and the trace's budget included)")
    print("samples | frames around the rise, ms | the denoiser's cost, ms | its share of its frame")
    costs = []
    for f in rises:
        window = [intervals.get(f + d) for d in range(-BEFORE, AFTER + 1)]
        if None in window:
            print(f"(frame {f}: an interval missed, not counted)")
            continue
        cost = sum(window) - len(window) * frame
        s = next(s for (_, g, s) in seen if g == f)
        # At the limit the trace stops: the frames after it are cheaper than the median.
        last = s >= a.samples
        if not last:
            costs.append(cost)
        print(f"{s:7} | {' '.join(f'{w * 1e3:.0f}' for w in window):>26} | {cost * 1e3:23.0f} "
              f"| {cost / (frame + cost):.2f}{' (the limit: the trace stops after it; not counted)' if last else ''}")
    if costs:
        m = statistics.median(costs)
        print(f"median cost {m * 1e3:.0f} ms over {len(costs)} runs: "
              f"{m / (frame + m):.2f} of the frame it runs in (target under 0.33)")


if __name__ == "__main__":
    main()
