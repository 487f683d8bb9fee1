"""Measure the faces: how often the detector finds them, how well the recogniser names them.

    python -m humimic.perception.faces detection [--per-bin 3] [--seed 0]
    python -m humimic.perception.faces recognition [--known 10] [--out DIR]

``detection`` renders every identity through the wide and the foveal eye camera (320 x 240)
in frontal views at face sizes 24-90 px and prints the detection rate per camera and size.
``recognition`` trains the eigenface recogniser on the first ``--known`` identities (or takes
it from the cache), renders a held-out set of every identity (the rest are strangers) with
another seed, prints the recognition rates at the automatic threshold and at 2 % false
acceptance, and writes the ROC to ``DIR/faces_roc.png``.
"""

from __future__ import annotations

from humimic import select_gl_backend

select_gl_backend()  # an entry point: MuJoCo's OpenGL backend, before anything imports mujoco

import argparse
import sys
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table
from tqdm import tqdm

from humimic.perception.faces import training
from humimic.perception.faces.rates import detection_rates
from humimic.world.faces import IDENTITY_NAMES


def _bar(total: int, what: str):
    return tqdm(total=total, desc=what, disable=not sys.stderr.isatty(), leave=False)


def detection(args) -> int:
    names = list(IDENTITY_NAMES)
    with _bar(len(names), "rendering") as bar:
        tab = detection_rates(names, per_bin=args.per_bin, seed=args.seed, progress=bar.update)
    t = Table(title="Haar frontal-face detection on rendered faces (frontal views)")
    t.add_column("camera")
    for b in tab.bins:
        t.add_column(f">= {b:.0f} px", justify="right")
    for cam in ("wide", "foveal"):
        t.add_row(cam, *[f"{tab.rate(cam, b):.2f} ({tab.trials.get((cam, b), 0)})"
                         if tab.trials.get((cam, b)) else "-" for b in range(len(tab.bins))])
    con = Console()
    con.print(t)
    con.print(f"all frames with a face of 24 px or more: {tab.overall():.3f}; "
              f"false detections: {tab.false_detections}")
    worst = sorted(tab.by_identity.items(), key=lambda kv: kv[1][0] / kv[1][1])[:3]
    con.print("lowest per identity: " + ", ".join(f"{k} {h}/{n}" for k, (h, n) in worst))
    return 0


def recognition(args) -> int:
    names = list(IDENTITY_NAMES)
    known, strangers = names[:args.known], names[args.known:]
    con = Console()
    with _bar(len(known), "training renders") as bar:
        model = training.trained_model(known, progress=bar.update)
    spec = training.RenderSpec(per_identity=args.per_identity, seed=args.seed)
    with _bar(len(names), "held-out renders") as bar:
        test = training.render_sets(names, spec, progress=bar.update)
    t = Table(title=f"eigenface recognition, {len(known)} known + {len(strangers)} strangers, "
                    f"held-out renders (seed {spec.seed}, yaw <= {spec.yaw_deg:g} deg)")
    for col in ("views", "faces", "closed-set", "correct @auto tau", "false acc. @auto",
                "correct @FAR<=2%", "tau @FAR<=2%"):
        t.add_column(col, justify="right")
    rocs = {}
    for label, limit in (("all", 1e9), ("|yaw| <= 12 deg", 12.0)):
        sel = {k: v.crops[np.abs(v.yaw_deg) <= limit] for k, v in test.items()}
        k_sets = {k: sel[k] for k in known}
        roc = training.roc(model, k_sets, {k: sel[k] for k in strangers})
        rocs[label] = roc
        X = np.concatenate(list(k_sets.values()))
        true = np.concatenate([np.full(len(v), i) for i, v in enumerate(k_sets.values())])
        label_auto, _ = model.classify(X)
        s_auto, _ = model.classify(np.concatenate([sel[k] for k in strangers]))
        closed = np.mean(np.argmin(model.distances(X), axis=1) == true)
        c2, tau2 = roc.at_far(0.02)
        t.add_row(label, str(len(X) + sum(len(sel[k]) for k in strangers)), f"{closed:.3f}",
                  f"{np.mean(label_auto == true):.3f}", f"{np.mean(s_auto >= 0):.3f}",
                  f"{c2:.3f}", f"{tau2:.1f}")
    con.print(t)
    con.print(f"automatic tau = {model.tau:.1f}, sigma = {model.sigma:.1f}; eigenvectors per "
              f"class {[len(b) for b in model.bases]}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    _plot(rocs, model.tau, out / "faces_roc.png")
    con.print(f"wrote {out / 'faces_roc.png'}")
    return 0


def _plot(rocs: dict, tau: float, path: Path) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(5, 4))  # its own Agg canvas: matplotlib's backend is left alone
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    for label, r in rocs.items():
        ax.plot(r.false_accept, r.correct, label=label)
        i = int(np.argmin(np.abs(r.tau - tau)))
        ax.plot(r.false_accept[i], r.correct[i], "o", color="k")
    ax.axvline(0.02, color="grey", ls=":", lw=1)
    ax.set_xlim(0, 0.2)
    ax.set_ylim(0.5, 1.0)
    ax.set_xlabel("strangers accepted (false acceptance)")
    ax.set_ylabel("known faces accepted with the right name")
    ax.set_title("eigenface recognition on rendered faces (dot: automatic tau)", fontsize=9)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m humimic.perception.faces",
                                 description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="what", required=True)
    d = sub.add_parser("detection", help="detection rate vs face size")
    d.add_argument("--per-bin", type=int, default=3, help="renders per identity, camera, size")
    d.add_argument("--seed", type=int, default=0)
    r = sub.add_parser("recognition", help="ROC of the eigenface recogniser")
    r.add_argument("--known", type=int, default=10, help="identities enrolled (the first K)")
    r.add_argument("--per-identity", type=int, default=50, help="held-out crops per identity")
    r.add_argument("--seed", type=int, default=1, help="seed of the held-out renders")
    r.add_argument("--out", default=".", help="directory for faces_roc.png")
    args = ap.parse_args(argv)
    if args.what == "recognition" and not 1 <= args.known < len(IDENTITY_NAMES):
        ap.error(f"--known must be 1..{len(IDENTITY_NAMES) - 1}")
    return detection(args) if args.what == "detection" else recognition(args)


if __name__ == "__main__":
    sys.exit(main())
