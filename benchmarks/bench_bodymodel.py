"""Body-model benchmarks: forward kinematics, projection and the trackers' sample points for
N = 100, 400, 1000 particles at 320x240 (the robot's wide eye camera), and what they cost
against each tracker's frame budget (issues 13 and 14).

Run: ``python benchmarks/bench_bodymodel.py [--repeats N] [--clock wall|cpu] [--json PATH]``.
Prints median and interquartile range over repeats (ms per call for all N particles) and writes
JSON. ``--clock cpu`` times the process's CPU time (``time.process_time``), which on a shared
machine leaves out the time the process waits for a core. A numpy reference (1e6-element
multiply-add, ~1 ms on an idle core) is timed alongside: compare rows against it.

Configurations, as the trackers will call the library:

* ``kpf`` (Schmidt): 14 DOF, elliptic-cylinder torso, 8-vertex outlines; per particle and
  iteration: FK + project + 20 edge, 30 ridge points and 3 colour bands per limb.
* ``tbp`` (Menezes): 8 DOF (arms; torso pose fixed), 16-vertex outlines, 20 contour points per
  part with normals and hidden-part removal.
* ``gest`` (Menezes): one free hand ellipsoid per particle, 20 contour points.
"""

# ruff: noqa: I001  -- select_gl_backend() runs before mujoco is imported (headless GL)
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import time
from pathlib import Path

from humimic import select_gl_backend

select_gl_backend()  # before anything imports mujoco

import numpy as np
from rich.console import Console
from rich.table import Table

import _harness
from _harness import fmt, row
from humimic import bodymodel as bm
from humimic.sensors.camera_model import Intrinsics, fovy_from_hfov

SIZES = (100, 400, 1000)
#: ``wall`` (perf_counter) or ``cpu`` (process_time), from ``--clock``.
CLOCK = "wall"
#: Frame budgets (ms) of the trackers' speed goals and the evaluations per frame they imply.
BUDGETS = {  # name: (ms per frame, particles, model evaluations per particle and frame)
    "kpf (150, 2) >= 75 Hz": (1000 / 75, 150, 2),
    "kpf (1000, 3) >= 10 Hz": (100.0, 1000, 3),
    "tbp N = 400 >= 20 fps": (50.0, 400, 1),
    "gest N = 100 >= 250 fps": (4.0, 100, 1),
}


def per_call(fn, repeats: int, inner: int) -> list[float]:
    """:func:`_harness.per_call` with the clock chosen by ``--clock``."""
    if CLOCK == "wall":
        return _harness.per_call(fn, repeats, inner)
    fn()
    out = []
    for _ in range(repeats):
        t0 = time.process_time()
        for _ in range(inner):
            fn()
        out.append((time.process_time() - t0) / inner)
    return out


def camera() -> tuple[Intrinsics, np.ndarray]:
    """The wide eye camera (100 deg) at 320x240, 1.3 m in front of the person's chest, level:
    ``T_cam_ref`` for a reference frame at the person's feet, x towards the camera, z up."""
    intr = Intrinsics.from_fovy(fovy_from_hfov(math.radians(100), 320, 240), 320, 240)
    R_cam_ref = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [-1.0, 0.0, 0.0]])
    T = np.eye(4)
    T[:3, :3] = R_cam_ref
    T[:3, 3] = -R_cam_ref @ np.array([1.3, 0.0, 1.45])
    return intr, T


def particles(body: bm.BodyModel, n: int, rng: np.random.Generator) -> np.ndarray:
    """Random free states around a person standing at the origin (arms anywhere in range)."""
    lo, hi = body.free_limits.lower, body.free_limits.upper
    q = rng.uniform(np.maximum(lo, -1.0), np.minimum(hi, 1.0), (n, len(body.free)))
    for i, name in enumerate(body.free):
        if name == "torso_z":
            q[:, i] = 1.03 + rng.normal(0, 0.02, n)
        elif name in ("torso_x", "torso_y", "torso_yaw", "torso_pitch", "torso_roll"):
            q[:, i] = rng.normal(0, 0.03, n)
        elif name.endswith(("SFE", "SAA", "HR", "EB")):
            q[:, i] = rng.uniform(max(lo[i], -0.5), min(hi[i], 2.0), n)
    return q


