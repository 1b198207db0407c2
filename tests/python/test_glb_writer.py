"""emdm.writers.glb: the .glb of a generated motion loads in three.js's GLTFLoader (as an app loads it) and its
animation puts every bone where the rig's forward kinematics puts the joint; the container is valid GLB."""

import json
import shutil
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest

import emdm
from emdm import skeleton as sk
from emdm.writers.glb import glb_bytes, write_glb
from emdm.motion.ik import forward_kinematics, solve_ik

CHECK = Path(__file__).with_name("gltf_check.mjs")
FRAMES = [0, 17, 39]


@pytest.fixture(scope="module")
def motion():
    return emdm.generate("a person walks forward", seconds=2, seed=5)


def test_three_gltfloader_plays_the_motion(motion, tmp_path):
    node = shutil.which("node")
    assert node, "node is needed (the project's npm toolchain) to load the GLB with three.js"
    path = write_glb(motion.joints, tmp_path / "walk.glb")
    r = subprocess.run([node, str(CHECK), str(path), str(sk.FPS), *map(str, FRAMES)], capture_output=True, text=True,
                       cwd=Path(__file__).parents[2], timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    out = json.loads(r.stdout)
    assert out["bones"] == list(sk.JOINT_NAMES) and out["animations"] == 1
    assert out["duration"] == pytest.approx((len(motion.joints) - 1) / sk.FPS, abs=1e-6)
    assert len(out["tracks"]) == 1 + sk.NUM_JOINTS            # the pelvis's position, every joint's rotation
    ik = solve_ik(motion.joints)
    rig = forward_kinematics(ik.root, ik.local, ik.offsets)[FRAMES]
    np.testing.assert_allclose(np.array(out["poses"]), rig, atol=1e-4)
    assert np.abs(np.array(out["poses"]) - motion.joints[FRAMES]).max() < 0.02   # the rig follows the joints


def test_glb_container(motion):
    data = glb_bytes(motion.joints)
    magic, version, length = struct.unpack_from("<4sII", data)
    assert (magic, version, length) == (b"glTF", 2, len(data)) and length % 4 == 0
    jlen, jtype = struct.unpack_from("<I4s", data, 12)
    doc = json.loads(data[20:20 + jlen])
    blen, btype = struct.unpack_from("<I4s", data, 20 + jlen)
    assert (jtype, btype) == (b"JSON", b"BIN\0") and jlen % 4 == 0 and 28 + jlen + blen == len(data)
    assert doc["asset"]["version"] == "2.0" and doc["buffers"][0]["byteLength"] <= blen
    assert all(v["byteOffset"] % 4 == 0 for v in doc["bufferViews"])
    pos = doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"]]
    assert len(pos["min"]) == len(pos["max"]) == 3
    t = doc["accessors"][doc["animations"][0]["samplers"][0]["input"]]
    assert t["min"] == [0.0] and t["max"][0] == pytest.approx((len(motion.joints) - 1) / sk.FPS)
    assert doc["skins"][0]["joints"] == list(range(sk.NUM_JOINTS))


@pytest.mark.parametrize("joints, what", [(np.zeros((4, 21, 3)), "shape"), (np.zeros((0, 22, 3)), "shape"),
                                          (np.full((3, 22, 3), np.nan), "NaN")])
def test_bad_joints(joints, what):
    with pytest.raises(ValueError, match=what):
        glb_bytes(joints)
