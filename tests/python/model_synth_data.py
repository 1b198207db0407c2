"""A tiny synthetic dataset in the HumanML3D layout, for the model/train/export/sample tests.

Clips are procedurally animated skeletons (reference T-pose, legs and arms swinging, walking forward
and turning), turned into real 263-d features by emdm.motion.features.extract_features, so the
geometric losses and the joint recovery see valid motion. Not a substitute for real data.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from emdm import skeleton as sk
from emdm.motion.features import extract_features

ACTIONS = ["walk", "wave", "turn"]


def rest_pose() -> np.ndarray:
    pos = np.zeros((sk.NUM_JOINTS, 3))
    for j, p in enumerate(sk.PARENTS):
        pos[j] = sk.REFERENCE_OFFSETS[j] + (pos[p] if p >= 0 else 0.0)
    return pos


def synth_clip(frames: int, action: int, rng: np.random.Generator) -> np.ndarray:
    """(frames, 22, 3) joints."""
    base = rest_pose()
    t = np.arange(frames) / sk.FPS
    freq = rng.uniform(0.8, 1.4)
    phase = np.sin(2 * np.pi * freq * t)
    j = np.repeat(base[None], frames, axis=0)
    speed = {0: 1.0, 1: 0.0, 2: 0.4}[action]
    turn = {0: 0.0, 1: 0.0, 2: 0.6}[action] * t
    for leg, sign in ((sk.JOINT_NAMES.index("l_knee"), 1), (sk.JOINT_NAMES.index("r_knee"), -1)):
        j[:, leg, 2] += 0.15 * sign * phase * (speed > 0)
    for foot, sign in ((7, 1), (10, 1), (8, -1), (11, -1)):
        j[:, foot, 2] += 0.25 * sign * phase * (speed > 0)
        j[:, foot, 1] += 0.05 * np.clip(sign * phase, 0, None) * (speed > 0)
    if action == 1:
        for arm in (19, 21):      # right elbow, wrist raise and wave
            j[:, arm, 1] += 0.3 + 0.2 * phase
    # heading turn about the pelvis, then translate forward along the heading
    c, s = np.cos(turn), np.sin(turn)
    rel = j - j[:, :1] * np.array([1, 0, 1])
    x, z = rel[..., 0].copy(), rel[..., 2].copy()
    rel[..., 0], rel[..., 2] = c[:, None] * x + s[:, None] * z, -s[:, None] * x + c[:, None] * z
    root = np.zeros((frames, 3))
    root[1:, 0] = np.cumsum(np.sin(turn[1:]) * speed / sk.FPS)
    root[1:, 2] = np.cumsum(np.cos(turn[1:]) * speed / sk.FPS)
    return (rel + root[:, None]).astype(np.float32)


def write_synthetic_dataset(root: Path, n_clips: int = 24, seed: int = 0, min_len: int = 41, max_len: int = 120) -> Path:
    root = Path(root)
    rng = np.random.default_rng(seed)
    for sub in ("new_joints", "new_joint_vecs", "texts"):
        (root / sub).mkdir(parents=True, exist_ok=True)
    ids, feats_all, meta = [], [], []
    words = {0: ["a person walks forward", "someone walks ahead"], 1: ["a person waves the right hand", "someone waves"],
             2: ["a person turns while walking", "someone walks in a curve"]}
    for i in range(n_clips):
        action = i % len(ACTIONS)
        frames = int(rng.integers(min_len, max_len + 1))
        joints = synth_clip(frames, action, rng)
        feats = extract_features(joints)
        cid = f"{i:06d}"
        np.save(root / "new_joints" / f"{cid}.npy", joints)
        np.save(root / "new_joint_vecs" / f"{cid}.npy", feats)
        lines = [f"{c}#a/DET person/NOUN#0.0#0.0" for c in words[action]]
        (root / "texts" / f"{cid}.txt").write_text("\n".join(lines) + "\n")
        ids.append(cid)
        feats_all.append(feats)
        meta.append({"id": cid, "source": "synthetic", "take": cid, "action": ACTIONS[action], "action_id": action,
                     "style": "", "fps": sk.FPS, "frames": frames, "mirrored": 0})
    allf = np.concatenate(feats_all)
    np.save(root / "Mean.npy", allf.mean(0).astype(np.float32))
    np.save(root / "Std.npy", allf.std(0).astype(np.float32))
    (root / "train.txt").write_text("\n".join(ids) + "\n")
    (root / "val.txt").write_text("\n".join(ids[:4]) + "\n")
    (root / "test.txt").write_text("\n".join(ids[:4]) + "\n")
    (root / "actions.json").write_text(json.dumps({"labels": ACTIONS}))
    with open(root / "metadata.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(meta[0]))
        w.writeheader()
        w.writerows(meta)
    return root


def fake_text_encoder(monkeypatch, dim: int = 16) -> None:
    """Replace emdm.text.encode_texts by a deterministic hash embedding (tests that must not depend on
    the text engineer's encoder files); returns L2-normalised (N, dim) float32."""
    import hashlib
    import sys
    import types

    def encode_texts(texts, encoder_id="all-MiniLM-L6-v2", batch_size=64):
        out = np.stack([np.frombuffer(hashlib.sha256(t.encode()).digest()[: dim], dtype=np.uint8).astype(np.float32)
                        for t in texts]) - 127.5
        return out / np.linalg.norm(out, axis=1, keepdims=True)

    mod = sys.modules.get("emdm.text")
    if mod is None:
        try:
            import emdm.text as mod  # noqa: F811
        except Exception:  # noqa: BLE001 - the real encoder package may not exist yet
            mod = types.ModuleType("emdm.text")
            monkeypatch.setitem(sys.modules, "emdm.text", mod)
    monkeypatch.setattr(mod, "encode_texts", encode_texts, raising=False)
