"""The evaluators, trained here because the official ones cannot be had.

* ``MatchingModel``: a text–motion matching model in the manner of Guo et al. (CVPR 2022): a
  motion encoder (temporal convolutions that downsample by 4, then a bidirectional GRU, as Guo's
  movement encoder + motion GRU) and a text encoder, trained contrastively on the train split so
  that a caption lies near its own motion. Guo's text side is a GRU over GloVe word vectors; GloVe
  cannot be had here, so the text side is a 2-layer MLP over the project's sentence encoder
  (all-MiniLM-L6-v2 via ``emdm.text.encode_texts``). Both embeddings are L2-normalised, so the
  Euclidean distances of the metrics (R-precision, MM-Dist) rank exactly like the cosine the
  loss trains (symmetric InfoNCE; captions that are near-duplicates of the positive are not used as
  negatives, since template captions repeat across clips).
* ``ActionClassifier``: the same motion encoder + a linear layer over the action vocabulary,
  trained with cross-entropy (ACTOR's protocol uses a recognition model's penultimate features for
  FID / diversity / multimodality and its prediction for accuracy; ``embed`` returns those).

Both read *raw* 263-d features (de-normalised), normalise them with the train-split Mean/Std
stored inside the checkpoint, and drop the 4 foot-contact channels (as Guo's evaluators do), so a
generator's own normalisation never matters.

CLI (``nice -n 19`` on shared machines; one thread by default):
    python -m emdm.eval.evaluators matcher    --dataset data/dataset --out runs/eval/matcher.pt
    python -m emdm.eval.evaluators classifier --dataset data/dataset --out runs/eval/classifier.pt
    python -m emdm.eval.evaluators classifier --seed 1 --out runs/eval/classifier-seed1.pt   # the judge of meaning
    python -m emdm.eval.evaluators classifier --seed 2 --out runs/eval/classifier-seed2.pt   # is all three (emdm.eval.judge)
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F
from torch.nn.utils.rnn import pack_padded_sequence

from emdm.checkpoints import torch_load
from emdm.eval import data as evdata
from emdm.eval import metrics as M
from emdm.outdir import OutputRefused, check_writable
from emdm.paths import DATASET_DIR, RUNS_DIR

FEATURE_DIM = 263
INPUT_DIM = 259           # features without the 4 foot-contact channels
DOWNSAMPLE = 4            # the conv front end halves the length twice
CHECKPOINT_SCHEMA = 1


# ----------------------------------------------------------------------------- networks

class MotionEncoder(nn.Module):
    """(B, L, 259) normalised features + lengths → (B, out_dim)."""

    def __init__(self, hidden: int = 256, out_dim: int = 256, dropout: float = 0.2):
        super().__init__()
        self.conv1 = nn.Sequential(nn.Conv1d(INPUT_DIM, hidden, 4, 2, 1), nn.LeakyReLU(0.2), nn.Dropout(dropout))
        self.conv2 = nn.Sequential(nn.Conv1d(hidden, hidden, 4, 2, 1), nn.LeakyReLU(0.2))
        self.gru = nn.GRU(hidden, hidden, batch_first=True, bidirectional=True)
        self.out = nn.Sequential(nn.Linear(2 * hidden, hidden), nn.LayerNorm(hidden), nn.LeakyReLU(0.2),
                                 nn.Linear(hidden, out_dim))

    def forward(self, x: torch.Tensor, lengths: torch.Tensor) -> torch.Tensor:
        h = self.conv1(x.transpose(1, 2))                                  # (B, hidden, L//2)
        # zero the half-rate frames past each clip's end, so that a clip's embedding does not depend
        # on how much padding its batch adds (the conv would turn zero input into its bias)
        half = torch.arange(h.shape[2], device=h.device)[None, :] < (lengths // 2)[:, None].to(h.device)
        h = self.conv2(h * half.unsqueeze(1)).transpose(1, 2)              # (B, L//4, hidden)
        steps = torch.clamp(lengths // DOWNSAMPLE, min=1, max=h.shape[1]).cpu()
        packed = pack_padded_sequence(h, steps, batch_first=True, enforce_sorted=False)
        _, hn = self.gru(packed)                                           # (2, B, hidden)
        return self.out(torch.cat([hn[0], hn[1]], dim=-1))


class _Normaliser(nn.Module):
    """Raw 263-d features → normalised, contact channels dropped; stats are checkpoint buffers."""

    def __init__(self, mean: np.ndarray, std: np.ndarray):
        super().__init__()
        mean, std = np.asarray(mean, np.float32), np.asarray(std, np.float32)
        if mean.shape != (FEATURE_DIM,) or std.shape != (FEATURE_DIM,):
            raise ValueError(f"mean/std must have shape ({FEATURE_DIM},), got {mean.shape} / {std.shape}")
        if np.any(std <= 0):
            raise ValueError(f"std has {int((std <= 0).sum())} non-positive entries (first at {int(np.argmax(std <= 0))})")
        self.register_buffer("mean", torch.from_numpy(mean))
        self.register_buffer("std", torch.from_numpy(std))

    def forward(self, raw: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        x = (raw - self.mean) / self.std
        return (x * mask.unsqueeze(-1))[..., :INPUT_DIM]


class MatchingModel(nn.Module):
    def __init__(self, mean, std, text_dim: int, hidden: int = 256, emb_dim: int = 256, dropout: float = 0.2):
        super().__init__()
        self.config = {"text_dim": text_dim, "hidden": hidden, "emb_dim": emb_dim, "dropout": dropout}
        self.norm = _Normaliser(mean, std)
        self.motion = MotionEncoder(hidden, emb_dim, dropout)
        self.text = nn.Sequential(nn.Linear(text_dim, 2 * hidden), nn.LayerNorm(2 * hidden), nn.LeakyReLU(0.2),
                                  nn.Dropout(dropout), nn.Linear(2 * hidden, emb_dim))
        self.log_scale = nn.Parameter(torch.tensor(math.log(1 / 0.07)))   # InfoNCE inverse temperature

    def encode_motion(self, raw: torch.Tensor, lengths: torch.Tensor) -> torch.Tensor:
        mask = (torch.arange(raw.shape[1])[None, :] < lengths[:, None]).float()
        return F.normalize(self.motion(self.norm(raw, mask), lengths), dim=-1)

    def encode_text(self, text_emb: torch.Tensor) -> torch.Tensor:
        return F.normalize(self.text(text_emb), dim=-1)


class ActionClassifier(nn.Module):
    def __init__(self, mean, std, num_classes: int, hidden: int = 256, emb_dim: int = 256, dropout: float = 0.2):
        super().__init__()
        self.config = {"num_classes": num_classes, "hidden": hidden, "emb_dim": emb_dim, "dropout": dropout}
        self.norm = _Normaliser(mean, std)
        self.motion = MotionEncoder(hidden, emb_dim, dropout)
        self.head = nn.Sequential(nn.LeakyReLU(0.2), nn.Dropout(dropout), nn.Linear(emb_dim, num_classes))

    def embed(self, raw: torch.Tensor, lengths: torch.Tensor) -> torch.Tensor:
        mask = (torch.arange(raw.shape[1])[None, :] < lengths[:, None]).float()
        return self.motion(self.norm(raw, mask), lengths)

    def forward(self, raw: torch.Tensor, lengths: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        emb = self.embed(raw, lengths)
        return self.head(emb), emb


# ----------------------------------------------------------------------------- batching

def pad_motions(motions: Sequence[np.ndarray]) -> tuple[torch.Tensor, torch.Tensor]:
    """List of raw (F_i, 263) arrays → zero-padded (B, max F, 263) tensor and lengths (B,)."""
    if len(motions) == 0:
        raise ValueError("pad_motions: no motions")
    for i, m in enumerate(motions):
        if m.ndim != 2 or m.shape[1] != FEATURE_DIM:
            raise ValueError(f"motion {i}: expected shape (frames, {FEATURE_DIM}), got {m.shape}")
        if m.shape[0] < DOWNSAMPLE:
            raise ValueError(f"motion {i}: {m.shape[0]} frames; the evaluators need at least {DOWNSAMPLE}")
        if not np.all(np.isfinite(m)):
            raise ValueError(f"motion {i}: non-finite feature at frame {int(np.argwhere(~np.isfinite(m))[0][0])}")
    lengths = torch.tensor([m.shape[0] for m in motions])
    out = torch.zeros(len(motions), int(lengths.max()), FEATURE_DIM)
    for i, m in enumerate(motions):
        out[i, : m.shape[0]] = torch.from_numpy(np.asarray(m, np.float32))
    return out, lengths


@torch.no_grad()
def embed_motions(model: MatchingModel | ActionClassifier, motions: Sequence[np.ndarray],
                  batch_size: int = 128) -> np.ndarray:
    """Evaluator embeddings (N, emb_dim) of raw feature sequences (eval mode, batched)."""
    was_training = model.training
    model.eval()
    out = []
    for s in range(0, len(motions), batch_size):
        raw, lengths = pad_motions(motions[s:s + batch_size])
        emb = model.encode_motion(raw, lengths) if isinstance(model, MatchingModel) else model.embed(raw, lengths)
        out.append(emb.numpy())
    model.train(was_training)
    return np.concatenate(out).astype(np.float64)


@torch.no_grad()
def embed_texts(model: MatchingModel, text_emb: np.ndarray) -> np.ndarray:
    was_training = model.training
    model.eval()
    out = model.encode_text(torch.as_tensor(np.asarray(text_emb, np.float32))).numpy()
    model.train(was_training)
    return out.astype(np.float64)


@torch.no_grad()
def classify(model: ActionClassifier, motions: Sequence[np.ndarray], batch_size: int = 128) -> tuple[np.ndarray, np.ndarray]:
    """Logits (N, classes) and penultimate features (N, emb_dim)."""
    was_training = model.training
    model.eval()
    logits, feats = [], []
    for s in range(0, len(motions), batch_size):
        raw, lengths = pad_motions(motions[s:s + batch_size])
        lg, emb = model(raw, lengths)
        logits.append(lg.numpy())
        feats.append(emb.numpy())
    model.train(was_training)
    return np.concatenate(logits).astype(np.float64), np.concatenate(feats).astype(np.float64)


# ----------------------------------------------------------------------------- training

@dataclass
class TrainConfig:
    epochs: int = 30
    batch_size: int = 64
    lr: float = 1e-3
    weight_decay: float = 1e-4
    hidden: int = 256
    emb_dim: int = 256
    dropout: float = 0.2
    seed: int = 0
    duplicate_cos: float = 0.95     # matcher: captions this similar to the positive are not negatives
    min_crop: float = 0.7           # classifier: random crops keep at least this fraction of a clip
    max_minutes: float = 0.0        # stop after this wall time (0 = no limit)


def matching_loss(text: torch.Tensor, motion: torch.Tensor, scale: torch.Tensor,
                  negative_mask: torch.Tensor | None = None) -> torch.Tensor:
    """Symmetric InfoNCE over a batch of normalised pairs; ``negative_mask[i, j]`` False removes j
    from row i's negatives (the diagonal always stays, as the positive)."""
    logits = scale * text @ motion.T
    if negative_mask is not None:
        keep = negative_mask | torch.eye(len(text), dtype=torch.bool)
        logits = logits.masked_fill(~keep, -1e4)
    target = torch.arange(len(text))
    return 0.5 * (F.cross_entropy(logits, target) + F.cross_entropy(logits.T, target))


