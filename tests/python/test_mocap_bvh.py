"""BVH reader + forward kinematics: known poses -> known joints; malformed files name file and line."""

from pathlib import Path

import numpy as np
import pytest

from emdm import paths
from emdm import skeleton as sk
from emdm.mocap import bvh
from emdm.mocap.errors import MocapFormatError

CHAIN = """HIERARCHY
ROOT Base
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Mid
  {
    OFFSET 0 0 1
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT Tip
    {
      OFFSET 0 0 2
      CHANNELS 3 Xposition Yposition Zposition
      End Site
      {
        OFFSET 0 5 0
      }
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.0333333
0 0 0  0 0 0   0 0 0    0 0 2
10 20 30  90 0 0   0 0 0    0 0 2
0 0 0  0 0 0   90 90 0    0 0 3
"""


def test_fk_known_poses_rotation_order_and_end_sites(tmp_path):
    p = tmp_path / "chain.bvh"
    p.write_text(CHAIN)
    b = bvh.read_bvh(p)
    assert b.names == ["Base", "Mid", "Tip", "Tip_End"]
    assert b.parents == [-1, 0, 1, 2]
    assert b.num_frames == 3 and abs(b.fps - 30.0) < 1e-3
    pos = bvh.forward_kinematics(b)
    # frame 0: rest
    np.testing.assert_allclose(pos[0], [[0, 0, 0], [0, 0, 1], [0, 0, 3], [0, 5, 3]], atol=1e-9)
    # frame 1: root moved and turned 90 deg about Z: +Y offsets become -X, Z offsets unchanged
    np.testing.assert_allclose(pos[1], [[10, 20, 30], [10, 20, 31], [10, 20, 33], [5, 20, 33]], atol=1e-9)
    # frame 2: Mid = Rz(90) Rx(90) Ry(0) (channel order Z X Y): (0,0,1) -Rx-> (0,-1,0) -Rz-> (1,0,0);
    # Tip's position channels replace its OFFSET (0,0,3)
    np.testing.assert_allclose(pos[2, 2], [0 + 3, 0, 1], atol=1e-9)
    # the End Site (0,5,0) under the same rotation: (0,5,0) -Rx-> (0,0,5) -Rz-> (0,0,5)
    np.testing.assert_allclose(pos[2, 3], [3, 0, 6], atol=1e-9)


def test_partial_fk_computes_only_the_requested_joints_and_ancestors(tmp_path):
    b = bvh.parse_bvh_text(CHAIN, "chain.bvh")
    pos = bvh.forward_kinematics(b, [1])
    assert np.isfinite(pos[:, :2]).all() and np.isnan(pos[:, 2:]).all()
    np.testing.assert_allclose(pos[:, 1], bvh.forward_kinematics(b)[:, 1])


@pytest.mark.parametrize("edit,line,needle", [
    (lambda s: s.replace("0 0 0  0 0 0   90 90 0    0 0 3", "0 0 0  0 0 0   90 90    0 0 3"), 26, "has 11 values, expected 12"),
    (lambda s: s.replace("CHANNELS 3 Zrotation Xrotation Yrotation", "CHANNELS 3 Zrotation Xrotation Wrotation"), 9, "unknown channel"),
    (lambda s: s.replace("OFFSET 0 0 2", "OFFSET 0 zero 2"), 12, "expected a number"),
    (lambda s: s.replace("Frames: 3", "Frames: 4"), 26, "header says 'Frames: 4'"),
    (lambda s: s.replace("CHANNELS 3 Zrotation", "CHANNELS 2 Zrotation"), 9, "says 2 channels but lists 3"),
    (lambda s: s.replace("  }\n}\nMOTION", "  }\nMOTION"), 20, "unclosed"),
    (lambda s: s.replace("HIERARCHY", "HIERARCHIE"), 1, "expected 'HIERARCHY'"),
    (lambda s: s.replace("0 0 0  0 0 0   0 0 0    0 0 2", "0 0 0  0 0 0   0 0 x    0 0 2"), 24, "expected a number"),
    (lambda s: s.replace("10 20 30  90", "10 nan 30  90"), 25, "joint 'Base' yposition: 'nan' is not a finite number"),
    (lambda s: s.replace("0 0 0  0 0 0   90 90 0", "0 0 0  0 0 0   90 1e308 0"), 26, "'Mid' xrotation: 1e308 degrees is out of range"),
    (lambda s: s.replace("OFFSET 0 0 2", "OFFSET 0 inf 2"), 12, "'inf' is not a finite number"),
    (lambda s: s.replace("Frame Time: 0.0333333", "Frame Time: inf"), 23, "Frame Time: 'inf' is not a finite number"),
    (lambda s: s.replace("Frame Time: 0.0333333", "Frame Time: 0"), 23, "Frame Time must be between 1e-05 and 10 seconds"),
])
def test_malformed_files_report_file_and_line(tmp_path, edit, line, needle):
    p = tmp_path / "bad.bvh"
    p.write_text(edit(CHAIN))
    with pytest.raises(MocapFormatError) as e:
        bvh.read_bvh(p)
    assert e.value.path == str(p) and e.value.line == line, str(e.value)
    assert needle in str(e.value) and f"{p}:{line}:" in str(e.value)


