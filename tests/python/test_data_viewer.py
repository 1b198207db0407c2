"""The PNG strip viewer renders a clip (by dataset id or .npy) and rejects wrong shapes."""

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
    with pytest.raises(SystemExit, match="not found"):
        viewer.main(["missing_00", "--dataset", str(ds), "--out", str(tmp_path / "c.png")])
    with pytest.raises(ValueError, match=r"expected \(frames, 22, 3\)"):
        viewer.render_strip(np.zeros((4, 21, 3)), tmp_path / "d.png")
