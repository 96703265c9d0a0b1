#!/usr/bin/env python3
"""What the viewport's denoiser costs the frames it runs in, in the editor itself.

Starts the editor on its default scene (1280x800, path traced at the default frame budget, the
denoiser on as it is by default) with `--samples N --state`, reads the state report every few
milliseconds and notes when each frame's report first appears, whether that frame traced, and
whether it made one of the denoiser's passes (it makes one a frame, a run of up to six after each
rise of the samples past a power of two). Each run is priced whole against the frames just
before and after it (frames grow cheaper as the view converges, and their intervals alternate
long and short as Bevy's main and render worlds overlap, so windows of an even count are taken):

    a pass's cost = (time over the run's frames - as many frames at the mean around it) / passes

and its share of its frame is cost / (the mean frame around it + cost). A run too close to
another to have plain frames around it is not counted. Run from the
repository under a display (a headless machine: `xvfb-run -a -s "-screen 0 1600x1000x24"`):

    python3 tools/scripts/denoise_frame_cost.py [--binary PATH] [--samples 64] [-- EDITOR ARGS]

The binary defaults to the dev build in $CARGO_TARGET_DIR (or target/).
"""
import argparse
import json
import os
import statistics
import sys
import time

from state_report import read_state, start_editor


def record(binary, samples, editor_args, timeout):
    """{frame: (time first seen, traced, denoise pass or None)} for every frame the report
    showed, until the view has its samples and the editor rests."""
    editor, state, tmp = start_editor(binary, "treelight-denoise-cost-",
                                      ["--samples", str(samples)] + editor_args)
    seen, start = {}, time.monotonic()
    try:
        while time.monotonic() - start < timeout:
            if editor.poll() is not None:
                sys.exit(f"the editor exited ({editor.returncode}); its log is in {tmp}")
            st = read_state(state)
            if st and st["frame"] not in seen:
                seen[st["frame"]] = (time.monotonic(), st["traced"] > 0, st["denoise_pass"])
                if st["samples"] >= samples and st["at_rest"]:
                    with open(os.path.join(tmp, "frames.json"), "w") as f:
                        json.dump({str(k): v for k, v in seen.items()}, f)
                    print(f"the frames seen are in {tmp}/frames.json (--frames reads them again)")
                    return seen
            time.sleep(0.004)
        sys.exit(f"the view did not reach {samples} samples in {timeout:.0f} s; log in {tmp}")
    finally:
        editor.kill()
        editor.wait()


def main():
    parser = argparse.ArgumentParser()
    target = os.environ.get("CARGO_TARGET_DIR", "target")
    parser.add_argument("--binary", default=os.path.join(target, "debug", "treelight"))
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--timeout", type=float, default=900.0)
    parser.add_argument("--frames", help="the frames.json of an earlier run, read instead of a run")
    parser.add_argument("editor_args", nargs="*")
    a = parser.parse_args()
    if a.frames:
        with open(a.frames) as f:
            seen = {int(k): (t, traced, tuple(p) if p else None)
                    for k, (t, traced, p) in json.load(f).items()}
    else:
        seen = record(a.binary, a.samples, a.editor_args, a.timeout)
    plain = [b[0] - a[0] for f, b in seen.items() for a in [seen.get(f - 1)]
             if a and b[1] and not b[2]]
    runs = sum(1 for e in seen.values() if e[2] and e[2][0] == 0)
    passes = sum(1 for e in seen.values() if e[2])
    print(f"frames seen: {len(seen)}; runs of the denoiser: {runs}, {passes} passes; frames that "
          f"traced without a pass: median {statistics.median(plain) * 1e3:.0f} ms")
    # Each run whole: the time from a frame before it to the frame after it, over an even count
    # of intervals (the long and short ones balance), less as many frames at the mean of the 8
    # frames before it and the 8 after it (the frames grow cheaper as the view converges, so the
    # whole run's median would price early runs high).
    print("run | passes | frames with it, ms | around it, ms | a pass's cost, ms | share of its frame")
    per_pass, shares = [], []
    for f0 in sorted(f for f, e in seen.items() if e[2] and e[2][0] == 0):
        n = seen[f0][2][1]
        end = f0 + n
        start = f0 - 1 if n % 2 == 1 else f0 - 2
        window = [seen.get(f) for f in range(start, end + 1)]
        before = [seen.get(f) for f in range(start - 8, start + 1)]
        after = [seen.get(f) for f in range(end + 1, end + 10)]
        if any(e is None or not e[1] for e in window + before + after) or \
                any(e[2] for e in before + after):
            continue
        spent = window[-1][0] - window[0][0]
        plain = (before[-1][0] - before[0][0] + after[-1][0] - after[0][0]) / 16
        cost = (spent - (end - start) * plain) / n
        per_pass.append(cost)
        shares.append(cost / (plain + cost))
        print(f"{f0:4} | {n:6} | {spent / (end - start) * 1e3:18.0f} | {plain * 1e3:13.0f} "
              f"| {cost * 1e3:17.0f} | {cost / (plain + cost):.2f}")
    if per_pass:
        print(f"median over {len(per_pass)} runs: a pass costs {statistics.median(per_pass) * 1e3:.0f}"
              f" ms, {statistics.median(shares):.2f} of its frame (target under 0.33)")
    alone = [b[0] - a[0] for f, b in seen.items() for a in [seen.get(f - 1)]
             if a and not b[1] and b[2]]
    if alone:
        print(f"frames with a pass after the limit (the trace stopped): {len(alone)}, "
              f"median {statistics.median(alone) * 1e3:.0f} ms")

if __name__ == "__main__":
    main()
