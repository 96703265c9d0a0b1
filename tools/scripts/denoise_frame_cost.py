#!/usr/bin/env python3
"""What the viewport's denoiser costs the frames it runs in, in the editor itself.

Starts the editor on its default scene (1280x800, path traced at the default frame budget, the
denoiser on as it is by default) with `--samples N --state`, reads the state report every few
milliseconds and notes when each frame's report first appears, whether that frame traced, and
whether it made one of the denoiser's passes (it makes one a frame, a run of up to six after each
rise of the samples past a power of two). Frames that traced with a pass are priced against those
that traced without one:

    a pass's cost = (median frame with a pass) - (median frame without one)

and its share of its frame is cost / (median frame with a pass). Only frames amid frames of their
kind count: the report may be a frame ahead of the render world. Run from the
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


def neighbourly(entry):
    """What a frame's neighbours must share with it to count: whether they traced, and whether
    they made a pass."""
    return entry[1], entry[2] is not None


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
    # Frame intervals alternate long and short (the main and render worlds overlap), so a frame
    # is priced by the mean of its interval and the next one's; it counts where the frames from
    # the one before to the one after next were all seen and are of its kind.
    by_kind = {}
    for f, entry in seen.items():
        span = [seen.get(f + d) for d in (-2, -1, 1, 2)]
        if None in span or any(neighbourly(e) != neighbourly(entry) for e in span):
            continue
        pair = (seen[f + 1][0] - seen[f - 1][0]) / 2
        by_kind.setdefault(neighbourly(entry), []).append(pair)
    plain = by_kind.get((True, False), [])
    if len(plain) < 3:
        sys.exit(f"too few frames that traced without the denoiser ({len(plain)}) to compare with")
    frame = statistics.median(plain)
    runs = sum(1 for e in seen.values() if e[2] and e[2][0] == 0)
    passes = sum(1 for e in seen.values() if e[2])
    print(f"frames seen: {len(seen)}; runs of the denoiser: {runs}, {passes} passes")
    print(f"frames that traced without a pass: {len(plain)} counted, median {frame * 1e3:.0f} ms "
          f"(the temporal pass and the trace's budget included)")
    with_pass = by_kind.get((True, True), [])
    if len(with_pass) < 3:
        sys.exit(f"too few frames that traced with a pass ({len(with_pass)}) to price it")
    m = statistics.median(with_pass)
    cost = m - frame
    print(f"frames that traced with a pass: {len(with_pass)} counted, median {m * 1e3:.0f} ms; "
          f"the pass costs {cost * 1e3:.0f} ms, {cost / m:.2f} of its frame (target under 0.33)")
    # Each run whole: the time from a frame before it to the frame after it, over an even count
    # of intervals (the long and short ones balance), less as many frames at the median.
    print("run | passes | frames, ms | its cost, ms | a pass's | share of its frame")
    per_pass = []
    for f0 in sorted(f for f, e in seen.items() if e[2] and e[2][0] == 0):
        n = seen[f0][2][1]
        end = f0 + n
        start = f0 - 1 if n % 2 == 1 else f0 - 2
        window = [seen.get(f) for f in range(start, end + 1)]
        if None in window or not all(e[1] for e in window):
            continue
        spent = window[-1][0] - window[0][0]
        cost = spent - (end - start) * frame
        per_pass.append(cost / n)
        print(f"{f0:4} | {n:6} | {spent * 1e3:10.0f} | {cost * 1e3:12.0f} | {cost / n * 1e3:8.0f} "
              f"| {cost / n / (frame + cost / n):.2f}")
    if per_pass:
        c = statistics.median(per_pass)
        print(f"median over {len(per_pass)} runs: a pass costs {c * 1e3:.0f} ms, "
              f"{c / (frame + c):.2f} of its frame (target under 0.33)")
    alone = by_kind.get((False, True), [])
    if alone:
        print(f"frames with a pass after the limit (the trace stopped): {len(alone)} counted, "
              f"median {statistics.median(alone) * 1e3:.0f} ms")


if __name__ == "__main__":
    main()
