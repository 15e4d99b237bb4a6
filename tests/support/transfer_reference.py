"""An independent numpy/scipy transcription of deformation transfer as docs/math/transfer.md states
it (Sumner and Popovic 2004; the gradient form of Botsch, Sumner, Pauly, Gross 2006): the source's
deformation gradients with the fourth vertex, the target's area-weighted gradient energy summed
over every (source, target) triangle pair, the tangential projection, identity rows for unpaired
target triangles, and each connected part's translation fixed by its fixed vertices or by a mean
constraint on its reference vertices. The energy is assembled pair by pair as the docs write it (not
in the module's weighted-mean form) and solved with scipy.sparse: a KKT system for the translation
constraints, so no anchor is held and shifted afterwards."""
import numpy as np
import scipy.sparse as sp
import scipy.sparse.csgraph as csgraph
import scipy.sparse.linalg as spla


def fan(faces):
    """Polygons fanned from their first corner, in face order: (t, 3) triangles."""
    out = []
    for face in faces:
        face = [int(v) for v in face]
        out += [[face[0], face[k], face[k + 1]] for k in range(1, len(face) - 1)]
    return np.array(out, dtype=np.int64)


def fourth_vertex_frame(a, b, c, unit_normal=False):
    """Sumner and Popovic 2004, eq. 1: V = [b - a, c - a, v4 - a] with v4 = a + n / sqrt(|n|)
    (unit_normal: a + n / |n| instead, a variant the tests use to show their cases see the rule)."""
    n = np.cross(b - a, c - a)
    return np.column_stack([b - a, c - a, n / (np.linalg.norm(n) if unit_normal else np.sqrt(np.linalg.norm(n)))])


def source_gradients(rest, pose, triangles, unit_normal=False):
    """S_j = V'_j V_j^-1 for every source triangle (eq. 3): (t, 3, 3)."""
    out = np.empty((len(triangles), 3, 3))
    for j, (a, b, c) in enumerate(triangles):
        v = fourth_vertex_frame(rest[a], rest[b], rest[c], unit_normal)
        w = fourth_vertex_frame(pose[a], pose[b], pose[c], unit_normal)
        out[j] = np.linalg.solve(v.T, w.T).T  # W V^-1
    return out


def triangle_gradient(points, tri):
    """(3, 3) G with G @ f[tri] the gradient of the linear function with vertex values f on the
    triangle: column k is n x (p_k+2 - p_k+1) / (2 A); also the unit normal and the area."""
    p = points[np.asarray(tri)]
    nn = np.cross(p[1] - p[0], p[2] - p[0])
    twice_area = np.linalg.norm(nn)
    n = nn / twice_area
    g = np.column_stack([np.cross(n, p[(k + 2) % 3] - p[(k + 1) % 3]) / twice_area for k in range(3)])
    return g, n, twice_area / 2


def parts_of(vertex_count, triangles):
    """Connected part of every vertex (vertices joined by triangle edges)."""
    rows = np.concatenate([triangles[:, 0], triangles[:, 1], triangles[:, 2]])
    cols = np.concatenate([triangles[:, 1], triangles[:, 2], triangles[:, 0]])
    graph = sp.coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(vertex_count, vertex_count))
    return csgraph.connected_components(graph, directed=False)[1]


def gradient_energy(target, target_triangles, pairs, gradients, area_weights=True, mean_of_partners=False,
                    projection=True):
    """The documented energy sum over pairs (s, t) of A_t sum_c |G_t x_c - P_t S_s^T e_c|^2, plus
    A_t sum_c |G_t x_c - P_t e_c|^2 for each target triangle without a partner, as M x - R with
    M sparse (3 rows per term) and R (rows, 3). The variants the tests use to show that their cases
    see each rule: area_weights=False weighs every term 1; mean_of_partners=True gives a target
    triangle one term, A_t |G_t x_c - P_t mean(S_s)^T e_c|^2, whatever its partner count;
    projection=False drops P_t (which only adds a constant: G_t x_c lies in the plane anyway)."""
    partners = [[] for _ in range(len(target_triangles))]
    for s, t in pairs:
        partners[int(t)].append(gradients[int(s)])
    if mean_of_partners:
        partners = [[np.mean(p, axis=0)] if p else [] for p in partners]
    rows, cols, vals, rhs = [], [], [], []
    for t, tri in enumerate(target_triangles):
        g, n, area = triangle_gradient(target, tri)
        area = area if area_weights else 1.0
        tangential = np.eye(3) - np.outer(n, n) if projection else np.eye(3)
        for s_grad in partners[t] or [np.eye(3)]:
            base = 3 * len(rhs)
            for r in range(3):
                for k in range(3):
                    rows.append(base + r)
                    cols.append(int(tri[k]))
                    vals.append(np.sqrt(area) * g[r, k])
            rhs.append(np.sqrt(area) * tangential @ s_grad.T)  # column c: P_t S^T e_c
    m = sp.csr_matrix((vals, (rows, cols)), shape=(3 * len(rhs), len(target)))
    return m, np.vstack(rhs)


