"""Shared test helpers (importable by name, unlike conftest)."""
import numpy as np


def random_frame(rng):
    """A rotation times a non-uniform scale plus a translation, as a 4x4 matrix."""
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    if np.linalg.det(q) < 0:
        q[:, 0] *= -1
    m = np.eye(4)
    m[:3, :3] = q @ np.diag([1.3, 0.7, 1.1])
    m[:3, 3] = rng.uniform(-1, 1, 3)
    return m


# --- Independent numpy references for the lattice deformers (the formulas of docs/math/lattice.md) ---
import math  # noqa: E402


def bernstein(degree, t):
    """B_i^d(t) = C(d, i) t^i (1 - t)^(d - i), as (n, d + 1); any t (the polynomial continued)."""
    i = np.arange(degree + 1)
    binom = np.array([math.comb(degree, k) for k in i], float)
    t = np.asarray(t, float)[:, None]
    return binom * t ** i * (1 - t) ** (degree - i)


def bezier_blocks_basis(count, t):
    """Piecewise cubic Bezier over (count - 1) / 3 equal blocks; the end blocks continue outside."""
    blocks = (count - 1) // 3
    g = np.asarray(t, float) * blocks
    block = np.clip(np.floor(g), 0, blocks - 1).astype(int)
    out = np.zeros((len(g), count))
    local = bernstein(3, g - block)
    for a in range(4):
        out[np.arange(len(g)), 3 * block + a] = local[:, a]
    return out


def bspline_basis(count, t):
    """Uniform cubic B-spline, knots at j / (count - 1); the first and last spans continue outside."""
    g = np.asarray(t, float) * (count - 1)
    span = np.clip(np.floor(g), 1, count - 3).astype(int)
    f = g - span
    n = [(1 - f) ** 3 / 6, (3 * f ** 3 - 6 * f ** 2 + 4) / 6, (-3 * f ** 3 + 3 * f ** 2 + 3 * f + 1) / 6, f ** 3 / 6]
    out = np.zeros((len(g), count))
    for a in range(4):
        out[np.arange(len(g)), span - 1 + a] = n[a]
    return out


def blender_key_weights(kind, f, float_constants=True):
    """Blender's key_curve_position_weights (key.cc) with its float constants (0.16666666f,
    0.71f), or with float_constants=False the real numbers they spell (1/6, 2/3, 0.71), as
    deformkit computes them in float64."""
    f2, f3 = f * f, f * f * f
    if kind == "linear":
        z = np.zeros_like(f)
        return [z, 1 - f, f, z]
    spell = (lambda x: float(np.float32(x))) if float_constants else float
    if kind == "bspline":
        c, d = (spell(0.16666666), spell(0.66666666)) if float_constants else (1 / 6, 2 / 3)
        return [-c * f3 + 0.5 * f2 - 0.5 * f + c, 0.5 * f3 - f2 + d, -0.5 * f3 + 0.5 * f2 + 0.5 * f + c, c * f3]
    fc = {"cardinal": spell(0.71), "catmull_rom": 0.5}[kind]
    return [-fc * f3 + 2 * fc * f2 - fc * f, (2 - fc) * f3 + (fc - 3) * f2 + 1,
            (fc - 2) * f3 + (3 - 2 * fc) * f2 + fc * f, fc * f3 - fc * f2]


def blender_basis(count, kind, t, float_constants=True):
    """BKE_lattice_deform_data_eval_co along one axis: u = t (count - 1), indices clamped (edge repeat)."""
    t = np.asarray(t, float)
    out = np.zeros((len(t), count))
    if count == 1:
        out[:, 0] = 1.0
        return out
    g = t * (count - 1)
    cell = np.floor(g).astype(int)
    w = blender_key_weights(kind, g - cell, float_constants)
    for a in range(4):
        np.add.at(out, (np.arange(len(t)), np.clip(cell - 1 + a, 0, count - 1)), w[a])
    return out