def reference_bvh_text(root_path: np.ndarray, yaw_deg: np.ndarray, arm_deg: np.ndarray, fps: float = 30.0,
                       scale: float = 100.0) -> str:
    """A BVH of the reference skeleton itself (joint names = SMPL names, centimetres by default):
    the pelvis follows ``root_path`` (F, 3) metres, turned ``yaw_deg`` about Y, and the left
    shoulder rotates the arm down by ``arm_deg`` about Z (T-pose at 0)."""
    children = {j: [c for c in range(22) if sk.PARENTS[c] == j] for j in range(22)}
    lines = ["HIERARCHY"]

    def emit(j, depth):
        ind = "  " * depth
        kw = "ROOT" if j == 0 else "JOINT"
        off = sk.REFERENCE_OFFSETS[j] * scale if j else np.zeros(3)
        lines.append(f"{ind}{kw} {sk.JOINT_NAMES[j]}")
        lines.append(f"{ind}{{")
        lines.append(f"{ind}  OFFSET {off[0]:.6f} {off[1]:.6f} {off[2]:.6f}")
        lines.append(f"{ind}  CHANNELS {6 if j == 0 else 3} " + ("Xposition Yposition Zposition " if j == 0 else "")
                     + "Yrotation Xrotation Zrotation")
        for c in children[j]:
            emit(c, depth + 1)
        if not children[j]:
            lines.extend([f"{ind}  End Site", f"{ind}  {{", f"{ind}    OFFSET 0 0 0", f"{ind}  }}"])
        lines.append(f"{ind}}}")

    emit(0, 0)
    F = len(root_path)
    lines += ["MOTION", f"Frames: {F}", f"Frame Time: {1.0 / fps:.8f}"]
    order = [0]
    stack = list(reversed(children[0]))
    while stack:  # depth-first order, as declared
        j = stack.pop()
        order.append(j)
        stack.extend(reversed(children[j]))
    for f in range(F):
        vals = []
        for j in order:
            if j == 0:
                vals += list(root_path[f] * scale) + [yaw_deg[f], 0.0, 0.0]
            elif sk.JOINT_NAMES[j] == "l_shoulder":
                vals += [0.0, 0.0, -arm_deg[f]]
            else:
                vals += [0.0, 0.0, 0.0]
        lines.append(" ".join(f"{v:.6f}" for v in vals))
    return "\n".join(lines) + "\n"


def test_reference_skeleton_bvh_round_trips_to_the_rest_pose(tmp_path):
    F = 4
    path = np.zeros((F, 3))
    path[:, 1] = sk.REFERENCE_OFFSETS[0, 1]
    p = tmp_path / "ref.bvh"
    p.write_text(reference_bvh_text(path, np.zeros(F), np.array([0, 0, 90, 90])))
    b = bvh.read_bvh(p)
    pos = bvh.forward_kinematics(b) / 100.0
    idx = [b.index(n) for n in sk.JOINT_NAMES]
    np.testing.assert_allclose(pos[0, idx], sk.rest_pose(), atol=1e-6)
    # left arm rotated 90 deg down about Z: the wrist hangs below the shoulder
    sh, wr = pos[2, b.index("l_shoulder")], pos[2, b.index("l_wrist")]
    np.testing.assert_allclose(wr - sh, [0, -0.51, 0], atol=1e-6)


SHARED = paths.shared_data_dir()
needs_bandai = pytest.mark.skipif(not (SHARED / "bandai-namco-motion.tar.xz").is_file(),
                                  reason=f"real mocap not found: {SHARED}/bandai-namco-motion.tar.xz "
                                         "(put ../shared/data beside the checkout or set EMDM_SHARED_DATA)")


@needs_bandai
def test_real_bandai_clip_parses_with_plausible_body():
    from emdm.data.unpack import unpack_archive

    root = unpack_archive(SHARED / "bandai-namco-motion.tar.xz")
    f = next(root.rglob("dataset-1_walk_normal_001.bvh"))
    b = bvh.read_bvh(f)
    assert abs(b.fps - 30) < 0.01 and b.num_frames > 100
    assert all(len(c) == 6 for c in b.channels if c)
    pos = bvh.forward_kinematics(b) / 100.0
    hips, head, toe = (pos[:, b.index(n)] for n in ("Hips", "Head", "Toes_L"))
    assert 0.8 < np.median(hips[:, 1]) < 1.05
    assert 1.3 < np.median(head[:, 1] - toe[:, 1]) < 1.8
    walked = hips[-1] - hips[0]
    assert walked[2] > 3.0, "the walk clip moves along +Z"
