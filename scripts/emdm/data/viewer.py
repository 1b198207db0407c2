"""Render a clip's joints to a PNG strip (stick figures at several frames) to eyeball retargeting.

    python -m emdm.data.viewer bandai_d1-walk_happy_001_00 --out walk.png [--dataset data/dataset]
    python -m emdm.data.viewer path/to/joints.npy --out x.png

Top row: side view (Z forward to the right, Y up) of evenly spaced frames, left limbs blue, right
limbs red, spine black, the floor grey. Bottom: the top view (X horizontal, Z vertical) of the
pelvis path with the first frame's facing arrow. The title shows the id and its first caption.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from emdm import paths
from emdm import skeleton as sk
from emdm.outdir import OutputRefused, check_writable

LEFT = {1, 4, 7, 10, 13, 16, 18, 20}
RIGHT = {2, 5, 8, 11, 14, 17, 19, 21}


def bone_color(j: int) -> str:
    return "tab:blue" if j in LEFT else ("tab:red" if j in RIGHT else "black")


def render_strip(joints: np.ndarray, out: Path, title: str = "", frames: int = 8, view: str = "side") -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    J = np.asarray(joints, dtype=np.float64)
    if J.ndim != 3 or J.shape[1:] != (sk.NUM_JOINTS, 3):
        raise ValueError(f"joints: expected (frames, 22, 3), got {J.shape}")
    idx = np.unique(np.linspace(0, J.shape[0] - 1, min(frames, J.shape[0])).round().astype(int))
    fig = plt.figure(figsize=(2.0 * len(idx), 5.2))
    gs = fig.add_gridspec(2, len(idx), height_ratios=[3, 1.4])
    h, v = (2, 1) if view == "side" else (0, 1)
    for k, f in enumerate(idx):
        ax = fig.add_subplot(gs[0, k])
        P = J[f]
        cx = P[0, h]
        for j in range(1, sk.NUM_JOINTS):
            p = sk.PARENTS[j]
            ax.plot([P[p, h] - cx, P[j, h] - cx], [P[p, v], P[j, v]], color=bone_color(j), lw=2)
        ax.scatter(P[:, h] - cx, P[:, v], s=6, color="k", zorder=3)
        ax.axhline(0.0, color="0.6", lw=1)
        ax.set_xlim(-1.0, 1.0)
        ax.set_ylim(-0.05, 2.0)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([0, 1, 2] if k == 0 else [])
        ax.set_title(f"t={f / sk.FPS:.2f}s", fontsize=8)
    ax = fig.add_subplot(gs[1, :])
    ax.plot(J[:, 0, 0], J[:, 0, 2], color="tab:green", lw=1.5)
    ax.scatter(J[idx, 0, 0], J[idx, 0, 2], s=10, color="tab:green")
    ax.arrow(J[0, 0, 0], J[0, 0, 2], 0.0, 0.3, width=0.01, color="k")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (left +)")
    ax.set_ylabel("z (forward +)")
    ax.invert_xaxis()  # seen from above and behind: the character's left is on the left
    fig.suptitle(title[:140], fontsize=9)
    fig.tight_layout()
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=80)
    plt.close(fig)
    return out


def main(argv: list[str] | None = None) -> int:
    """Render the strip; 0, or 2 with one line on stderr for a clip, --out or --frames it cannot use."""
    ap = argparse.ArgumentParser(prog="python -m emdm.data.viewer", description=__doc__.split("\n\n")[0])
    ap.add_argument("clip", help="a dataset id (new_joints/<id>.npy) or a .npy file of (frames, 22, 3) joints")
    ap.add_argument("--dataset", default=str(paths.DATASET_DIR))
    ap.add_argument("--out", required=True)
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--view", choices=["side", "front"], default="side")
    args = ap.parse_args(argv)
    if args.frames < 1:
        ap.error(f"--frames: expected ≥ 1, got {args.frames}")
    p = Path(args.clip)
    title = p.stem
    if p.suffix != ".npy":
        p = Path(args.dataset) / "new_joints" / f"{args.clip}.npy"
        t = Path(args.dataset) / "texts" / f"{args.clip}.txt"
        if t.is_file():
            title = f"{args.clip}: {(t.read_text().splitlines() or [''])[0].split('#')[0]}"
    try:
        if not p.is_file():
            raise ValueError(f"{p}: not found (give a dataset id or a .npy file)")
        out = check_writable(args.out)
        joints = _read_joints(p)
    except (ValueError, OutputRefused) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(render_strip(joints, out, title, args.frames, args.view))
    return 0


def _read_joints(p: Path) -> np.ndarray:
    """A (frames, 22, 3) joints array from ``p``, or ValueError naming the file."""
    try:
        J = np.load(p, allow_pickle=False)
    except (OSError, ValueError, EOFError) as e:
        raise ValueError(f"{p}: cannot read as a .npy array ({e})") from None
    if J.ndim != 3 or J.shape[1:] != (sk.NUM_JOINTS, 3) or len(J) == 0:
        raise ValueError(f"{p}: expected joints of shape (frames, {sk.NUM_JOINTS}, 3), got {J.shape}")
    return J


if __name__ == "__main__":
    raise SystemExit(main())
