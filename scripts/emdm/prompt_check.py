"""Is a prompt near what a shipped model does well? The runtime half of the capabilities file (the twin of
``src/capabilities.ts``'s ``checkPrompt``): reads ``capabilities-<model>.json`` beside the model, scores a prompt's
embedding against its anchors (training captions of every action, covered or not) and names the closest working
prompts. Light on purpose: ``emdm.sample`` prints its
line, and a no-torch install runs it; ``emdm.eval.capabilities`` builds the file."""
from __future__ import annotations

import base64
import json
from pathlib import Path

import numpy as np

from emdm import manifest as mf
from emdm import paths
from emdm.prompt_language import reads_as_english

SCHEMA = 2             # 2: anchors of the uncovered actions too; known = nearest anchor covered and close enough
SUGGESTIONS = 3        # closest working prompts offered for an unknown one
# A prompt that reads as an uncovered action whose anchors lie this close (cosine of the two actions' anchor means) to a
# covered action's gets its suggestions ranked by the prompt and that action's mean together: "a person waves" reads as
# wave-both-hands (0.73 to raise-both-hands) and is offered the raised hands, not the bow, walk and run its words
# alone are nearest to. Below it the relation is too loose to lead (kick's nearest covered mean is sneak's, 0.70).
RELATED = 0.72
# The notice names the uncovered action a prompt reads as only from this cosine up: the held-apart paraphrases of the
# uncovered actions read as one at 0.57 and more; what merely lands nearest one (gibberish 0.33, French 0.37, "plays the
# guitar" as swordplay 0.47, "sits down on a chair" as deposit-floor 0.51) is said to be far from all it learned.
NAMED = 0.55
# What the notice and the page's list call an action whose label is dataset shorthand (others: hyphens as spaces); the
# capabilities file carries them (``actions[].name``) for the page.
ACTION_NAMES = {
    "call": "beckoning someone over", "deposit-floor": "putting something down on the floor",
    "dribble": "dribbling a ball", "elbow-to-knee": "touching each elbow to the opposite knee",
    "grab-high": "reaching up to grab something", "guide": "showing the way with a hand",
    "jog-in-circle": "jogging in a circle", "lie-down": "lying down", "pick-up": "picking something up",
    "respond": "replying with a raised hand", "rotate-arms": "circling the arms", "slash": "slashing with a sword",
    "swordplay": "sword fighting", "wash": "washing oneself",
}


def action_name(label: str) -> str:
    """What a visitor reads for an action label: "reaching up to grab something" for grab-high, "raise left hand"."""
    return ACTION_NAMES.get(label, label.replace("-", " "))


class CapabilitiesError(ValueError):
    """A capabilities file this code cannot read (another schema version): one line naming the file and what to do."""


def file_name(model: str) -> str:
    return f"capabilities-{model}.json"


def dequantise(q: np.ndarray) -> np.ndarray:
    """int8 rows → unit float rows (what the page computes with)."""
    v = np.asarray(q, np.float32)
    return v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-12)


def covered_actions(caps: dict) -> set[str]:
    return {r["label"] for r in caps["actions"] if r["covered"]}


def check(caps: dict, emb: np.ndarray) -> dict:
    """{known, score, action: the closest anchor's action, covered: whether the model does that action well, nearest:
    [chip prompts, closest first, one per action]} for one unit embedding. Known iff the closest anchor is of a covered
    action and its cosine is at least ``check.threshold``."""
    a = caps["anchors"]
    vecs = dequantise(np.frombuffer(base64.b64decode(a["embeddings"]), np.int8).reshape(len(a["texts"]), -1))
    emb = np.asarray(emb, np.float32)
    cos = vecs @ emb
    best = int(np.argmax(cos))
    action = a["actions"][best]
    good = covered_actions(caps)
    covered = action in good
    rank = cos
    if not covered:                 # an uncovered action's prompt: led by the covered action nearest to it (RELATED)
        means = action_means(vecs, a["actions"])
        near = max((float(means[action] @ means[x]) for x in good if x in means), default=-1.0)
        if near >= RELATED:
            q = emb + means[action]
            rank = vecs @ (q / max(float(np.linalg.norm(q)), 1e-12))
    nearest, seen = [], set()
    for i in np.argsort(-rank, kind="stable"):
        if a["suggest"][i] and a["actions"][i] not in seen:
            seen.add(a["actions"][i])
            nearest.append(a["texts"][i])
            if len(nearest) == SUGGESTIONS:
                break
    return {"known": bool(covered and cos[best] >= caps["check"]["threshold"]), "score": round(float(cos[best]), 4),
            "action": action, "covered": covered, "nearest": nearest}


def action_means(vecs: np.ndarray, actions: list[str]) -> dict[str, np.ndarray]:
    """Each action's anchors' mean, as a unit vector (float64)."""
    acts = np.asarray(actions)
    out = {}
    for x in dict.fromkeys(actions):
        m = vecs[acts == x].astype(np.float64).mean(0)
        out[x] = m / max(float(np.linalg.norm(m)), 1e-12)
    return out


def notice(result: dict, prompt: str | None = None) -> str | None:
    """The one line the CLI prints for an unknown prompt (None for a known one); the page says the same. With the
    ``prompt``, one that does not read as English is told so first (the model reads English only)."""
    if result["known"]:
        return None
    if prompt is not None and not reads_as_english(prompt):
        near = f"it does not read as English, and the model understands English prompts only; best match {result['score']:.2f}"
    elif not result["covered"] and result["score"] >= NAMED:
        near = f"it reads as {action_name(result['action'])}, which the model does not do well yet"
    else:
        near = f"best match {result['score']:.2f}"
    return (f"this prompt is far from what the model does well ({near}); it may come out as walking or standing. "
            "Closest prompts that work: " + "; ".join(repr(p) for p in result["nearest"]))


def load(model: str, models_dir: Path | str | None = None) -> dict | None:
    """The shipped capabilities file of ``model`` (None when there is none, or it was built for another encoder file;
    a ``CapabilitiesError`` for a file of another schema version)."""
    models_dir = paths.models_dir(models_dir)       # the argument, $EMDM_MODELS_DIR or public/models
    path = models_dir / file_name(model)
    if not path.is_file():
        return None
    caps = json.loads(path.read_text())
    if caps.get("schema") != SCHEMA:
        raise CapabilitiesError(f"{paths.display_path(path)}: schema {caps.get('schema')!r}, this code reads {SCHEMA}; "
                                f"rebuild it with python -m emdm.eval.capabilities --model {model}")
    if caps.get("model") != model or "check" not in caps:
        return None
    enc = caps["encoder"]
    if mf.load(models_dir)["files"].get(enc["onnx"], {}).get("sha256") != enc["sha256"]:
        return None                           # embeddings of another encoder file: stale, say nothing
    return caps


def prompt_notice(model: str, emb: np.ndarray, models_dir: Path | str | None = None,
                  prompt: str | None = None) -> str | None:
    caps = load(model, models_dir)
    return None if caps is None else notice(check(caps, emb), prompt)
