"""The PNG strip viewer renders a clip (by dataset id or .npy) and rejects wrong shapes, ids and --out paths."""

import numpy as np
import pytest
from PIL import Image

from emdm.data import viewer
from emdm.motion.synthetic import synthetic_walk


def test_strip_from_npy_and_from_a_dataset_id(tmp_path, capsys):
    J = synthetic_walk(40).astype(np.float32)
    np.save(tmp_path / "walk.npy", J)
    assert viewer.main([str(tmp_path / "walk.npy"), "--out", str(tmp_path / "a.png"), "--frames", "5"]) == 0
    img = Image.open(tmp_path / "a.png")
    assert img.size[0] > 1.5 * img.size[1] and img.size[1] > 200, "a wide strip"
    ds = tmp_path / "ds"
    (ds / "new_joints").mkdir(parents=True)
    (ds / "texts").mkdir()
    np.save(ds / "new_joints" / "x_00.npy", J)
    (ds / "texts" / "x_00.txt").write_text("A person walks.#a/DET person/NOUN walk/VERB#0.0#0.0\n")
    assert viewer.main(["x_00", "--dataset", str(ds), "--out", str(tmp_path / "b.png"), "--view", "front"]) == 0
    assert (tmp_path / "b.png").stat().st_size > 1000
    with pytest.raises(ValueError, match=r"expected \(frames, 22, 3\)"):
        viewer.render_strip(np.zeros((4, 21, 3)), tmp_path / "d.png")


def test_a_clip_or_out_it_cannot_use_is_one_line_and_exit_2(tmp_path, capsys):
    """As the other CLIs: an unknown id, an unreadable or wrong-shaped .npy, an --out that is a folder or lies under a
    file answer one line starting 'error:' (exit 2) and write nothing."""
    ds = tmp_path / "ds"
    (ds / "new_joints").mkdir(parents=True)
    np.save(tmp_path / "flat.npy", np.zeros((4, 21, 3)))
    (tmp_path / "junk.npy").write_text("not an array")
    np.save(tmp_path / "walk.npy", synthetic_walk(10).astype(np.float32))
    cases = {("missing_00", "c.png"): f"{ds / 'new_joints' / 'missing_00.npy'}: not found (give a dataset id or a .npy",
             (str(tmp_path / "flat.npy"), "c.png"): f"{tmp_path / 'flat.npy'}: expected joints of shape "
                                                    "(frames, 22, 3), got (4, 21, 3)",
             (str(tmp_path / "junk.npy"), "c.png"): f"{tmp_path / 'junk.npy'}: cannot read as a .npy array",
             (str(tmp_path / "walk.npy"), "ds"): f"--out {ds}: is a folder; give a file path",
             (str(tmp_path / "walk.npy"), "junk.npy/c.png"): f"--out {tmp_path / 'junk.npy' / 'c.png'}: "
                                                             f"{tmp_path / 'junk.npy'} is a file, not a folder"}
    for (clip, out), says in cases.items():
        assert viewer.main([clip, "--dataset", str(ds), "--out", str(tmp_path / out)]) == 2
        cap = capsys.readouterr()
        lines = cap.err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"error: {says}") and not cap.out, (says, cap.err)
    with pytest.raises(SystemExit) as e:
        viewer.main([str(tmp_path / "walk.npy"), "--out", str(tmp_path / "c.png"), "--frames", "0"])
    assert e.value.code == 2 and "--frames: expected ≥ 1, got 0" in capsys.readouterr().err
    assert not list(tmp_path.glob("*.png"))
