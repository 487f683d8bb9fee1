"""Why the robot's head nods while it mimics: the trunk, neck and eye joints' traces.

Runs a scenario (``humimic.run`` overrides) and, from the mimic stage's record, reports per
trunk / neck / eye joint the RMS and peak of the IK's reference motion (``q_ik`` from its start
value) and of the servo's tracking error (``q_robot - q_ik``), the eyes' base rotation
(``mimicry.head_still``), and the correlation of each joint's tracking error with the driven
arm's joint accelerations (the reaction the trunk and neck servos must resist).

    PYTHONPATH=src python benchmarks/nod_trace.py scenarios/mimic_tracked_wave.yaml \
        --seed 42 --set human.distance=2.2 --out runs/nod --npz runs/nod/trace.npz
"""

from __future__ import annotations

from humimic import select_gl_backend

select_gl_backend()  # an entry point: MuJoCo's OpenGL backend, before anything imports mujoco

import argparse  # noqa: E402
import json  # noqa: E402

import numpy as np  # noqa: E402

from humimic.control.stage import MimicStage  # noqa: E402
from humimic.run import run_one  # noqa: E402
from humimic.scenario import load_scenario  # noqa: E402
from humimic.world.names import ROBOT_JOINTS  # noqa: E402

WATCH = ("B_TR", "B_TAA", "B_TFE", "B_HR", "B_HN", "B_HT", "L_EP", "L_ET", "R_EP", "R_ET")
ARM = ("R_SFE", "R_SAA", "R_HR", "R_EB")


def trace(rec) -> dict[str, np.ndarray]:
    n = rec.n
    return {k: np.asarray(getattr(rec, k)[:n]) for k in
            ("t", "q_ik", "qdot_ik", "ctrl", "q_robot", "p_head", "R_head", "cam_mat")}


def summarise(tr: dict[str, np.ndarray], dt: float) -> dict:
    q_ik, q = tr["q_ik"], tr["q_robot"]
    # q_robot[k] is the state at t[k]; q_ik[k] the reference for the middle of [t, t + dt]:
    # compare the state with the previous tick's reference (half a tick apart, not 1.5)
    err = q[1:] - q_ik[:-1]
    ref = q_ik - q_ik[0]
    arm = [ROBOT_JOINTS.index(j) for j in ARM]
    acc = np.gradient(np.gradient(q_ik[:, arm], dt, axis=0), dt, axis=0)[:-1]
    acc_norm = np.linalg.norm(acc, axis=1)
    out = {}
    for name in WATCH:
        j = ROBOT_JOINTS.index(name)
        e = err[:, j]
        r = [float(np.corrcoef(e, acc[:, a])[0, 1]) if np.std(e) > 0 else 0.0
             for a in range(len(arm))]
        out[name] = {"ref_rms_mrad": 1e3 * float(np.sqrt(np.mean(ref[:, j] ** 2))),
                     "ref_peak_mrad": 1e3 * float(np.abs(ref[:, j]).max()),
                     "err_rms_mrad": 1e3 * float(np.sqrt(np.mean(e ** 2))),
                     "err_peak_mrad": 1e3 * float(np.abs(e).max()),
                     "r_err_arm_acc": dict(zip(ARM, np.round(r, 2).tolist(), strict=True))}
    R = tr["R_head"].reshape(-1, 3, 3)
    rel = np.einsum("ji,njk->nik", R[0], R)
    ang = np.arccos(np.clip((np.trace(rel, axis1=1, axis2=2) - 1) / 2, -1, 1))
    out["head_rotation_max_deg"] = float(np.degrees(ang.max()))
    out["arm_acc_rms"] = float(np.sqrt(np.mean(acc_norm ** 2)))
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("scenario")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--set", action="append", default=[], dest="overrides")
    ap.add_argument("--duration", type=float)
    ap.add_argument("--out", required=True)
    ap.add_argument("--npz")
    a = ap.parse_args()
    sc = load_scenario(a.scenario, a.overrides + ["output.plots=false"], seed=a.seed,
                       duration=a.duration)
    got = {}
    original = MimicStage.metrics

    def metrics(self):
        got["tr"], got["dt"] = trace(self.rec), self.dt
        return original(self)

    MimicStage.metrics = metrics
    m = run_one(sc, a.out, "off", progress=False)
    mm = m["mimicry"]
    site = next((k for k in mm if isinstance(mm[k], dict) and "rmse_mm" in mm[k]), None)
    sm = mm.get(site, {})
    s = summarise(got["tr"], got["dt"]) if "tr" in got else {}
    s["metrics"] = {"head_still": mm.get("head_still"), "rmse_mm": sm.get("rmse_mm"),
                    "lag_ms": sm.get("lag_ms"), "jerk": sm.get("jerk"),
                    "limit_hits": sm.get("joint_limit_hits_by_joint"),
                    "joints": mm.get("joints"),
                    "head_raw_filt_mm": [(m.get("tracking", {}).get("head") or {}).get(k)
                                         for k in ("raw_rmse_mm", "filtered_rmse_mm")]}
    if a.npz and "tr" in got:
        np.savez(a.npz, **got["tr"])
    print(json.dumps(s, indent=1))


if __name__ == "__main__":
    main()
