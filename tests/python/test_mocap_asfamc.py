"""ASF/AMC reader + forward kinematics: known poses -> known joints, units, dof order, errors."""

import numpy as np
import pytest

from emdm import paths
from emdm.mocap import asfamc
from emdm.mocap.errors import MocapFormatError

ASF = """# test skeleton
:version 1.10
:name test
:units
  mass 1.0
  length {length}
  angle {angle}
:root
   order TX TY TZ RX RY RZ
   axis XYZ
   position 0 0 0
   orientation 0 0 0
:bonedata
  begin
     id 1
     name upper
     direction 0 1 0
     length 10
     axis 0 0 0  XYZ
    dof rx ry rz
  end
  begin
     id 2
     name lower
     direction 1 0 0
     length 5
     axis 0 0 {axis90} XYZ
    dof rz rx
  end
:hierarchy
  begin
    root upper
    upper lower
  end
"""

AMC = """:FULLY-SPECIFIED
:{unit}
1
root 0 0 0 0 0 0
upper 0 0 0
lower 0 0
2
root 1 2 3 0 0 {a90}
upper 0 0 0
lower 0 0
3
root 0 0 0 0 0 0
upper 0 0 0
lower {a90} 0
4
root 0 0 0 0 0 0
upper 0 0 0
lower 0 {a90}
"""

EXPECTED = np.array([
    [[0, 0, 0], [0, 10, 0], [5, 10, 0]],
    [[1, 2, 3], [-9, 2, 3], [-9, 7, 3]],     # root turned 90 deg about Z
    [[0, 0, 0], [0, 10, 0], [0, 15, 0]],     # lower: rz = 90 (its first dof value)
    [[0, 0, 0], [0, 10, 0], [0, 10, -5]],    # lower: rx = 90 about its axis frame C = Rz(90)
], dtype=float)


def _write(tmp_path, angle="deg", length="1.0"):
    a90 = "90" if angle == "deg" else f"{np.pi / 2:.12f}"
    (tmp_path / "t.asf").write_text(ASF.format(length=length, angle=angle, axis90=a90))
    (tmp_path / "t_01.amc").write_text(AMC.format(unit="DEGREES" if angle == "deg" else "RADIANS", a90=a90))
    return tmp_path / "t.asf", tmp_path / "t_01.amc"


@pytest.mark.parametrize("angle", ["deg", "rad"])
def test_fk_known_poses_in_file_units(tmp_path, angle):
    asf_p, amc_p = _write(tmp_path, angle)
    asf = asfamc.read_asf(asf_p)
    assert asf.order() == ["upper", "lower"] and asf.bones["lower"].dof == ["rz", "rx"]
    names, pos = asfamc.forward_kinematics(asf, asfamc.read_amc(amc_p, asf), length_scale=1.0)
    assert names == ["root", "upper", "lower"]
    np.testing.assert_allclose(pos, EXPECTED, atol=1e-9)


def test_default_units_are_asf_length_inches_to_metres(tmp_path):
    asf_p, amc_p = _write(tmp_path, length="0.45")
    asf = asfamc.read_asf(asf_p)
    _, pos = asfamc.forward_kinematics(asf, asfamc.read_amc(amc_p, asf))
    np.testing.assert_allclose(pos, EXPECTED / 0.45 * 0.0254, atol=1e-12)


@pytest.mark.parametrize("old,new,line,needle", [
    ("lower 90 0\n4", "lower 90\n4", 14, "has 1 values, expected 2"),
    ("upper 0 0 0\nlower 0 0\n2", "upper 0 0 0\nelbow 0 0\n2", 6, "bone 'elbow' is not in the skeleton"),
    ("3\nroot 0 0 0 0 0 0\nupper 0 0 0\nlower 90 0", "3\nroot 0 0 0 0 0 0\nlower 90 0", 11, "has no line for bone 'upper'"),
    ("root 1 2 3 0 0 90", "root 1 2 three 0 0 90", 8, "expected a number"),
])
def test_malformed_amc_reports_file_and_line(tmp_path, old, new, line, needle):
    asf_p, amc_p = _write(tmp_path)
    text = amc_p.read_text()
    assert old in text
    amc_p.write_text(text.replace(old, new))
    asf = asfamc.read_asf(asf_p)
    with pytest.raises(MocapFormatError) as e:
        asfamc.read_amc(amc_p, asf)
    assert e.value.line == line and e.value.path == str(amc_p), str(e.value)
    assert needle in str(e.value)