def solve_transfer(m, r, vertex_count, fixed, fixed_positions, mean_constraints):
    """min |M x - R|^2 with x[fixed] = fixed_positions and, per (vertices, target mean), the mean
    of x over the vertices (repeats counted) equal to the target mean: the KKT system, by spsolve."""
    fixed = np.asarray(fixed, dtype=np.int64)
    free = np.setdiff1d(np.arange(vertex_count), fixed)
    index = -np.ones(vertex_count, dtype=np.int64)
    index[free] = np.arange(len(free))
    a = (m.T @ m).tocsr()
    b = m.T @ r
    x = np.zeros((vertex_count, 3))
    x[fixed] = fixed_positions
    b_free = b[free] - a[free][:, fixed] @ x[fixed]
    c_rows, c_cols, c_vals, c_rhs = [], [], [], []
    for k, (vertices, mean) in enumerate(mean_constraints):
        vertices = np.asarray(vertices)
        assert np.all(index[vertices] >= 0), "a mean constraint on a fixed vertex"
        for v in vertices:
            c_rows.append(k)
            c_cols.append(index[v])
            c_vals.append(1.0 / len(vertices))
        c_rhs.append(mean)
    c = sp.csr_matrix((c_vals, (c_rows, c_cols)), shape=(len(mean_constraints), len(free)))
    kkt = sp.bmat([[a[free][:, free], c.T], [c, None]], format="csc")
    rhs = np.vstack([b_free, np.array(c_rhs).reshape(-1, 3)])
    sol = spla.spsolve(kkt, rhs)
    sol += spla.spsolve(kkt, rhs - kkt @ sol)  # one step of iterative refinement
    x[free] = sol[: len(free)]
    return x


def transfer(source, source_faces, target, target_faces, pose, pairs=None, markers=None,
             fixed_vertices=(), fixed_positions=None, **variant):
    """The target's pose for one source pose, as docs/math/transfer.md defines it.

    pairs: (m, 2) (source triangle, target triangle) over the fanned triangles, None for the same
    connectivity (triangle j with triangle j). markers: (source vertex, target vertex) pairs fixing
    the translation of the parts they are in. Translation per part: fixed vertices where it has
    some; else (same connectivity) its first vertex moves as its source partner; else its markers'
    mean moves as their sources' mean; else the mean of its paired triangles' centroids moves as
    their partners' does. variant: unit_normal, area_weights, mean_of_partners, projection (see above)."""
    source, target, pose = (np.asarray(a, float) for a in (source, target, pose))
    st, tt = fan(source_faces), fan(target_faces)
    same = pairs is None
    if same:
        pairs = np.column_stack([np.arange(len(st)), np.arange(len(tt))])
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    gradients = source_gradients(source, pose, st, variant.pop("unit_normal", False))
    m, r = gradient_energy(target, tt, pairs, gradients, **variant)
    fixed = np.asarray(fixed_vertices, dtype=np.int64)
    fixed_positions = target[fixed] if fixed_positions is None else np.asarray(fixed_positions, float)
    part = parts_of(len(target), tt)
    moved = pose - source
    constraints = []
    for p in np.unique(part):
        if np.any(part[fixed] == p):
            continue
        if same:
            first = int(np.flatnonzero(part == p)[0])
            constraints.append(([first], target[first] + moved[first]))
            continue
        chosen = [(s, g) for s, g in (markers if markers is not None else []) if part[g] == p]
        if chosen:
            s, g = np.array(chosen).T
            constraints.append((g, target[g].mean(0) + moved[s].mean(0)))
            continue
        in_part = pairs[part[tt[pairs[:, 1], 0]] == p]
        g = tt[in_part[:, 1]].ravel()  # corners of the paired target triangles, once per pair
        s = st[in_part[:, 0]].ravel()
        constraints.append((g, target[g].mean(0) + moved[s].mean(0)))
    return solve_transfer(m, r, len(target), fixed, fixed_positions, constraints)
