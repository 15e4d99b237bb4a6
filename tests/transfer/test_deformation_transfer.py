"""dk.DeformationTransfer (same connectivity) on Sumner's horse: the rest pose transfers to the
target rest, a source equal to the target reproduces all ten poses, the poses transfer onto another
horse without folding its triangles, triangles the target shares with the source take the source's
gradients, a translated target gives translated poses, several poses at once equal one at a time,
bad input refused."""
import numpy as np
import pytest

import deformkit as dk
from transfer_files import frames, load, normals


@pytest.fixture(scope="module")
def horse():
    rest, faces = load("horse_ref")
    poses = np.stack([load(f"horse-{i:02d}")[0] for i in range(1, 11)])
    return rest, faces, poses


def other_horse(rest):
    """Another character on the horse's mesh: a longer, heavier-bodied horse (a smooth non-affine map)."""
    centre = rest.mean(0)
    p = rest - centre
    size = np.abs(p).max()
    u = p / size
    return centre + size * np.stack([1.25 * u[:, 0] + 0.1 * u[:, 1] ** 2, u[:, 1] * (1 + 0.3 * np.exp(-4 * u[:, 0] ** 2)),
                                     u[:, 2] * (1 + 0.2 * np.exp(-4 * u[:, 0] ** 2))], 1)


def test_the_rest_pose_transfers_to_the_target_rest(horse):
    rest, faces, _ = horse
    target = other_horse(rest)
    dt = dk.DeformationTransfer(rest, faces, target)
    assert np.abs(dt.transfer(rest) - target).max() < 1e-10 * np.abs(target).max()


def test_a_source_equal_to_the_target_reproduces_every_pose(horse):
    rest, faces, poses = horse
    dt = dk.DeformationTransfer(rest, faces, rest)
    out = dt.transfer(poses)
    assert out.shape == poses.shape
    assert np.abs(out - poses).max() < 1e-8 * np.abs(rest).max()


def test_poses_transfer_onto_another_horse_nearly_without_folds(horse):
    """A folded triangle faces against its target-rest normal turned by its source partner's
    rotation (the polar factor of the source's deformation gradient): an independent truth of
    which way it should face. Measured: 1 of 16,843 triangles folded, in pose 6 (a least-squares
    fit of gradients does not forbid folds); the median agreement is 1.0000."""
    rest, faces, poses = horse
    target = other_horse(rest)
    out = dk.DeformationTransfer(rest, faces, target).transfer(poses)
    inverse = np.linalg.inv(frames(rest, faces))
    for k in range(len(poses)):
        u, _, vt = np.linalg.svd(frames(poses[k], faces) @ inverse)
        expected = np.einsum("tij,tj->ti", u @ vt, normals(target, faces))
        agree = (normals(out[k], faces) * expected).sum(1)
        assert (agree <= 0).sum() <= max(1, 1e-4 * len(faces)), f"pose {k + 1}: {(agree <= 0).sum()} folded"
        assert np.median(agree) > 0.999


def test_gradients_match_the_sources_where_the_target_triangle_is_the_sources(horse):
    """A target that is the horse at the back and reshaped towards the front: on the 7,955
    triangles left as the horse's, the transferred gradient (the posed target's frames over its
    rest frames) is the source's. Measured: median relative error 3e-6 to 1.1e-5 over the poses,
    at most 4.2% beside the reshaped part, which pulls on them through the shared vertices."""
    rest, faces, poses = horse
    w = np.clip((rest[:, 2] - 0.1) / 0.2, 0, 1)
    w = w * w * (3 - 2 * w)
    target = rest + w[:, None] * (other_horse(rest) - rest)
    kept = (w[faces] == 0).all(1)
    assert kept.sum() > 0.4 * len(faces)
    out = dk.DeformationTransfer(rest, faces, target).transfer(poses)
    for k in range(len(poses)):
        source = frames(poses[k], faces) @ np.linalg.inv(frames(rest, faces))
        moved = frames(out[k], faces) @ np.linalg.inv(frames(target, faces))
        error = (np.linalg.norm(moved - source, axis=(1, 2)) / np.linalg.norm(source, axis=(1, 2)))[kept]
        assert np.median(error) < 1e-4 and error.max() < 0.06, (k, np.median(error), error.max())


def test_a_translated_target_gives_the_same_shape_translated(horse):
    """Gradients do not see a translation: moving the target rest moves every transferred pose by
    the same vector, to rounding. (Rotating the target alone is not such a symmetry: the source's
    gradients act in world axes, as in Sumner and Popovic; rotating the source, its poses and the
    target together is, cpp/tests/transfer RotatingTheWholeSetupRotatesTheResult.)"""
    rest, faces, poses = horse
    target = other_horse(rest)
    shift = np.array([3.0, -2.0, 0.5])
    out = dk.DeformationTransfer(rest, faces, target).transfer(poses)
    moved = dk.DeformationTransfer(rest, faces, target + shift).transfer(poses)
    assert np.abs(moved - (out + shift)).max() < 1e-10


def test_several_poses_at_once_equal_one_at_a_time(horse):
    rest, faces, poses = horse
    dt = dk.DeformationTransfer(rest, faces, other_horse(rest))
    both = dt.transfer(poses[:3])
    for k in range(3):
        assert np.abs(both[k] - dt.transfer(poses[k])).max() < 1e-12 * np.abs(rest).max()


def test_bad_input_is_refused_by_name():
    grid = np.array([[x, y, 0.1 * x * y] for y in range(3) for x in range(3)], float)
    quads = np.array([[0, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6], [4, 5, 8, 7]])
    with pytest.raises(ValueError, match="^target_points: expected 9 points"):
        dk.DeformationTransfer(grid, quads, grid[:5])
    with pytest.raises(ValueError, match="^markers: the meshes differ .target_faces is not source_faces., so the transfer needs"):
        dk.DeformationTransfer(grid, quads, grid, quads[:, ::-1])
    with pytest.raises(ValueError, match="^markers: the meshes share their faces .same connectivity"):
        dk.DeformationTransfer(grid, quads, grid, markers=([0], [0]))
    dt = dk.DeformationTransfer(grid, quads, grid * 2)
    with pytest.raises(ValueError, match=r"^source_pose: expected shape \(9, 3\) or \(k, 9, 3\)"):
        dt.transfer(grid[:4])
    flat = grid.copy()
    flat[1] = flat[0]
    with pytest.raises(ValueError, match="^source_pose: pose 0 collapses triangle 0"):
        dt.transfer(flat)
    with pytest.raises(ValueError, match="^target_faces: triangle 0"):
        dk.DeformationTransfer(grid, quads, flat)
    with pytest.raises(TypeError, match="^source_pose: expected float32 or float64, got int64"):
        dt.transfer(grid.astype(np.int64))
    assert np.array_equal(dt.transfer(grid.astype(">f8")), dt.transfer(grid))  # any float layout
    assert dt.transfer(np.zeros((0, 9, 3))).shape == (0, 9, 3)
    x = grid.copy()
    dt.transfer(x)
    assert np.array_equal(x, grid)  # the pose is not modified
