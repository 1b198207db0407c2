"""Training-time reader of the HumanML3D folder layout (docs/ARCHITECTURE.md, "Dataset layout").

``load_split(root, "train")`` returns a :class:`MotionSet`: normalised 263-d feature clips (at most 196
frames, at least ``min_frames``), their captions and (when the folder has ``actions.json`` +
``metadata.csv``) their action ids. A real HumanML3D folder (no action files) loads for text and
unconditional training. Caption lines with a nonzero from/to become their own sub-clip, as HumanML3D does.

:class:`BucketBatcher` yields index batches of similar length (less padding → less compute) with an
exactly resumable, seeded, DDP-shardable order; with ``alpha`` ≠ 1 it draws clips by action with
P(action a) ∝ n_a^α (:func:`balanced_weights`). :class:`DeviceClips` holds the whole split as one padded tensor
on the training device and gathers batches there. :func:`collate` pads a batch and builds the frame mask.
"""

from __future__ import annotations

import csv
import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from emdm import manifest
from emdm import text as text_encoders      # .encode_texts looked up at each call: tests replace it

FPS = 20
MAX_FRAMES = 196
FEATURE_DIM = 263


class DatasetError(ValueError):
    """The dataset folder is missing a file or a file is malformed (the message names which)."""


@dataclass
class MotionSet:
    root: Path
    split: str
    names: list[str]                 # clip id (plus "#k" for caption sub-clips)
    motions: list[np.ndarray]        # (F, 263) float32, NORMALISED with mean/std
    captions: list[list[str]]        # at least one caption per clip ("" when the folder has no texts)
    actions: np.ndarray              # (N,) int64 action id, -1 when unknown
    mean: np.ndarray                 # (263,) float32
    std: np.ndarray                  # (263,) float32 (after the floor clamp)
    action_labels: list[str] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.motions)

    @property
    def lengths(self) -> np.ndarray:
        return np.array([len(m) for m in self.motions], dtype=np.int64)


def _read_npy(path: Path, what: str) -> np.ndarray:
    if not path.is_file():
        raise DatasetError(f"{path}: {what} not found")
    try:
        return np.load(path)
    except Exception as e:  # noqa: BLE001 - re-raised with the file name
        raise DatasetError(f"{path}: cannot read {what}: {e}") from e


