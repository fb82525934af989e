#!/usr/bin/env python3
"""What the corner fit gains and costs, from two sweeps of the same minutes: one with
`--fit-corners`, one without (docs/results/sweep.md, "Corners fitted to the surface").

    python3 benches/fit_sweep_table.py docs/results/sweep/fit/results-exact.json \\
        docs/results/sweep/fit/results-fitted.json

Per depth and method over the models: the median (and range) of the PSNR gain in dB and of the
build-time ratio fitted ÷ exact (each build time one sample, `build_ms`). Standard library only.
"""

import json
import statistics
import sys


def rows(path):
    with open(path, encoding="utf-8") as f:
        data = json.load(f)
    return data, {(r["model"], r["method"], r["depth"]): r for r in data["rows"]}


def main():
    (exact_data, exact), (fitted_data, fitted) = rows(sys.argv[1]), rows(sys.argv[2])
    assert not exact_data["settings"].get("fit_corners") and fitted_data["settings"]["fit_corners"]
    print("| depth | method | PSNR gain, dB: median (range) | build time fitted ÷ exact: median (range) |")
    print("|---:|---|---|---|")
    for depth in sorted({k[2] for k in exact}):
        for method in ("svo", "multi"):
            keys = [k for k in exact if k[2] == depth and k[1] == method and k in fitted]
            if not keys:
                continue
            gain = [fitted[k]["psnr"] - exact[k]["psnr"] for k in keys]
            time = [fitted[k]["build_ms"] / exact[k]["build_ms"] for k in keys]
            print(f"| {depth} | {method} | {statistics.median(gain):+.2f} ({min(gain):+.2f} to {max(gain):+.2f}) "
                  f"| {statistics.median(time):.2f}× ({min(time):.2f}–{max(time):.2f}) |")


if __name__ == "__main__":
    main()