def bench(repeats: int) -> list:
    rng = np.random.default_rng(0)
    intr, T = camera()
    kpf = bm.avatar_body(torso="cylinder")
    tbp = bm.avatar_body().with_free(bm.ARM_DOFS["R"] + bm.ARM_DOFS["L"])
    torso6 = np.array([0.0, 0.0, 1.03, 0.0, 0.0, 0.0])
    a = rng.random(1_000_000)
    rows = [row("reference", "numpy multiply-add, 1e6 float64", per_call(
        lambda: a * a + a, repeats, 20), "ms", 1e3)]
    for n in SIZES:
        inner = max(1, 400 // n)
        q14, q8 = particles(kpf, n, rng), particles(tbp, n, rng)
        pose14, pose8 = kpf.forward(q14), tbp.forward(q8, fixed=torso6)
        v_kpf = bm.project(kpf, pose14, intr, T, n_vertices=8)
        v_tbp = bm.project(tbp, pose8, intr, T, n_vertices=16)

        def kpf_all(q=q14):
            view = bm.project(kpf, kpf.forward(q), intr, T, n_vertices=8)
            bm.limb_edges(view, 20), bm.limb_ridges(view, 30), bm.limb_bands(view, 3, 0.2)

        def tbp_all(q=q8):
            view = bm.project(tbp, tbp.forward(q, fixed=torso6), intr, T, n_vertices=16)
            bm.contour_points(view, 20, occlusion=True)

        hands = np.column_stack([rng.normal([0.35, -0.2, 1.2], 0.05, (n, 3)),
                                 rng.uniform(-0.5, 0.5, (n, 3)),
                                 np.broadcast_to([0.045, 0.022, 0.08], (n, 3))])

        def gest_all(s=hands):
            R, c, axes = bm.hand_ellipsoids(s)
            R, c = bm.to_camera(T, R, c)
            out, _, _ = bm.project_ellipsoids(R[:, None], c[:, None], axes[:, None], intr, 16)
            bm.resample(out, 20)

        g = f"N={n}"
        rows += [
            row(g, "FK 14 DOF", per_call(lambda q=q14: kpf.forward(q), repeats, inner), "ms",
                1e3),
            row(g, "kpf: project (8 parts, 8 vertices)", per_call(
                lambda p=pose14: bm.project(kpf, p, intr, T, n_vertices=8), repeats, inner),
                "ms", 1e3),
            row(g, "kpf: edges 20 + ridges 30 + bands 3", per_call(
                lambda v=v_kpf: (bm.limb_edges(v, 20), bm.limb_ridges(v, 30),
                                 bm.limb_bands(v, 3, 0.2)), repeats, inner), "ms", 1e3),
            row(g, "kpf: FK + project + features", per_call(kpf_all, repeats, inner), "ms", 1e3),
            row(g, "tbp: project (9 parts, 16 vertices)", per_call(
                lambda p=pose8: bm.project(tbp, p, intr, T, n_vertices=16), repeats, inner),
                "ms", 1e3),
            row(g, "tbp: 20 contour points/part, no occlusion", per_call(
                lambda v=v_tbp: bm.contour_points(v, 20, occlusion=False), repeats, inner),
                "ms", 1e3),
            row(g, "tbp: 20 contour points/part, hidden-part removal", per_call(
                lambda v=v_tbp: bm.contour_points(v, 20, occlusion=True), repeats, inner),
                "ms", 1e3),
            row(g, "tbp: FK + project + contour points", per_call(tbp_all, repeats, inner),
                "ms", 1e3),
            row(g, "gest: hand ellipsoid + 20 contour points", per_call(
                gest_all, repeats, inner), "ms", 1e3),
        ]
    return rows


def budget_rows(rows) -> list[tuple[str, float, float]]:
    """(goal, model ms per frame, share of the frame budget) by interpolating the rows."""
    by = {(r.group, r.name): r.median for r in rows}

    def at(name: str, n: int) -> float:
        xs = np.array(SIZES, float)
        return float(np.interp(n, xs, [by[(f"N={s}", name)] for s in SIZES]))

    out = []
    for goal, (ms, n, evals) in BUDGETS.items():
        name = {"kpf": "kpf: FK + project + features", "tbp": "tbp: FK + project + contour "
                "points", "gest": "gest: hand ellipsoid + 20 contour points"}[goal.split()[0]]
        cost = at(name, n) * evals
        out.append((goal, cost, cost / ms))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--clock", choices=("wall", "cpu"), default="wall")
    ap.add_argument("--json", type=Path, default=Path("benchmarks/results/bodymodel.json"))
    args = ap.parse_args()
    global CLOCK
    CLOCK = args.clock
    load0 = os.getloadavg()
    rows = bench(args.repeats)
    load1 = os.getloadavg()
    table = Table(title=f"humimic body model ({platform.machine()}, {os.cpu_count()} cores, "
                        f"load {load0[0]:.1f} -> {load1[0]:.1f}, {CLOCK} clock)")
    for col in ("group", "benchmark", "median", "IQR", "unit"):
        table.add_column(col)
    for r in rows:
        table.add_row(r.group, r.name, fmt(r.median), f"{fmt(r.q1)}-{fmt(r.q3)}", r.unit)
    console = Console()
    console.print(table)
    budget = Table(title="model cost per frame against the trackers' speed goals")
    for col in ("goal", "model ms / frame", "share of the frame"):
        budget.add_column(col)
    shares = budget_rows(rows)
    for goal, cost, share in shares:
        budget.add_row(goal, f"{cost:.2f}", f"{100 * share:.0f} %")
    console.print(budget)
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps({
        "machine": platform.platform(), "load": [load0, load1], "clock": CLOCK,
        "rows": [r.as_dict() for r in rows],
        "budget": [{"goal": g, "model_ms_per_frame": c, "share": s} for g, c, s in shares],
    }, indent=2))


if __name__ == "__main__":
    main()
