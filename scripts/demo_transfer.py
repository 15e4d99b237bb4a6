"""Deformation transfer between unlike meshes: Sumner's horse poses onto the camel.

    .venv/bin/python scripts/demo_transfer.py --out demo_out/transfer

With ../shared/transfer present: the correspondence phase from the horse to the camel under the
paper's 107 markers, then the ten horse poses transferred at once; writes <out>/camel-01.obj ..
camel-10.obj and two pictures, <out>/horse_camel_poses_1-5.png and _6-10.png (the horse poses
above, the camel's below), and prints the figures. Without it a built-in pair stands in: a tube
bent by deformkit's ARAP, transferred onto a thicker, waisted tube of another triangulation
(<out>/tube_transfer.png).
"""
import argparse
import sys
import time
from pathlib import Path

import numpy as np
import trimesh

import deformkit as dk
from deformkit.preview import AFTER_COLOR, BEFORE_COLOR, atomic_write, render_panels

ROOT = Path(__file__).resolve().parent.parent
SHARED = (ROOT.parent / "shared").resolve()
TRANSFER = SHARED / "transfer"


def load(name):
    mesh = trimesh.load(TRANSFER / f"{name}.obj", process=False, force="mesh")
    return np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)


def write_obj(path, points, faces, header):
    text = trimesh.exchange.obj.export_obj(trimesh.Trimesh(points, faces, process=False), include_normals=False,
                                           include_texture=False, header=header)
    atomic_write(path, lambda fh: fh.write(text.encode()))


def pose_pictures(out, stem, sources, source_faces, targets, target_faces, numbers, title, source_name, target_name):
    """One picture per five poses: the source's in a row above, the target's below."""
    paths = []
    for start in range(0, len(numbers), 5):
        chunk = numbers[start:start + 5]
        meshes = [sources[k] for k in chunk] + [targets[k] for k in chunk]
        path = out / f"{stem}_{chunk[0] + 1}-{chunk[-1] + 1}.png"
        render_panels(path, meshes, source_faces, title,
                      [f"{source_name} pose {k + 1}" for k in chunk] + [f"{target_name}, transferred" for k in chunk],
                      5.0, 0.0, panel_faces=[None] * len(chunk) + [target_faces] * len(chunk),
                      colors=[BEFORE_COLOR] * len(chunk) + [AFTER_COLOR] * len(chunk), columns=len(chunk))
        paths.append(path)
    return paths


def horse_camel(out):
    horse, horse_faces = load("horse_ref")
    camel, camel_faces = load("camel_ref")
    pairs = np.loadtxt(TRANSFER / "horse_camel.cons", delimiter=",", skiprows=1, dtype=np.int64)
    poses = np.stack([load(f"horse-{i:02d}")[0] for i in range(1, 11)])
    t0 = time.perf_counter()
    dt = dk.DeformationTransfer(horse, horse_faces, camel, camel_faces, markers=(pairs[:, 0], pairs[:, 1]))
    t_build = time.perf_counter() - t0
    t0 = time.perf_counter()
    camels = dt.transfer(poses)
    t_poses = time.perf_counter() - t0
    diagonal = np.linalg.norm(np.ptp(camel, 0))
    mean, worst = dt.correspondence_distance
    print(f"transfer:      horse ({len(horse):,} vertices, {len(horse_faces):,} triangles) -> camel "
          f"({len(camel):,} vertices, {len(camel_faces):,} triangles), {len(pairs)} markers")
    print(f"               correspondence and factorisation {t_build:.2f} s: {len(dt.correspondence):,} triangle pairs, "
          f"{len(dt.unmatched_target_triangles)} camel triangles unpaired, fitted horse to camel "
          f"mean {mean / diagonal:.2%}, max {worst / diagonal:.2%} of the diagonal")
    print(f"               ten poses at once {t_poses * 1e3:.1f} ms")
    for k, pose in enumerate(camels):
        write_obj(out / f"camel-{k + 1:02d}.obj", pose, camel_faces, f"deformkit: horse-{k + 1:02d} transferred onto the camel")
    paths = pose_pictures(out, "horse_camel_poses", poses, horse_faces, camels, camel_faces, list(range(10)),
                          "deformkit DeformationTransfer: Sumner's horse poses (above) onto the camel (below), "
                          f"{len(pairs)} markers", "horse", "camel")
    print(f"wrote:         {out / 'camel-01.obj'} .. camel-10.obj\n               " + "\n               ".join(map(str, paths)))


def tube(rings, segments, length, radius):
    """A closed tube along z; radius(z) may vary."""
    theta = 2 * np.pi * np.arange(segments) / segments
    z = np.linspace(0, length, rings)
    side = np.array([[radius(h) * np.cos(t), radius(h) * np.sin(t), h] for h in z for t in theta])
    points = np.vstack([side, [[0, 0, 0], [0, 0, length]]])
    faces = []
    for r in range(rings - 1):
        for s in range(segments):
            a, b = r * segments + s, r * segments + (s + 1) % segments
            faces += [[a, b, b + segments], [a, b + segments, a + segments]]
    for s in range(segments):
        faces += [[len(side), (s + 1) % segments, s], [len(side) + 1, (rings - 1) * segments + s, (rings - 1) * segments + (s + 1) % segments]]
    return points, np.array(faces)


def builtin(out):
    source, source_faces = tube(25, 16, 4.0, lambda z: 0.4)
    target, target_faces = tube(33, 22, 4.0, lambda z: 0.55 - 0.15 * np.sin(np.pi * z / 4))
    bottom, top = np.where(source[:, 2] < 1e-9)[0], np.where(source[:, 2] > 4 - 1e-9)[0]
    arap = dk.SurfaceDeformer(source, source_faces, anchors=bottom, handles=top, method="arap", iterations=30)
    poses = []
    for angle, side in ((30, 0.6), (60, 1.2), (90, 1.8)):
        a = np.radians(angle)
        turn = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
        centre = source[top].mean(0)
        poses.append(arap.deform((source[top] - centre) @ turn.T + centre + [0, -side, -0.3 * side]))
    rings = [source[:, 2] > 4 - 1e-9, source[:, 2] < 1e-9, np.abs(source[:, 2] - 2) < 1e-9]
    ids = np.concatenate([np.where(r)[0][::4] for r in rings])
    chosen = [int(np.argmin(np.linalg.norm(target - source[i] * [1.3, 1.3, 1], axis=1))) for i in ids]
    dt = dk.DeformationTransfer(source, source_faces, target, target_faces, markers=(ids, chosen))
    targets = dt.transfer(np.stack(poses))
    path = pose_pictures(out, "tube_transfer", poses, source_faces, targets, target_faces, [0, 1, 2],
                         "deformkit DeformationTransfer (built-in pair): a tube's ARAP poses onto a waisted tube "
                         "of another triangulation", "tube", "waisted tube")[0]
    print(f"transfer:      built-in tubes ({len(source_faces)} -> {len(target_faces)} triangles), "
          f"{len(dt.unmatched_target_triangles)} target triangles unpaired\nwrote:         {path}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="demo_out/transfer", help="output directory (created if missing)")
    args = ap.parse_args()
    out = Path(args.out).resolve()
    if out == SHARED or SHARED in out.parents:
        sys.exit(f"demo_transfer: refusing to write into {SHARED} (shared, read-only data); choose another --out")
    out.mkdir(parents=True, exist_ok=True)
    if TRANSFER.is_dir():
        horse_camel(out)
    else:
        print(f"note:          {TRANSFER} not found: the built-in tubes stand in for the horse and camel")
        builtin(out)


if __name__ == "__main__":
    main()
