"""The reference skeleton: SMPL order, a plausible adult T-pose, exact left/right symmetry."""

import numpy as np

from emdm import manifest
from emdm import skeleton as sk


def test_names_parents_chains_agree():
    assert len(sk.JOINT_NAMES) == 22 == len(sk.PARENTS) == sk.REFERENCE_OFFSETS.shape[0]
    assert sk.PARENTS[0] == -1
    assert all(0 <= p < j for j, p in enumerate(sk.PARENTS) if j > 0), "parents must precede children"
    for chain in sk.KINEMATIC_CHAINS:
        for a, b in zip(chain[:-1], chain[1:]):
            assert sk.PARENTS[b] == a, f"chain {chain}: {sk.JOINT_NAMES[b]} is not a child of {sk.JOINT_NAMES[a]}"
    assert [sk.JOINT_NAMES[j] for j in sk.FOOT_JOINTS] == ["l_ankle", "l_foot", "r_ankle", "r_foot"]
    assert (sk.FPS, sk.MAX_FRAMES, sk.FEATURE_DIM) == (20, 196, 263)


def test_rest_pose_is_an_upright_adult_t_pose_facing_plus_z():
    p = sk.rest_pose()
    assert 0.93 <= p[0, 1] <= 0.95, "pelvis height"
    assert abs(min(p[10, 1], p[11, 1])) < 1e-9, "feet (ball joints) touch the floor"
    assert 1.45 < p[15, 1] < 1.65, "head joint at adult height"
    for n in ("hip", "knee", "ankle", "foot", "collar", "shoulder", "elbow", "wrist"):
        l, r = sk.JOINT_NAMES.index("l_" + n), sk.JOINT_NAMES.index("r_" + n)
        assert p[l, 0] > 0 > p[r, 0], f"{n}: the left side must be at +X"
        np.testing.assert_allclose(p[l] * [-1, 1, 1], p[r], atol=1e-12)
    for n in ("l_elbow", "l_wrist", "r_elbow", "r_wrist"):
        off = sk.REFERENCE_OFFSETS[sk.JOINT_NAMES.index(n)]
        assert off[1] == 0 and off[2] == 0 and abs(off[0]) > 0.2, "arms straight out along X"
    assert p[10, 2] > p[7, 2], "feet point forward (+Z) from the ankles"
    arm_span = p[20, 0] - p[21, 0]
    assert 1.2 < arm_span < 1.6


def test_mirror_permutation_swaps_sides_and_is_an_involution():
    perm = sk.MIRROR_PERMUTATION
    assert sorted(perm) == list(range(22))
    assert [perm[perm[j]] for j in range(22)] == list(range(22))
    for j, n in enumerate(sk.JOINT_NAMES):
        other = sk.JOINT_NAMES[perm[j]]
        if n.startswith("l_"):
            assert other == "r_" + n[2:]
        elif not n.startswith("r_"):
            assert other == n
    p = sk.rest_pose()
    np.testing.assert_allclose(sk.mirror_joints(p), p, atol=1e-12)  # the T-pose is symmetric


def test_manifest_skeleton_entry_reads_the_module():
    e = manifest.skeleton_entry()
    assert e["joints"] == sk.JOINT_NAMES and e["footJoints"] == [7, 10, 8, 11]
    assert np.allclose(e["offsets"], sk.REFERENCE_OFFSETS, atol=1e-6)


def test_the_shipped_manifest_carries_this_skeleton():
    """public/models/manifest.json is what the page reads (tests/unit/coreSkeleton.test.ts checks src/skeleton.ts
    against it): it must hold this module's skeleton, so Python and TypeScript agree through it."""
    from emdm import paths

    shipped = manifest.load(paths.MODELS_DIR, missing_ok=True)["skeleton"]
    want = manifest.skeleton_entry()
    assert shipped == want, ("public/models/manifest.json skeleton differs from emdm.skeleton: "
                             f"{sorted(k for k in want if shipped.get(k) != want[k])}; rewrite the manifest with emdm.manifest")
