"""Where TBP's error comes from (issue 13): run a scenario once through the whole pipeline
(the shoulders from perception's measured head, as in the run), keep the tracker's frames, then
replay the tracker over them for several seeds and options, and print per DOF and per joint
the error split into the camera's depth and image plane, the shoulder placement error, and how
often the true pose scores better than the MMSE under the tracker's own likelihood (eq. 19)
-- with the measured torso and with the true one -- and by how much per cue (shape, skin,
each colour patch, stabiliser, collision; median over the frames, measured torso). True
better: a search failure; estimate better: a cue failure. The wrists' error is also taken
to the image: how far (px) the estimated wrist projects from the true one, and which share
of the 3-D wrist error (squared) falls in frames where it projects within ``--px`` pixels
of the truth -- the error along the line of sight, which one eye cannot see (the monocular
depth ambiguity).

Run: ``python benchmarks/diagnose_tbp.py scenarios/fig13_tbp_clutter.yaml --seeds 0,1,2
[--torso truth] [--set sigma_deg=1.5 --set edges=grey ...]``. CPU time per frame
(``time.process_time``, not wall clock) is printed beside the errors.
"""

# ruff: noqa: I001  -- humimic must be imported before mujoco (headless GL)
from __future__ import annotations

import argparse
import json
import time

from humimic import select_gl_backend

select_gl_backend()  # before anything imports mujoco

import numpy as np

from humimic.bodymodel.avatar import truth_state
from humimic.bodymodel.kinematics import DOF_NAMES
from humimic.maths.stats import rmse
from humimic.perception.trackers.tbp.likelihood import (
    full_log_likelihood,
    log_likelihood_terms,
    project_arms,
)
from humimic.perception.trackers.tbp.stage import JOINTS, TbpStage
from humimic.perception.trackers.tbp.tracker import ARM_NAMES, TbpTracker
from humimic.pipeline.build import build_stages
from humimic.pipeline.simulation import simulate
from humimic.rngs import Rngs
from humimic.scenario import load_scenario
from humimic.viz.rerun_log import RerunLog
from humimic.world.world import World


def record(path: str, overrides: list[str]):
    """The TBP stage's frames ``(t, frame, torso, truth state)`` of one pipeline run."""
    sc = load_scenario(path, overrides)
    rngs = Rngs(sc.seed)
    world = World(sc, rngs)
    try:
        with RerunLog(world.scene, "off", None, recording_id="diagnose_tbp") as rlog:
            stages = build_stages(sc, world, rngs, rlog)
            tbp = next(s for s in stages if isinstance(s, TbpStage))
            tbp.recorded = []
            simulate(world, stages, rlog, progress=False)
        frames = [(t, f, torso, truth_state(world, world.gt.index_of(t), "base"))
                  for t, f, torso in tbp.recorded]
        return tbp, frames
    finally:
        world.close()


def monocular_share(err_mm: np.ndarray, err_px: np.ndarray, px: float) -> float:
    """Share of the squared 3-D error ``err_mm (T,)`` in the frames whose projected error
    ``err_px (T,)`` is at most ``px``: the part of the error the image does not show."""
    total = float(np.sum(err_mm ** 2))
    return float(np.sum(err_mm[err_px <= px] ** 2)) / total if total > 0 else 0.0