def tensor_weights(bu, bv, bw):
    """Dense rows of W over flattened control points (i * nv + j) * nw + k."""
    return np.einsum("ni,nj,nk->nijk", bu, bv, bw).reshape(len(bu), bu.shape[1] * bv.shape[1] * bw.shape[1])


def box_coordinates(points, origin, edges):
    """The lecture's cross products: s = (T x U).(X - X0) / ((T x U).S), t and u alike."""
    s_, t_, u_ = (np.asarray(e, float) for e in edges)
    d = np.asarray(points, float) - np.asarray(origin, float)
    cols = []
    for a, b, c in ((t_, u_, s_), (s_, u_, t_), (s_, t_, u_)):
        n = np.cross(a, b)
        cols.append(d @ n / (n @ c))
    return np.stack(cols, axis=1)


def box_point(stu, origin, edges):
    return np.asarray(origin, float) + np.asarray(stu, float) @ np.asarray(edges, float)


def box_grid(counts, origin, edges):
    """Rest control points evenly spaced over the box including its faces (one point: the centre)."""
    axes = [np.linspace(0, 1, n) if n > 1 else np.array([0.5]) for n in counts]
    stu = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
    return box_point(stu.reshape(-1, 3), origin, edges).reshape(*counts, 3)


def frame_box(frame):
    """origin and edges of Blender's rest cube [-1/2, 1/2]^3 mapped by a 4x4 frame."""
    frame = np.asarray(frame, float)
    return frame[:3, :3] @ np.full(3, -0.5) + frame[:3, 3], frame[:3, :3].T.copy()


def bezier_grid_eval(grid, params):
    """Position-form evaluation of a grid of tricubic Bezier blocks at global parameters in [0, 1]^3."""
    nu, nv, nw = grid.shape[:3]
    w = tensor_weights(*(bezier_blocks_basis(n, params[:, a]) for a, n in enumerate((nu, nv, nw))))
    return w @ grid.reshape(-1, 3)


def fd_jacobian(f, pts, h=1e-6):
    """Central differences, J[n, r, c] = dF_r / dx_c."""
    cols = []
    for c in range(3):
        e = np.zeros(3)
        e[c] = h
        cols.append((f(pts + e) - f(pts - e)) / (2 * h))
    return np.stack(cols, axis=-1)


def cofactor_normals(jac, normals):
    """cof(J) N = det(J) J^-T N, normalised."""
    cof = np.linalg.det(jac)[:, None, None] * np.linalg.inv(jac).transpose(0, 2, 1)
    out = np.einsum("nij,nj->ni", cof, normals)
    return out / np.linalg.norm(out, axis=1)[:, None]


def csr_dense(csr, columns):
    indptr, indices, data = csr
    dense = np.zeros((len(indptr) - 1, columns))
    for r in range(len(indptr) - 1):
        np.add.at(dense[r], indices[indptr[r]:indptr[r + 1]], data[indptr[r]:indptr[r + 1]])
    return dense


def box_surface(n):
    """Closed, outward-oriented triangle mesh of the unit cube's surface, n x n quads per face."""
    g = np.linspace(0, 1, n + 1)
    a, b = (x.ravel() for x in np.meshgrid(g, g, indexing="ij"))
    q = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
    quads = np.stack([q, q + n + 1, q + n + 2, q + 1], axis=1)
    verts, faces = [], []
    for axis in range(3):
        for side in (0.0, 1.0):
            p = np.zeros((len(a), 3))
            p[:, axis], p[:, (axis + 1) % 3], p[:, (axis + 2) % 3] = side, a, b
            tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
            if side == 0.0:
                tris = tris[:, ::-1]
            faces.append(tris + sum(len(v) for v in verts))
            verts.append(p)
    return np.concatenate(verts), np.concatenate(faces)


def mesh_volume(verts, faces):
    v = verts[faces]
    return np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2])).sum() / 6