@pytest.mark.parametrize("old,new,line,needle", [
    ("root 1 2 3 0 0 90", "root 1 nan 3 0 0 90", 8, "'nan' is not a finite number"),
    ("root 1 2 3 0 0 90", "root 1 2 3 0 0 -inf", 8, "'-inf' is not a finite number"),
    ("lower 90 0\n4", "lower 1e308 0\n4", 14, "out of range"),
])
def test_non_finite_and_absurd_amc_values_report_the_line(tmp_path, old, new, line, needle):
    asf_p, amc_p = _write(tmp_path)
    amc_p.write_text(amc_p.read_text().replace(old, new))
    with pytest.raises(MocapFormatError) as e:
        asfamc.read_amc(amc_p, asfamc.read_asf(asf_p))
    assert e.value.line == line and needle in str(e.value), str(e.value)


def test_a_position_that_overflows_after_scaling_is_refused(tmp_path):
    """1e308 inches in the root's tx is finite in the file; in metres its square is inf (Mean/Std NaN)."""
    from emdm.mocap.jointmap import load_joint_map
    from emdm.mocap.load import load_amc_clip

    asf_p, amc_p = _write(tmp_path)
    amc_p.write_text(amc_p.read_text().replace("root 1 2 3 0 0 90", "root 1e308 2 3 0 0 90"))
    jm = load_joint_map("cmu_asfamc")
    jm.joints = {n: ("lower" if n.startswith("l") else "upper") for n in jm.joints}
    with pytest.raises(MocapFormatError, match="out of range") as e:
        load_amc_clip(amc_p, asfamc.read_asf(asf_p), jm)
    assert e.value.path == str(amc_p)


def test_missing_asf_names_the_file_it_looked_for(tmp_path):
    from emdm.mocap.load import find_asf

    (tmp_path / "take.amc").write_text("")
    with pytest.raises(MocapFormatError, match=r"take\.asf") as e:
        find_asf(tmp_path / "take.amc")
    assert "(tried )" not in str(e.value)
    (tmp_path / "a.asf").write_text("")
    (tmp_path / "b.asf").write_text("")
    with pytest.raises(MocapFormatError, match="2 .asf files"):
        find_asf(tmp_path / "take.amc")
    (tmp_path / "take.asf").write_text("")
    assert find_asf(tmp_path / "take.amc") == tmp_path / "take.asf"


@pytest.mark.parametrize("old,new,needle", [
    ("axis 0 0 0  XYZ", "axis 0 0 0", "expected 'axis ax ay az ORDER'"),
    ("    upper lower", "    upper forearm", "names bone 'forearm'"),
    ("angle deg", "angle grad", "expected ':units angle deg'"),
    ("dof rz rx", "dof rz rw", "unknown dof 'rw'"),
])
def test_malformed_asf_reports_file_and_line(tmp_path, old, new, needle):
    asf_p, _ = _write(tmp_path)
    text = asf_p.read_text()
    asf_p.write_text(text.replace(old, new))
    line = next(i for i, l in enumerate(asf_p.read_text().splitlines(), 1) if new.strip() in l)
    with pytest.raises(MocapFormatError) as e:
        asfamc.read_asf(asf_p)
    assert e.value.line == line and needle in str(e.value), str(e.value)


SHARED = paths.shared_data_dir()


@pytest.mark.skipif(not (SHARED / "hdm05-subset.tar.xz").is_file(),
                    reason=f"real mocap not found: {SHARED}/hdm05-subset.tar.xz "
                           "(put ../shared/data beside the checkout or set EMDM_SHARED_DATA)")
def test_real_hdm05_clip_is_a_standing_adult_in_metres():
    from emdm.data.unpack import unpack_archive

    root = unpack_archive(SHARED / "hdm05-subset.tar.xz")
    amc = sorted(root.rglob("HDM_bd_squat1Reps_*_120.amc"))[0]
    asf = asfamc.read_asf(amc.parent / "HDM_bd.asf")
    names, pos = asfamc.forward_kinematics(asf, asfamc.read_amc(amc, asf))
    head, lfoot = pos[0, names.index("head")], pos[0, names.index("lfoot")]
    assert 1.4 < head[1] - lfoot[1] < 1.9, "head top above the foot, metres, Y up"
    femur = np.linalg.norm(pos[:, names.index("lfemur")] - pos[:, names.index("lhipjoint")], axis=-1)
    np.testing.assert_allclose(femur, asf.bones["lfemur"].length / 0.45 * 0.0254, rtol=1e-9)
    hips_y = pos[:, 0, 1]
    assert hips_y.min() < hips_y[0] - 0.2, "a squat lowers the pelvis"