def replay(tbp: TbpStage, frames, seed: int, update: dict, torso_truth: bool,
           px: float = 2.0) -> dict:
    cfg = tbp.cfg.model_copy(update=update)
    trk = TbpTracker(cfg, tbp.tracker.body, tbp.tracker.lut)
    body = trk.body.with_free(DOF_NAMES)
    rng = np.random.default_rng(seed)
    err, d_cam, lls, cpu = [], {j: [] for j in JOINTS}, [], 0.0
    wrist_px, wrist_mm, terms = [], [], []
    for _, frame, torso, truth in frames:
        torso = truth[:6] if torso_truth else torso
        c0 = time.process_time()
        mean, _, _ = trk.step(frame, torso, rng)
        cpu += time.process_time() - c0
        err.append(np.degrees((mean - truth[6:] + np.pi) % (2 * np.pi) - np.pi))
        p_true, p_est = body.forward(truth[None]), body.forward(np.r_[torso, mean][None])
        R = frame.camera.T_base_cam[:3, :3]
        for j in JOINTS:
            d_cam[j].append(R.T @ (p_est.joint(j) - p_true.joint(j))[0])
        for j in ("r_wrist", "l_wrist"):
            uv = frame.camera.project_base(np.vstack([p_est.joint(j), p_true.joint(j)]))
            wrist_px.append(np.linalg.norm(uv[0] - uv[1]))
            wrist_mm.append(1e3 * np.linalg.norm(p_est.joint(j) - p_true.joint(j)))
        qs = np.stack([truth[6:], mean])
        lls.append([full_log_likelihood(project_arms(trk.body, qs, t, trk.last_view,
                                                     cfg.n_points), trk.last_view, qs,
                                        trk.body, trk.weights, trk.refs) for t in
                    (torso, truth[:6])])
        per = log_likelihood_terms(project_arms(trk.body, qs, torso, trk.last_view,
                                                cfg.n_points), trk.last_view, qs, trk.body,
                                   trk.weights, trk.refs)
        terms.append({k: float(v[0] - v[1]) for k, v in per.items()})
    err, lls = np.array(err), np.array(lls)                       # lls (T, 2 torsos, 2 poses)
    out = {"cpu_ms_per_frame": 1e3 * cpu / len(frames),
           "joint_rmse_deg": float(np.sqrt(np.mean(err ** 2))),
           "per_dof_deg": dict(zip(ARM_NAMES, np.sqrt(np.mean(err ** 2, 0)).round(1).tolist(),
                                   strict=True))}
    for part in ("shoulder", "elbow", "wrist"):
        d = np.vstack([d_cam[f"{s}_{part}"] for s in "rl"])
        out[f"{part}_mm"] = {"3d": 1e3 * rmse(d), "depth": 1e3 * rmse(d[:, 2:]),
                             "image_plane": 1e3 * rmse(d[:, :2])}
    wrist_px, wrist_mm = np.array(wrist_px), np.array(wrist_mm)
    out["wrist_px_rmse"] = rmse(wrist_px[:, None])
    out[f"wrist_error_share_within_{px:g}px"] = monocular_share(wrist_mm, wrist_px, px)
    gap = lls[:, :, 0] - lls[:, :, 1]
    out["true_pose_better_fraction"] = {"measured_torso": float(np.mean(gap[:, 0] > 0)),
                                        "true_torso": float(np.mean(gap[:, 1] > 0))}
    out["true_minus_mmse_median_nats"] = {"measured_torso": float(np.median(gap[:, 0])),
                                          "true_torso": float(np.median(gap[:, 1]))}
    out["true_minus_mmse_median_nats_per_cue"] = {
        k: float(np.median([t[k] for t in terms if k in t])) for k in terms[-1]}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario")
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--torso", choices=["measured", "truth"], default="measured")
    ap.add_argument("--px", type=float, default=2.0,
                    help="projected wrist error (px) below which the 3-D error counts as "
                         "along the line of sight")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=JSON",
                    help="a tracker option for the replays, e.g. sigma_deg=1.5")
    ap.add_argument("-o", "--override", action="append", default=[],
                    help="a scenario override for the recorded run")
    args = ap.parse_args()
    update = {k: json.loads(v) for k, v in (kv.split("=", 1) for kv in args.set)}
    tbp, frames = record(args.scenario, args.override)
    frames = [f for f in frames if f[2] is not None]
    for seed in (int(s) for s in args.seeds.split(",")):
        res = replay(tbp, frames, seed, update, args.torso == "truth", args.px)
        print(f"seed {seed}:", json.dumps(res, default=lambda x: round(float(x), 2)))


if __name__ == "__main__":
    main()