def load_mean_std(root: Path | str, std_floor: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    root = Path(root)
    mean = _read_npy(root / "Mean.npy", "Mean.npy").astype(np.float32)
    std = _read_npy(root / "Std.npy", "Std.npy").astype(np.float32)
    for name, a in (("Mean.npy", mean), ("Std.npy", std)):
        if a.shape != (FEATURE_DIM,):
            raise DatasetError(f"{root / name}: expected shape ({FEATURE_DIM},), got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise DatasetError(f"{root / name}: contains NaN or infinite values")
    return mean, np.maximum(std, std_floor).astype(np.float32)


def parse_text_file(path: Path) -> list[tuple[str, float, float]]:
    """Lines "caption#tok/POS ...#from#to" → [(caption, from, to)]. Bad lines raise naming file:line."""
    out = []
    for lineno, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if not line.strip():
            continue
        parts = line.split("#")
        if len(parts) < 4:
            raise DatasetError(f"{path}:{lineno}: expected 'caption#tokens#from#to', got {line!r}")
        try:
            f_tag, to_tag = float(parts[-2] or 0.0), float(parts[-1] or 0.0)
        except ValueError as e:
            raise DatasetError(f"{path}:{lineno}: from/to must be numbers (seconds), got {parts[-2]!r}, {parts[-1]!r}") from e
        f_tag = 0.0 if np.isnan(f_tag) else f_tag
        to_tag = 0.0 if np.isnan(to_tag) else to_tag
        out.append((parts[0].strip(), f_tag, to_tag))
    return out


def read_actions(root: Path) -> tuple[list[str], dict[str, int]]:
    """(labels, id → action_id) from actions.json + metadata.csv; ([], {}) when the folder has neither."""
    aj, meta = root / "actions.json", root / "metadata.csv"
    if not aj.exists() and not meta.exists():
        return [], {}
    if not aj.exists() or not meta.exists():
        missing = aj if not aj.exists() else meta
        raise DatasetError(f"{missing}: not found (actions.json and metadata.csv come together)")
    try:
        labels = json.loads(aj.read_text())["labels"]
    except (json.JSONDecodeError, KeyError, TypeError) as e:
        raise DatasetError(f"{aj}: expected {{\"labels\": [...]}}: {e}") from e
    table: dict[str, int] = {}
    with open(meta, newline="") as f:
        reader = csv.DictReader(f)
        for col in ("id", "action_id"):
            if reader.fieldnames is None or col not in reader.fieldnames:
                raise DatasetError(f"{meta}:1: missing column {col!r} (header: {reader.fieldnames})")
        for lineno, row in enumerate(reader, 2):
            raw = (row.get("action_id") or "").strip()
            if raw in ("", "-1"):
                continue
            try:
                a = int(raw)
            except ValueError as e:
                raise DatasetError(f"{meta}:{lineno}: field 'action_id' must be an integer, got {raw!r}") from e
            if not 0 <= a < len(labels):
                raise DatasetError(f"{meta}:{lineno}: action_id {a} outside 0..{len(labels) - 1} of actions.json")
            table[row["id"]] = a
    return list(labels), table


def load_split(root: Path | str, split: str = "train", *, min_frames: int = 40, max_frames: int = MAX_FRAMES,
               limit: int | None = None, require_action: bool = False, std_floor: float = 1e-3) -> MotionSet:
    root = Path(root)
    split_file = root / f"{split}.txt"
    if not split_file.is_file():
        raise DatasetError(f"{split_file}: split file not found (is {root} a HumanML3D-layout dataset?)")
    ids = [line.strip() for line in split_file.read_text().splitlines() if line.strip()]
    mean, std = load_mean_std(root, std_floor)
    labels, action_of = read_actions(root)
    names, motions, captions, actions = [], [], [], []
    for cid in ids:
        if limit is not None and len(motions) >= limit:
            break
        path = root / "new_joint_vecs" / f"{cid}.npy"
        if not path.exists():
            continue                                  # HumanML3D split files list a few absent ids
        feats = _read_npy(path, "features")
        if feats.ndim != 2 or feats.shape[1] != FEATURE_DIM:
            raise DatasetError(f"{path}: expected shape (frames, {FEATURE_DIM}), got {feats.shape}")
        if not np.all(np.isfinite(feats)):
            raise DatasetError(f"{path}: contains NaN or infinite values")
        action = action_of.get(cid, -1)
        if require_action and action < 0:
            continue
        tpath = root / "texts" / f"{cid}.txt"
        lines = parse_text_file(tpath) if tpath.exists() else []
        whole = [c for c, a, b in lines if a == 0.0 and b == 0.0 and c]
        subs: dict[tuple[float, float], list[str]] = {}
        for c, a, b in lines:
            if (a, b) != (0.0, 0.0) and c:
                subs.setdefault((a, b), []).append(c)
        norm = ((feats.astype(np.float32) - mean) / std).astype(np.float32)
        if len(norm) >= min_frames and (whole or not lines):
            names.append(cid)
            motions.append(norm[:max_frames])
            captions.append(whole or [""])
            actions.append(action)
        for k, ((a, b), caps) in enumerate(sorted(subs.items())):
            seg = norm[int(a * FPS): int(b * FPS)]
            if len(seg) >= min_frames:
                names.append(f"{cid}#{k}")
                motions.append(seg[:max_frames])
                captions.append(caps)
                actions.append(action)
    if not motions:
        raise DatasetError(f"{split_file}: no usable clips (≥ {min_frames} frames{', with an action' if require_action else ''})")
    return MotionSet(root=root, split=split, names=names, motions=motions, captions=captions,
                     actions=np.array(actions, dtype=np.int64), mean=mean, std=std, action_labels=labels)


def caption_table(ms: MotionSet) -> tuple[list[str], list[np.ndarray]]:
    """Unique captions and, per clip, the indices of its captions into that list."""
    uniq: dict[str, int] = {}
    per_clip = []
    for caps in ms.captions:
        per_clip.append(np.array([uniq.setdefault(c, len(uniq)) for c in caps], dtype=np.int64))
    return list(uniq), per_clip


def _encoder_file_sha256(encoder_id: str) -> str:
    """sha256 of the encoder's ONNX file as listed in the shipped manifest ('' if it is not listed)."""
    m = manifest.load(missing_ok=True)
    onnx = m.get("textEncoders", {}).get(encoder_id, {}).get("onnx")
    return m.get("files", {}).get(onnx, {}).get("sha256", "") if onnx else ""


def cached_text_embeddings(captions: list[str], encoder_id: str, cache_dir: Path | str) -> np.ndarray:
    """Embed captions with ``emdm.text.encode_texts`` (the shipped ONNX encoder), cached on disk by content."""
    cache_dir = Path(cache_dir)
    # the key covers the encoder's shipped ONNX file too, so re-exporting the encoder invalidates the cache
    key = hashlib.sha256(("\n".join(captions) + "\0" + encoder_id + "\0" + _encoder_file_sha256(encoder_id)).encode()).hexdigest()[:16]
    path = cache_dir / f"text-{encoder_id}-{key}.npy"
    if path.exists():
        emb = np.load(path)
        if emb.shape[0] == len(captions):
            return emb

    # batch_size 1: exactly what the browser computes (int8 dynamic quantisation scales per call)
    try:
        emb = np.asarray(text_encoders.encode_texts(captions, encoder_id=encoder_id, batch_size=1), dtype=np.float32)
    except text_encoders.TextEncoderError as e:   # a mistyped --encoder, or one not exported: one line, not a traceback
        raise DatasetError(f"text encoder {encoder_id!r} for the captions' embeddings: {e}") from None
    if emb.shape[0] != len(captions):
        raise RuntimeError(f"text encoder {encoder_id}: {emb.shape[0]} embeddings for {len(captions)} captions")
    cache_dir.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npy")
    np.save(tmp, emb)
    tmp.replace(path)
    return emb


def balanced_weights(groups: np.ndarray, alpha: float) -> np.ndarray:
    """Per-clip probabilities (N,) float64: group (action) a with n_a clips is drawn with P(a) ∝ n_a^α and its
    clips uniformly, so α = 1 is uniform over clips (the plain epoch) and α = 0 uniform over actions. Clips
    without an action (-1) form one group of their own."""
    groups = np.asarray(groups)
    if not np.isfinite(alpha) or alpha < 0:
        raise ValueError(f"balance alpha must be a finite number ≥ 0, got {alpha}")
    _, inv, counts = np.unique(groups, return_inverse=True, return_counts=True)
    pa = counts.astype(np.float64) ** alpha
    pa /= pa.sum()
    return pa[inv] / counts[inv]


def action_shares(groups: np.ndarray, alpha: float, labels: list[str]) -> list[dict]:
    """Per action, most drawn first: {"action", "clips", "share" (P at α), "share_clips" (P at α = 1)}."""
    groups = np.asarray(groups)
    w = balanced_weights(groups, alpha)
    rows = []
    for a in np.unique(groups):
        sel = groups == a
        name = labels[a] if 0 <= a < len(labels) else ("(no action)" if a < 0 else str(a))
        rows.append({"action": name, "clips": int(sel.sum()), "share": float(w[sel].sum()),
                     "share_clips": float(sel.mean())})
    return sorted(rows, key=lambda r: (-r["share"], r["action"]))


class BucketBatcher:
    """Seeded batches of similar-length clips; ``state()``/``load_state()`` give exact resume.

    Each epoch: permute (seed, epoch) — or, with ``alpha`` ≠ 1, draw N clips with replacement with the
    :func:`balanced_weights` of ``groups`` —, cut into chunks of ``batch * bucket`` clips, sort each chunk by
    length, cut into batches, permute the batches. With ``world > 1`` every rank takes its own
    ``batch``-sized slice of each global batch of ``batch * world`` clips.
    """

    def __init__(self, lengths: np.ndarray, batch: int, seed: int = 0, bucket: int = 20, rank: int = 0, world: int = 1,
                 groups: np.ndarray | None = None, alpha: float = 1.0):
        if len(lengths) < batch * world:
            raise ValueError(f"dataset has {len(lengths)} clips, fewer than one global batch ({batch}×{world})")
        self.lengths, self.batch, self.seed, self.bucket, self.rank, self.world = np.asarray(lengths), batch, seed, bucket, rank, world
        self.alpha = float(alpha)
        self.weights = None
        if self.alpha != 1.0:
            if groups is None or len(groups) != len(lengths):
                raise ValueError("balanced sampling (alpha ≠ 1) needs one group (action id) per clip")
            self.weights = balanced_weights(groups, self.alpha)
        self.epoch, self.pos = 0, 0
        self._order = self._epoch_batches(0)

    def _epoch_batches(self, epoch: int) -> list[np.ndarray]:
        rng = np.random.default_rng([self.seed, epoch])
        n = len(self.lengths)
        perm = rng.permutation(n) if self.weights is None else rng.choice(n, size=n, p=self.weights)
        gb = self.batch * self.world
        chunk = gb * self.bucket
        batches = []
        for s in range(0, len(perm) - gb + 1, chunk):
            part = perm[s:s + chunk]
            part = part[np.argsort(self.lengths[part], kind="stable")]
            batches += [part[i:i + gb] for i in range(0, len(part) - gb + 1, gb)]
        order = rng.permutation(len(batches))
        return [batches[i][self.rank * self.batch:(self.rank + 1) * self.batch] for i in order]

    def next(self) -> np.ndarray:
        return self.next_row()[2]

    def next_row(self) -> tuple[int, int, np.ndarray]:
        """(epoch, row of :meth:`epoch_order`, clip indices) of the next batch."""
        if self.pos >= len(self._order):
            self.epoch += 1
            self.pos = 0
            self._order = self._epoch_batches(self.epoch)
        b = self._order[self.pos]
        self.pos += 1
        return self.epoch, self.pos - 1, b

    def epoch_order(self) -> np.ndarray:
        """This rank's batches of the current epoch, (batches, batch) int64."""
        return np.stack(self._order).astype(np.int64)

    def state(self) -> dict:
        return {"epoch": self.epoch, "pos": self.pos, "seed": self.seed, "alpha": self.alpha}

    def load_state(self, st: dict) -> None:
        alpha = float(st.get("alpha", 1.0))
        if alpha != self.alpha:
            raise ValueError(f"the checkpoint's data order was drawn with balance alpha {alpha}, this run asks "
                             f"for {self.alpha}: use the same --balance-alpha, or another --out / --no-resume")
        self.seed, self.epoch, self.pos = st["seed"], st["epoch"], st["pos"]
        self._order = self._epoch_batches(self.epoch)


def crop_plan(lengths: np.ndarray, p: float, crop_min: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Random sub-windows: (start, length) per clip of ``lengths`` (any shape). With probability ``p`` a clip
    longer than ``crop_min`` gets a window of crop_min..len frames at a uniform start; otherwise the whole clip."""
    lengths = np.asarray(lengths, np.int64)
    start, n = np.zeros_like(lengths), lengths.copy()
    if p <= 0:
        return start, n
    u = rng.random(lengths.shape)
    v = rng.random(lengths.shape)
    w = rng.random(lengths.shape)
    do = (u < p) & (lengths > crop_min)
    cut = crop_min + np.floor(v * (lengths - crop_min + 1)).astype(np.int64)
    cut = np.minimum(cut, lengths)
    s = np.floor(w * (lengths - cut + 1)).astype(np.int64)
    return np.where(do, s, 0), np.where(do, cut, lengths)


class DeviceClips:
    """The whole split as one zero-padded tensor on ``device`` (N, L_max, 263), with lengths, actions and (text
    task) a padded table of each clip's caption ids, so a batch is gathered on the device without collation.

    Memory: N × L_max × 263 × 4 bytes (7,202 clips × 196 frames ≈ 1.5 GB)."""

    def __init__(self, ms: MotionSet, device, clip_caps: list[np.ndarray] | None = None):
        import torch

        n, lmax = len(ms), int(ms.lengths.max())
        x = torch.zeros(n, lmax, FEATURE_DIM, dtype=torch.float32)
        for i, m in enumerate(ms.motions):
            x[i, : len(m)] = torch.from_numpy(m)
        self.device = device
        self.x = x.to(device)
        self.max_len = lmax
        self.actions = torch.from_numpy(ms.actions).to(device)
        self.caps = self.ncaps = None
        if clip_caps is not None:
            width = max(len(c) for c in clip_caps)
            caps = np.zeros((n, width), np.int64)
            for i, c in enumerate(clip_caps):
                caps[i, : len(c)] = c
            self.caps = torch.from_numpy(caps).to(device)
            self.ncaps = torch.from_numpy(np.array([len(c) for c in clip_caps], np.int64)).to(device)

    def gather(self, idx, start, length, frames: int):
        """idx, start, length (B,) device int64; ``frames`` (host int ≥ max length) → x0 (B, frames, 263), mask."""
        import torch

        ar = torch.arange(frames, device=self.x.device)
        mask = (ar[None] < length[:, None])
        rows = (start[:, None] + ar[None]).clamp(max=self.max_len - 1)
        x0 = self.x[idx[:, None], rows] * mask.unsqueeze(-1)
        return x0, mask.float()

    def pick_captions(self, idx):
        """One caption id per clip of ``idx``, uniformly among the clip's captions (device RNG)."""
        import torch

        n = self.ncaps[idx]
        j = torch.minimum((torch.rand(idx.shape, device=self.x.device) * n).long(), n - 1)
        return self.caps[idx, j]


def collate(motions: list[np.ndarray], max_frames: int = MAX_FRAMES) -> tuple[np.ndarray, np.ndarray]:
    """Pad to the longest clip: (B, L, 263) float32 and mask (B, L) float32."""
    length = min(max(len(m) for m in motions), max_frames)
    x = np.zeros((len(motions), length, FEATURE_DIM), dtype=np.float32)
    mask = np.zeros((len(motions), length), dtype=np.float32)
    for i, m in enumerate(motions):
        n = min(len(m), length)
        x[i, :n] = m[:n]
        mask[i, :n] = 1.0
    return x, mask
