"""Cue ablation of a tracker (Menezes' claim that fused cues beat any single one): a
scenario run with each cue alone, the pairs the tracker knows and all cues fused, over a few
seeds; prints a table of loss rate, identity switches, error and speed.

    python -m humimic.perception.trackers.ablation [--scenario FILE] [--tracker NAME]
        [--seeds 0 1 2]

Defaults: the hand tracker on Fig. 5 (``hand2d``: shape, colour, shape + motion, shape +
motion + skin (the default), all); for the ICU tracker (``icu``: shape, colour, both) e.g.
``--scenario scenarios/menezes_fig10_crossing.yaml --tracker icu``.
"""

from __future__ import annotations

from humimic import select_gl_backend

select_gl_backend()  # an entry point: MuJoCo's OpenGL backend, before anything imports mujoco

import argparse
import sys
from pathlib import Path

import numpy as np

from humimic.errors import InputError, report_error
from humimic.paths import SCENARIOS_DIR

CUE_SETS = {
    "hand2d": {"shape": ["shape"], "colour": ["colour"], "shape+motion": ["shape", "motion"],
               "shape+motion+skin": ["shape", "motion", "skin"],
               "all fused": ["shape", "motion", "colour", "skin"]},
    "icu": {"shape": ["shape"], "colour": ["colour"], "all fused": ["shape", "colour"]},
}
KEYS = ("lost_fraction", "identity_switches", "center_median_px", "center_rmse_px",
        "frames_per_s")


def run(scenario_file: Path, seeds: list[int], tracker: str = "hand",
        duration: float | None = None, extra: list[str] | None = None) -> dict[str, dict]:
    """Mean of each score over the seeds per cue set."""
    import tempfile

    from humimic.run import run_one
    from humimic.scenario import load_scenario

    kind = load_scenario(scenario_file).trackers[tracker].kind
    out = {}
    for label, cues in CUE_SETS[kind].items():
        rows = []
        for seed in seeds:
            sets = ["output.plots=false", f"seed={seed}",
                    f"trackers.{tracker}.cues=[{', '.join(cues)}]"] + list(extra or [])
            sc = load_scenario(scenario_file, sets, duration=duration)
            with tempfile.TemporaryDirectory() as tmp:
                m = run_one(sc, tmp, rerun="off", progress=False)["trackers"][tracker]
            rows.append([np.nan if m[k] is None else m[k] for k in KEYS])
        out[label] = dict(zip(KEYS, np.nanmean(np.array(rows, float), axis=0), strict=True))
    return out


def table(results: dict[str, dict]) -> str:
    lines = ["| cues | lost fraction | identity switches | centre error median (px) | "
             "RMSE (px) | frames/s |", "|---|---|---|---|---|---|"]
    for label, r in results.items():
        lines.append(f"| {label} | {r['lost_fraction']:.3f} | {r['identity_switches']:.1f} | "
                     f"{r['center_median_px']:.1f} | {r['center_rmse_px']:.1f} | "
                     f"{r['frames_per_s']:.0f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m humimic.perception.trackers.ablation",
                                description=__doc__.split("\n")[0])
    p.add_argument("--scenario", type=Path, default=SCENARIOS_DIR / "menezes_fig5_hand.yaml")
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    p.add_argument("--tracker", default="hand")
    p.add_argument("--duration", type=float, default=None)
    p.add_argument("--set", dest="overrides", action="append", default=[])
    args = p.parse_args(argv)
    try:
        results = run(args.scenario, args.seeds, args.tracker, args.duration, args.overrides)
    except InputError as err:
        return report_error(err)
    print(table(results))
    return 0


if __name__ == "__main__":
    sys.exit(main())
