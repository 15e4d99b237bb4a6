"""Before/after pictures of meshes with matplotlib (Agg): flat-shaded triangles, no GPU needed.
Used by the demo and by the batch command; matplotlib is needed only when this is imported."""
import math
import os
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

MAX_DRAWN_FACES = 150_000  # 124k faces draw in about a second
Y_UP = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])  # OBJ files are y-up, the plot z-up
Z_UP = np.eye(3)  # Blender


def atomic_write(path, write):
    """Write to a temporary file in the same directory, then rename over `path`."""
    path = os.fspath(path)
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(path) or ".", prefix=f".{os.path.basename(path)}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            write(fh)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give the usual permissions
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def decimate(vertices, faces, max_faces):
    """Vertex clustering for drawing only: returns (kept vertex ids, faces into them)."""
    if len(faces) <= max_faces:
        return np.arange(len(vertices)), faces
    lo, size = vertices.min(axis=0), np.ptp(vertices, axis=0).max() / 200
    while True:
        cells = np.floor((vertices - lo) / size).astype(np.int64)
        _, rep, inverse = np.unique(cells, axis=0, return_index=True, return_inverse=True)
        f = inverse.reshape(-1)[faces]
        f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
        f = f[np.unique(np.sort(f, axis=1), axis=0, return_index=True)[1]]
        if len(f) <= max_faces:
            return rep, f
        size *= 1.2


def _draw(ax, vertices, faces, color, view, light, limits, title, to_plot):
    tri = (vertices @ to_plot.T)[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    front = n @ view > 0  # back faces are hidden anyway; culling them helps the painter's sort
    shade = 0.3 + 0.7 * np.clip(n[front] @ light, 0, 1)
    if color.ndim == 2:  # one colour per vertex: each face takes its vertices' mean
        rgb = np.clip(shade[:, None] * color[faces[front]].mean(axis=1), 0, 1)
    else:
        rgb = np.clip(np.outer(shade, color), 0, 1)
    ax.add_collection3d(Poly3DCollection(tri[front], facecolors=rgb, edgecolors=rgb, linewidths=0.15))
    for set_lim, (a, b) in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), limits):
        set_lim(a, b)
    ax.set_box_aspect((1, 1, 1), zoom=1.45)
    ax.set_axis_off()
    ax.set_title(title, fontsize=11)


def render_before_after(path, before, after, faces, title, labels=("before", "after"), elev=15.0, azim=-60.0,
                        to_plot=Y_UP, after_faces=None):
    """Write a PNG with `before` and `after` (same triangles `faces`, or `after_faces` for a mesh of
    another topology, such as a subdivided one) side by side."""
    render_panels(path, [before, after], faces, title, labels, elev, azim, to_plot,
                  panel_faces=[None, after_faces])


BEFORE_COLOR, AFTER_COLOR = (0.55, 0.65, 0.85), (0.95, 0.62, 0.35)


def render_panels(path, meshes, faces, title, labels, elev=15.0, azim=-60.0, to_plot=Y_UP, panel_faces=None,
                  colors=None, columns=None):
    """Write a PNG with the meshes side by side (rows of `columns`, default all in one row), all in
    one frame and one view so that they compare: the first in the "before" colour, the others in the
    "after" one unless `colors` are given (an RGB triple per panel, or an (n, 3) array of one per
    vertex). Each mesh uses the triangles `faces`, or its own in `panel_faces` (None: `faces`)."""
    faces = np.asarray(faces)
    panel_faces = panel_faces or [None] * len(meshes)
    colors = colors or [BEFORE_COLOR] + [AFTER_COLOR] * (len(meshes) - 1)
    columns = columns or len(meshes)
    rows = -(-len(meshes) // columns)
    shared = decimate(meshes[0], faces, MAX_DRAWN_FACES)
    drawn = [shared if own is None else decimate(v, np.asarray(own), MAX_DRAWN_FACES)
             for v, own in zip(meshes, panel_faces)]
    every = np.vstack(meshes) @ to_plot.T
    mid, half = (every.min(axis=0) + every.max(axis=0)) / 2, np.ptp(every, axis=0).max() / 2 * 1.02
    limits = [(m - half, m + half) for m in mid]
    e, a = math.radians(elev), math.radians(azim)
    view = np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])
    light = view + np.array([0.0, 0.0, 1.0]) + 0.6 * np.cross([0.0, 0.0, 1.0], view)
    light /= np.linalg.norm(light)
    # Two panels in one row keep the before/after pictures' historical 13 x 6.8 inches.
    height = 6.8 + 5.8 * (rows - 1)  # inches; the title keeps 0.952 of them at the top
    fig = plt.figure(figsize=(6.5 * columns, height), dpi=100)
    f = shared[1]
    note = f"{len(f):,} faces drawn" + ("" if len(f) == len(faces) else f" of {len(faces):,}")
    for i, (v, (k, tri), color, label) in enumerate(zip(meshes, drawn, colors, labels)):
        ax = fig.add_subplot(rows, columns, i + 1, projection="3d", proj_type="ortho")
        ax.view_init(elev=elev, azim=azim)
        color = np.asarray(color, dtype=np.float64)
        _draw(ax, v[k], tri, color[k] if color.ndim == 2 else color, view, light, limits, label, to_plot)
    fig.suptitle(f"{title}\n({note})", fontsize=10)
    fig.subplots_adjust(left=0, right=1, bottom=0, top=1 - 0.952 / height, wspace=0, hspace=0.05)
    atomic_write(path, lambda fh: fig.savefig(fh, format="png"))
    plt.close(fig)