def length_batches(lengths: np.ndarray, batch: int, rng: np.random.Generator, bucket: int = 8) -> list[np.ndarray]:
    """One epoch of index batches of similar lengths (less padding, so less compute): shuffle, sort
    chunks of ``batch * bucket`` clips by length, cut into batches, shuffle the batches. A final
    incomplete batch is dropped (contrastive batches need their negatives)."""
    perm = rng.permutation(len(lengths))
    out = []
    for s in range(0, len(perm), batch * bucket):
        chunk = perm[s:s + batch * bucket]
        chunk = chunk[np.argsort(np.asarray(lengths)[chunk], kind="stable")]
        out += [chunk[i:i + batch] for i in range(0, len(chunk) - batch + 1, batch)]
    if not out:                              # fewer clips than one batch: one smaller batch
        out = [perm]
    return [out[i] for i in rng.permutation(len(out))]


def _crop(m: np.ndarray, rng: np.random.Generator, min_frac: float) -> np.ndarray:
    n = m.shape[0]
    keep = int(rng.integers(max(DOWNSAMPLE, int(math.ceil(n * min_frac))), n + 1))
    start = int(rng.integers(0, n - keep + 1))
    return m[start:start + keep]


def train_matcher(motions: Sequence[np.ndarray], text_emb: Sequence[np.ndarray], mean, std,
                  cfg: TrainConfig = TrainConfig(), *, val: tuple[Sequence[np.ndarray], np.ndarray] | None = None,
                  log: Callable[[dict], None] | None = None) -> MatchingModel:
    """Train on pairs: ``motions[i]`` (raw (F, 263)) with ``text_emb[i]`` (n_i, text_dim): one or
    more caption embeddings of that motion, of which each batch draws one at random.

    ``val`` = (motions, one caption embedding each) reports R-precision per epoch through ``log``.
    """
    if len(motions) != len(text_emb):
        raise ValueError(f"train_matcher: {len(motions)} motions but {len(text_emb)} caption sets")
    caps = [np.atleast_2d(np.asarray(c, np.float32)) for c in text_emb]
    for i, c in enumerate(caps):
        if c.shape[0] == 0:
            raise ValueError(f"train_matcher: motion {i} has no caption embedding")
    torch.manual_seed(cfg.seed)
    rng = np.random.default_rng(cfg.seed)
    model = MatchingModel(mean, std, caps[0].shape[1], cfg.hidden, cfg.emb_dim, cfg.dropout)

    def batch_loss(idx: np.ndarray) -> torch.Tensor:
        raw, lengths = pad_motions([motions[i] for i in idx])
        t_raw = torch.from_numpy(np.stack([caps[i][rng.integers(len(caps[i]))] for i in idx]))
        neg = (F.normalize(t_raw, dim=-1) @ F.normalize(t_raw, dim=-1).T) < cfg.duplicate_cos
        return matching_loss(model.encode_text(t_raw), model.encode_motion(raw, lengths),
                             model.log_scale.exp().clamp(max=100.0), neg)

    def validate() -> dict:
        if val is None or len(val[0]) < M.R_PRECISION_POOL:
            return {}
        rp, mm = M.r_precision_and_matching(embed_texts(model, val[1]), embed_motions(model, val[0]), rng=0)
        return {"val_top1": rp[0], "val_top3": rp[2], "val_mm_dist": mm}

    return _fit(model, [len(m) for m in motions], cfg, rng, batch_loss, validate, log)