def gauss_box(breaks, order=6):
    """Tensor Gauss-Legendre nodes and weights over a box, one rule per piece between breakpoints."""
    x, w = np.polynomial.legendre.leggauss(order)
    axes = []
    for br in breaks:
        br = np.asarray(br, float)
        lo, hi = br[:-1, None], br[1:, None]
        axes.append(((((hi - lo) * x + hi + lo) / 2).ravel(), ((hi - lo) / 2 * w).ravel()))
    grid = np.stack(np.meshgrid(*(a[0] for a in axes), indexing="ij"), -1).reshape(-1, 3)
    weights = np.einsum("i,j,k->ijk", *(a[1] for a in axes)).ravel()
    return grid, weights


# --- Dense numpy references for the surface deformers (docs/math/surface.md) ---
def cot_weights(points, tris):
    """W[a, b] = (cot alpha + cot beta) / 2 from the angles opposite edge ab."""
    p = np.asarray(points, float)
    w = np.zeros((len(p), len(p)))
    for c, a, b in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        u, v = p[tris[:, a]] - p[tris[:, c]], p[tris[:, b]] - p[tris[:, c]]
        cot = np.einsum("ij,ij->i", u, v) / np.linalg.norm(np.cross(u, v), axis=1)
        np.add.at(w, (tris[:, a], tris[:, b]), cot / 2)
        np.add.at(w, (tris[:, b], tris[:, a]), cot / 2)
    return w


def lap(w):
    return np.diag(w.sum(1)) - w


def naive_reference(points, w, fixed, fixed_pos, form):
    """min ||L x' - L x||^2 over all rows ('ls'), or the free rows solved exactly ('free_rows')."""
    L, x = lap(w), np.array(points, float)
    free = np.setdiff1d(np.arange(len(x)), fixed)
    x[fixed] = fixed_pos
    rhs = L @ points - L[:, fixed] @ x[fixed]
    if form == "ls":
        x[free] = np.linalg.lstsq(L[:, free], rhs, rcond=None)[0]
    else:
        x[free] = np.linalg.solve(L[np.ix_(free, free)], rhs[free])
    return x


def local_rotations(w, p, q):
    """R_i = V U^T from S_i = sum_j w_ij e_ij e'_ij^T, with the reflection fix on U's last column."""
    out = np.empty((len(p), 3, 3))
    for i in range(len(p)):
        j = np.nonzero(w[i])[0]
        s = (w[i, j, None] * (p[i] - p[j])).T @ (q[i] - q[j])
        u, _, vt = np.linalg.svd(s)
        if np.linalg.det(vt.T @ u.T) < 0:
            u[:, 2] *= -1
        out[i] = vt.T @ u.T
    return out


def arap_energy(w, p, q, r):
    i, j = np.nonzero(w)
    d = (q[i] - q[j]) - np.einsum("nab,nb->na", r[i], p[i] - p[j])
    return (w[i, j] * (d ** 2).sum(1)).sum()


def arap_step(w, p, q, fixed):
    """One local step at q, then the global solve L p' = b(R) with the fixed vertices kept."""
    r, L = local_rotations(w, p, q), lap(w)
    i, j = np.nonzero(w)
    b = np.zeros_like(p)
    np.add.at(b, i, w[i, j, None] / 2 * np.einsum("nab,nb->na", r[i] + r[j], p[i] - p[j]))
    free, out = np.setdiff1d(np.arange(len(p)), fixed), q.copy()
    out[free] = np.linalg.solve(L[np.ix_(free, free)], b[free] - L[np.ix_(free, fixed)] @ q[fixed])
    return out


def euler_xyz(rx, ry, rz):
    """Blender's XYZ Euler: R = Rz @ Ry @ Rx."""
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    rxm = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    rym = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rzm = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rzm @ rym @ rxm


def trs(t=(0, 0, 0), euler=(0, 0, 0), s=(1, 1, 1)):
    """A 4x4 matrix as Blender composes location, XYZ Euler rotation and scale."""
    m = np.eye(4)
    m[:3, :3] = euler_xyz(*euler) @ np.diag(s)
    m[:3, 3] = t
    return m
