"""The similarity that places the source's rest on the target's: a deformation gradient is carried
in the frame it was measured in, so both rests are brought into one frame first (see
docs/blender_addon.md, "Transfer Deformation")."""
from collections import namedtuple

import numpy as np

Similarity = namedtuple("Similarity", "scale rotation translation")


def fitted_similarity(points, onto):
    """The rotation R, uniform scale s and translation t minimising sum |s R p + t - q|^2 over
    the pairs (p, q) (Umeyama 1991, "Least-squares estimation of transformation parameters
    between two point patterns", eqs. 40-42): the reflection is excluded."""
    p, q = np.asarray(points, np.float64), np.asarray(onto, np.float64)
    mp, mq = p.mean(0), q.mean(0)
    pc, qc = p - mp, q - mq
    u, d, vt = np.linalg.svd(qc.T @ pc / len(p))
    sign = np.ones(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        sign[2] = -1.0
    rotation = (u * sign) @ vt
    spread = (pc ** 2).sum() / len(p)
    scale = float((d * sign).sum() / spread) if spread > 0 else 1.0
    return Similarity(scale, rotation, mq - scale * rotation @ mp)


def applied(similarity, points):
    return similarity.scale * np.asarray(points, np.float64) @ similarity.rotation.T + similarity.translation