def train_classifier(motions: Sequence[np.ndarray], labels, num_classes: int, mean, std,
                     cfg: TrainConfig = TrainConfig(), *, val: tuple[Sequence[np.ndarray], np.ndarray] | None = None,
                     log: Callable[[dict], None] | None = None) -> ActionClassifier:
    """Cross-entropy training on random crops (≥ ``cfg.min_crop`` of each clip), class-balanced loss."""
    labels = np.asarray(labels, dtype=np.int64)
    if labels.shape != (len(motions),):
        raise ValueError(f"train_classifier: labels shape {labels.shape} != ({len(motions)},)")
    if labels.min() < 0 or labels.max() >= num_classes:
        raise ValueError(f"train_classifier: labels must lie in [0, {num_classes}), got [{labels.min()}, {labels.max()}]")
    torch.manual_seed(cfg.seed)
    rng = np.random.default_rng(cfg.seed)
    model = ActionClassifier(mean, std, num_classes, cfg.hidden, cfg.emb_dim, cfg.dropout)
    counts = np.bincount(labels, minlength=num_classes).astype(np.float32)
    weight = torch.from_numpy(np.where(counts > 0, counts.sum() / np.maximum(counts, 1) / num_classes, 0.0)).float()

    def batch_loss(idx: np.ndarray) -> torch.Tensor:
        raw, lengths = pad_motions([_crop(motions[i], rng, cfg.min_crop) for i in idx])
        logits, _ = model(raw, lengths)
        return F.cross_entropy(logits, torch.from_numpy(labels[idx]), weight=weight)

    def validate() -> dict:
        if val is None or not len(val[0]):
            return {}
        return {"val_accuracy": M.accuracy(classify(model, val[0])[0], val[1])}

    return _fit(model, [len(m) for m in motions], cfg, rng, batch_loss, validate, log)


