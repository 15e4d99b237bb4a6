"""Lattices you can trust: a folded lattice flagged by its certificate, and a volume-preserving edit.

    .venv/bin/python scripts/demo_lattice_bounds.py --out demo_out/lattice_bounds

Module only, no Blender. Writes <out>/folded_lattice.png: a B-spline lattice with one control
point pulled through its neighbour, a slice through it coloured by the volume ratio det J (red
where it is <= 0), and the cells `fold_free` reports outlined; and <out>/volume_preserving.png: a
sphere's top pulled up by direct manipulation, plainly and with preserve_volume (its volume kept).
Prints the certificate, the bounds and the volumes (docs/lattice.md, docs/math/lattice.md).
"""
import argparse
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import deformkit as dk  # noqa: E402
from deformkit.preview import AFTER_COLOR, BEFORE_COLOR, render_panels  # noqa: E402

RESOLUTION = 5  # B-spline control points per axis: 2 spans inside the box


def folded_lattice():
    """A unit-cube B-spline lattice whose middle points (3 x 3 of the middle layer) are pulled
    through their neighbours along x."""
    lattice = dk.BSplineLattice(RESOLUTION, origin=(0.0, 0.0, 0.0), edges=np.eye(3))
    control = lattice.control_points
    middle = RESOLUTION // 2
    control[middle, middle - 1:middle + 2, middle - 1:middle + 2, 0] = 1.0
    lattice.control_points = control
    return lattice


def span_box(cell, n=RESOLUTION):
    """(lo, hi) of a B-spline span in the unit cube: span c covers the interval c + 1 of n - 1."""
    cell = np.asarray(cell, float)
    return (cell + 1) / (n - 1), (cell + 2) / (n - 1)


