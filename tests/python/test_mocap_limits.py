"""What one mocap file can make the readers do is bounded (issue 29): a FIFO or folder named .bvh/.asf/.amc is
refused at once (it used to hang the run), and a file too big, a rig with too many joints or bones, or a take
with too many frames or values is refused by name before anything that size is allocated."""

import os
import signal

import numpy as np
import pytest

from emdm.mocap import asfamc, bvh, textfile
from emdm.mocap.errors import MocapFormatError
from test_mocap_asfamc import ASF
from test_mocap_bvh import CHAIN


@pytest.fixture
def no_hang():
    """A reader that blocks fails the test after 5 s instead of hanging it."""
    class Blocked(BaseException):     # not an OSError: the reader must not take it for a read error
        pass

    def boom(*_):
        raise Blocked("the reader blocked for 5 s")
    old = signal.signal(signal.SIGALRM, boom)
    signal.alarm(5)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


@pytest.mark.parametrize("name,read", [
    ("take.bvh", bvh.read_bvh), ("take.bvh", bvh.read_bvh_names), ("s.asf", asfamc.read_asf),
    ("take.amc", lambda p: asfamc.read_amc(p, asfamc.parse_asf_text(ASF.format(length=1, angle="deg", axis90=90)))),
])
def test_a_fifo_or_folder_is_refused_at_once(tmp_path, no_hang, name, read):
    fifo = tmp_path / name
    os.mkfifo(fifo)
    with pytest.raises(MocapFormatError, match="named pipe .FIFO., not a regular file") as e:
        read(fifo)
    assert e.value.path == str(fifo)
    folder = tmp_path / "dir" / name
    folder.mkdir(parents=True)
    with pytest.raises(MocapFormatError, match="is a folder, not a regular file"):
        read(folder)


def test_a_file_over_the_size_limit_is_refused_naming_it(tmp_path, monkeypatch):
    p = tmp_path / "big.bvh"
    p.write_text(CHAIN)
    monkeypatch.setattr(textfile, "MAX_FILE_BYTES", len(CHAIN) - 1)
    with pytest.raises(MocapFormatError, match="MiB one mocap file may have"):
        bvh.read_bvh(p)
    monkeypatch.setattr(textfile, "MAX_FILE_BYTES", len(CHAIN))
    assert bvh.read_bvh(p).num_frames == 3


def _chain_rig(n: int) -> str:
    """A rig whose root has a chain of ``n`` joints, one frame."""
    joints = [f"JOINT j{i}\n{{\nOFFSET 0 1 0\nCHANNELS 1 Zrotation" for i in range(n)]
    return ("HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n" + "\n".join(joints)
            + "\n" + "}\n" * (n + 1) + f"MOTION\nFrames: 2\nFrame Time: 0.1\n" + ("0 " * (n + 3) + "\n") * 2)


def test_too_many_joints_or_too_long_a_hierarchy_is_refused(tmp_path):
    p = tmp_path / "rig.bvh"
    p.write_text(_chain_rig(bvh.MAX_JOINTS - 1))
    b = bvh.read_bvh(p)
    np.testing.assert_allclose(bvh.joint_positions(b, [len(b.names) - 1])[:, 0], [[0, bvh.MAX_JOINTS - 1, 0]] * 2)
    p.write_text(_chain_rig(bvh.MAX_JOINTS))
    for read in (bvh.read_bvh, bvh.read_bvh_names):
        with pytest.raises(MocapFormatError, match=f"more than {bvh.MAX_JOINTS} joints"):
            read(p)
    p.write_text("HIERARCHY\n" + "\n" * bvh.MAX_HIERARCHY_CHARS + CHAIN.split("\n", 1)[1])
    with pytest.raises(MocapFormatError, match="the HIERARCHY is 4.0 MiB, more than"):
        bvh.read_bvh(p)


@pytest.mark.parametrize("frames,needle", [("100001", "100001 frames is more than the 100000"),
                                           ("-1", "'Frames: -1' is negative")])
def test_a_frame_count_beyond_the_limits_is_refused_before_allocating(tmp_path, frames, needle):
    p = tmp_path / "f.bvh"
    p.write_text(CHAIN.replace("Frames: 3", f"Frames: {frames}"))
    with pytest.raises(MocapFormatError, match=needle):
        bvh.read_bvh(p)
    zero = CHAIN.replace("CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation", "CHANNELS 0")
    zero = zero.replace("CHANNELS 3 Zrotation Xrotation Yrotation", "CHANNELS 0")
    zero = zero.replace("CHANNELS 3 Xposition Yposition Zposition", "CHANNELS 0")
    p.write_text(zero.split("Frames:")[0] + f"Frames: {frames}\nFrame Time: 0.1\n")
    with pytest.raises(MocapFormatError, match=needle):      # no channels: nothing in the file bounds the count
        bvh.read_bvh(p)


def test_amc_frames_and_asf_bones_are_bounded(tmp_path, monkeypatch):
    asf = asfamc.parse_asf_text(ASF.format(length=1, angle="deg", axis90=90))
    monkeypatch.setattr(textfile, "MAX_FRAMES", 3)
    frame = "root 0 0 0 0 0 0\nupper 0 0 0\nlower 0 0\n"
    assert asfamc.parse_amc_text("".join(f"{i}\n{frame}" for i in (1, 2, 3)), asf).values["root"].shape == (3, 6)
    with pytest.raises(MocapFormatError, match="4 frames is more than the 3"):
        asfamc.parse_amc_text("".join(f"{i}\n{frame}" for i in (1, 2, 3, 4)), asf, "a.amc")
    bone = "  begin\n name b{i}\n direction 0 1 0\n length 1\n  end\n"
    many = ASF.format(length=1, angle="deg", axis90=90).replace(
        ":hierarchy", "".join(bone.format(i=i) for i in range(asfamc.MAX_BONES)) + ":hierarchy")
    with pytest.raises(MocapFormatError, match=f"more than {asfamc.MAX_BONES} bones"):
        asfamc.parse_asf_text(many, "many.asf")