def _fit(model: nn.Module, lens: Sequence[int], cfg: TrainConfig, rng: np.random.Generator,
         batch_loss: Callable[[np.ndarray], torch.Tensor], validate: Callable[[], dict],
         log: Callable[[dict], None] | None):
    """The evaluators' one training loop: AdamW, cosine decay to 5% over ``cfg.epochs`` epochs of
    length-bucketed batches (``batch_loss(indices)`` → loss), gradient clipping at 1, a row per epoch
    (loss, minutes, ``validate()``'s metrics) to ``log``, a stop after ``cfg.max_minutes``. Returns the
    model in eval mode."""
    lens = np.asarray(lens)
    opt = torch.optim.AdamW(model.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
    n_batches = len(length_batches(lens, cfg.batch_size, np.random.default_rng(0)))
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, T_max=cfg.epochs * n_batches, eta_min=cfg.lr * 0.05)
    t0 = time.time()
    for epoch in range(cfg.epochs):
        losses = []
        for idx in length_batches(lens, cfg.batch_size, rng):
            loss = batch_loss(idx)
            opt.zero_grad()
            loss.backward()
            nn.utils.clip_grad_norm_(model.parameters(), 1.0)
            opt.step()
            sched.step()
            losses.append(loss.item())
        row = {"epoch": epoch + 1, "loss": float(np.mean(losses)), "minutes": (time.time() - t0) / 60}
        row.update(validate())
        if log:
            log(row)
        if cfg.max_minutes and row["minutes"] >= cfg.max_minutes:
            break
    return model.eval()