def draw_folded(ax, lattice, certificate, z):
    """The slice z = const of the lattice's inner domain, deformed, coloured by det J."""
    lo, hi = 1 / (RESOLUTION - 1), (RESOLUTION - 2) / (RESOLUTION - 1)
    s = np.linspace(lo, hi, 161)
    x, y = np.meshgrid(s, s, indexing="ij")
    rest = np.stack([x.ravel(), y.ravel(), np.full(x.size, z)], axis=1)
    moved = lattice.deform(rest)
    ratio = lattice.volume_ratio(rest)
    limit = np.abs(ratio).max()
    shown = ax.scatter(moved[:, 0], moved[:, 1], c=ratio, s=3, cmap="RdBu", vmin=-limit, vmax=limit,
                       linewidths=0)
    ax.scatter(*moved[ratio <= 0][:, :2].T, s=3, c="#d62728", linewidths=0, label="det J <= 0")
    for line in np.linspace(lo, hi, 3):  # the span boundaries, deformed
        t = np.linspace(lo, hi, 200)
        for across in (np.stack([np.full_like(t, line), t, np.full_like(t, z)], 1),
                       np.stack([t, np.full_like(t, line), np.full_like(t, z)], 1)):
            ax.plot(*lattice.deform(across)[:, :2].T, color="0.35", lw=0.8)
    for cell, _where, _lower in certificate.cells:
        a, b = span_box(cell)
        if not a[2] <= z <= b[2]:
            continue
        t = np.linspace(0, 1, 100)
        edge = np.concatenate([np.stack([a[0] + (b[0] - a[0]) * t, np.full_like(t, a[1])], 1),
                               np.stack([np.full_like(t, b[0]), a[1] + (b[1] - a[1]) * t], 1),
                               np.stack([b[0] - (b[0] - a[0]) * t, np.full_like(t, b[1])], 1),
                               np.stack([np.full_like(t, a[0]), b[1] - (b[1] - a[1]) * t], 1)])
        outline = lattice.deform(np.column_stack([edge, np.full(len(edge), z)]))
        ax.plot(*outline[:, :2].T, color="black", lw=2.2)
    control = lattice.control_points[:, :, RESOLUTION // 2]
    ax.plot(*control[..., :2].reshape(-1, 2).T, "o", color="0.1", ms=3)
    ax.set_aspect("equal")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    return shown


def sphere(rings=24, segments=48):
    """A closed UV sphere of radius 0.3 around (0.5, 0.5, 0.5): points and outward triangles."""
    theta = np.linspace(0, np.pi, rings + 1)[1:-1]
    phi = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    points = np.column_stack([np.sin(t).ravel() * np.cos(p).ravel(), np.sin(t).ravel() * np.sin(p).ravel(),
                              np.cos(t).ravel()])
    points = np.vstack([[0, 0, 1], points, [0, 0, -1]]) * 0.3 + 0.5
    ring = 1 + np.arange((rings - 1) * segments).reshape(rings - 1, segments)
    faces = [(0, a, b) for a, b in zip(ring[0], np.roll(ring[0], -1))]
    for i in range(rings - 2):
        for a, b, c, d in zip(ring[i], np.roll(ring[i], -1), np.roll(ring[i + 1], -1), ring[i + 1]):
            faces += [(a, d, c), (a, c, b)]
    last = len(points) - 1
    faces += [(last, b, a) for a, b in zip(ring[-1], np.roll(ring[-1], -1))]
    return points, np.array(faces)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="demo_out/lattice_bounds")
    args = parser.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    lattice = folded_lattice()
    certificate = lattice.fold_free()
    lower, upper = lattice.volume_ratio_bounds()
    rest = dk.BSplineLattice(RESOLUTION, origin=(0.0, 0.0, 0.0), edges=np.eye(3)).deformed_volume()
    print(f"folded lattice: fold_free {bool(certificate)}, {len(certificate.cells)} cells flagged "
          f"({sum(certificate.folded)} with det J <= 0 found); volume ratio in [{lower:.3f}, {upper:.3f}]; "
          f"deformed volume of the inner region {lattice.deformed_volume():.4f} (rest {rest:.4f})")
    fig, axes = plt.subplots(1, 2, figsize=(13, 6.8))
    for ax, z in zip(axes, (0.5, 0.62)):
        shown = draw_folded(ax, lattice, certificate, z)
        ax.set_title(f"slice z = {z}: det J coloured, flagged cells outlined")
    fig.colorbar(shown, ax=axes, shrink=0.8, label="volume ratio det J")
    fig.suptitle(f"A B-spline lattice folded (3 x 3 middle points pulled through their neighbours): fold_free is "
                 f"{bool(certificate)}, det J >= {lower:.2f}")
    path = out / "folded_lattice.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    print(f"wrote {path}")

    points, faces = sphere()
    volume = dk.mesh_volume(points, faces)
    handles = np.flatnonzero(points[:, 2] > 0.5 + 0.27)
    targets = points[handles] + (0.0, 0.0, 0.18)
    results = []
    for preserve in (None, (points, faces)):
        lattice = dk.BSplineLattice(4, origin=(0.1, 0.1, 0.1), edges=0.8 * np.eye(3))
        kwargs = {} if preserve is None else {"preserve_volume": preserve}
        solved = lattice.direct_manipulation(points[handles], targets, **kwargs)
        lattice.control_points = solved.control_points
        moved = lattice.deform(points)
        change = dk.mesh_volume(moved, faces) / volume - 1
        reach = np.abs(moved[handles] - targets).max()
        results.append((moved, change, reach))
        print(f"{'preserve_volume' if preserve else 'plain':>15}: volume {100 * change:+.6f} %, "
              f"handles within {reach:.2g} of their targets")
    (plain, plain_change, _), (kept, kept_change, _) = results
    path = out / "volume_preserving.png"
    render_panels(path, [points, plain, kept], faces,
                  "direct manipulation pulling a sphere's top up, plainly and with preserve_volume",
                  ["the sphere", f"plain: volume {100 * plain_change:+.1f} %",
                   f"preserve_volume: {100 * kept_change:+.1e} %"],
                  colors=[BEFORE_COLOR, AFTER_COLOR, AFTER_COLOR], to_plot=np.eye(3), elev=10.0)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