# ----------------------------------------------------------------------------- checkpoints

def save(model: MatchingModel | ActionClassifier, path: Path | str, meta: dict | None = None) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    kind = "matcher" if isinstance(model, MatchingModel) else "classifier"
    tmp = path.with_suffix(path.suffix + ".tmp")
    torch.save({"schema": CHECKPOINT_SCHEMA, "kind": kind, "config": model.config,
                "state": model.state_dict(), "meta": meta or {}}, tmp)
    tmp.replace(path)
    return path


def load(path: Path | str, kind: str | None = None) -> MatchingModel | ActionClassifier:
    """Load a checkpoint written by ``save``; ``kind`` ('matcher'/'classifier') is checked if given."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: evaluator checkpoint not found; train it with "
                                f"`python -m emdm.eval.evaluators {kind or 'matcher'} --out {path}`")
    try:                                     # tensors and plain values only: a checkpoint cannot run code

        ck = torch_load(path)
    except Exception as e:  # noqa: BLE001 - re-raised as one line naming the file
        first = (str(e).strip().splitlines() or [type(e).__name__])[0]
        raise ValueError(f"{path}: cannot read as an evaluator checkpoint: {type(e).__name__}: {first[:200]}") from e
    if not isinstance(ck, dict) or ck.get("schema") != CHECKPOINT_SCHEMA:
        raise ValueError(f"{path}: not an evaluator checkpoint of schema {CHECKPOINT_SCHEMA}")
    if kind is not None and ck["kind"] != kind:
        raise ValueError(f"{path}: holds a {ck['kind']}, expected a {kind}")
    st = ck["state"]
    zeros = np.zeros(FEATURE_DIM, np.float32)
    if ck["kind"] == "matcher":
        model: nn.Module = MatchingModel(zeros, zeros + 1, **ck["config"])
    else:
        model = ActionClassifier(zeros, zeros + 1, **ck["config"])
    model.load_state_dict(st)
    model.meta = ck.get("meta", {})
    return model.eval()


# ----------------------------------------------------------------------------- CLI

def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="python -m emdm.eval.evaluators", description=__doc__.split("\n\n")[0])
    ap.add_argument("kind", choices=["matcher", "classifier"])
    ap.add_argument("--dataset", type=Path, default=DATASET_DIR)
    ap.add_argument("--out", type=Path, default=None, help="checkpoint (default runs/eval/<kind>.pt)")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--max-items", type=int, default=0, help="use at most this many train clips (0 = all)")
    for f, v in asdict(TrainConfig()).items():
        ap.add_argument("--" + f.replace("_", "-"), type=type(v), default=v)
    return ap


def _check_args(ap: argparse.ArgumentParser, a: argparse.Namespace) -> None:
    """``ap.error`` (exit 2) for a count the training cannot use."""
    for name, least in (("threads", 1), ("epochs", 1), ("batch_size", 1), ("max_items", 0)):
        if getattr(a, name) < least:
            ap.error(f"--{name.replace('_', '-')}: expected ≥ {least}, got {getattr(a, name)}")


def _inputs(a: argparse.Namespace) -> tuple[evdata.EvalSplit, tuple | None, list | None]:
    """The train split, the validation pair the training reports on (None: no usable val split) and, for the
    matcher, the train captions' embeddings; a ValueError (DatasetError, TextEncoderError: one line naming the
    file) for a dataset it cannot train on."""
    need_action = a.kind == "classifier"
    train = evdata.load_split(a.dataset, "train", max_items=a.max_items or None, require_action=need_action)
    try:
        val = evdata.load_split(a.dataset, "val", require_action=need_action)
    except Exception as e:  # noqa: BLE001 - a dataset without a val split still trains
        print(f"no validation split used: {e}", file=sys.stderr)
        val = None
    if need_action:
        evdata.action_labels(train)
        return train, (val.motions, val.actions) if val is not None else None, None
    cap_emb = evdata.caption_embeddings(train)
    vpair = None
    if val is not None:
        vemb = evdata.caption_embeddings(val)
        vpair = (val.motions, np.stack([e[0] for e in vemb]))
    return train, vpair, cap_emb


def _main(argv: list[str] | None = None) -> int:
    """Train one evaluator; 0, or 2 with one line on stderr for a dataset or --out it cannot use (checked before
    anything is written: a refused run leaves no checkpoint, log or folder)."""
    ap = _parser()
    a = ap.parse_args(argv)
    _check_args(ap, a)
    torch.set_num_threads(a.threads)
    cfg = TrainConfig(**{f: getattr(a, f) for f in asdict(TrainConfig())})
    out = a.out or RUNS_DIR / "eval" / f"{a.kind}.pt"
    log_path = out.with_suffix(".log.jsonl")
    try:
        check_writable(out)
        check_writable(log_path, option="--out (its log)")
        train, vpair, cap_emb = _inputs(a)
    except (OutputRefused, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    log_path.parent.mkdir(parents=True, exist_ok=True)
    history: list[dict] = []
    meta = {"dataset": str(a.dataset), "train_items": len(train), "config": asdict(cfg)}
    t0 = time.time()
    with open(log_path, "w") as logf:
        def log(row: dict) -> None:
            history.append(row)
            logf.write(json.dumps(row) + "\n")
            logf.flush()
            print(" ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()), flush=True)

        if a.kind == "matcher":
            model = train_matcher(train.motions, cap_emb, train.mean, train.std, cfg, val=vpair, log=log)
            meta["text_encoder"] = evdata.TEXT_ENCODER
        else:
            labels, vocab = evdata.action_labels(train)
            model = train_classifier(train.motions, labels, len(vocab), train.mean, train.std, cfg, val=vpair, log=log)
            meta["labels"] = vocab
    meta["minutes"] = (time.time() - t0) / 60
    meta["epochs_run"] = len(history)
    meta["final"] = history[-1] if history else {}
    save(model, out, meta)
    print(f"wrote {out} ({meta['minutes']:.1f} min); log {log_path}")
    return 0


if __name__ == "__main__":
    sys.exit(_main())
