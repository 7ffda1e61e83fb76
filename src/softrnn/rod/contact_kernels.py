"""The contact kernels (docs/lgvi.md §2.11): the obstacles' gaps and normals, the penalty normal force
and friction, and contact between the rod's own segments. ``_contact_loads`` adds the contact loads
of the obstacles in ``StepInputs`` (and, with a SELF column, between the rod's own segments:
``_self_contact``) to the applied loads once per step, before the node loop, and only when there are
obstacles: ``_contact_loads_if_any`` and ``_applied_outputs_if_any`` compile to nothing for inputs
whose ``contact_kind`` is None, so a rod without obstacles never compiles the contact kernels.
Inlined into ``rod.kernels`` and ``rod.implicit`` (see ``rod.kernel_records``)."""

import math

from numba import njit
from numba.extending import overload

from .kernel_records import _INLINE, BIFURCATION, BRANCH, CYLINDER, MESH, PLANE, SELF, UNION_BLEND, VESSEL, absent

_VESSEL_WINDOW = 3
"""Segments searched either way of a node's tracked vessel segment before walking further."""

_MESH_MARGIN = 1.0
"""A node whose walk from its tracked face ends nearer than 2 rod radii plus this many seed-grid
cells to the wall also walks from its cell's seed face (the nearer result is kept)."""

_MESH_WALK = 256
"""Most steps of the descent over a mesh's faces toward a node's closest face."""


@njit(**_INLINE)
def _segment_projection(P, k, x0, x1, x2):
    """Squared distance [m^2] from x to the segment P[k] -> P[k + 1] and the parameter t of the
    projection of x on its line (not clipped: t < 0 or t > 1 lies beyond the segment's ends)."""
    e0 = P[k + 1, 0] - P[k, 0]
    e1 = P[k + 1, 1] - P[k, 1]
    e2 = P[k + 1, 2] - P[k, 2]
    q0 = x0 - P[k, 0]
    q1 = x1 - P[k, 1]
    q2 = x2 - P[k, 2]
    t = (q0 * e0 + q1 * e1 + q2 * e2) / (e0 * e0 + e1 * e1 + e2 * e2)
    tc = min(max(t, 0.0), 1.0)
    d0 = q0 - tc * e0
    d1 = q1 - tc * e1
    d2 = q2 - tc * e2
    return d0 * d0 + d1 * d1 + d2 * d2, t


@njit(**_INLINE)
def _vessel_gap(a, o, x0, x1, x2, ra, inputs):
    """Gap [m] and inward unit normal of node a (centreline point x, rod radius ra) inside vessel o.
    The tracked segment inputs.contact_segment[a, o] is the warm start of a local search (a window
    of _VESSEL_WINDOW segments either way, then a walk while the distance decreases) and is
    updated. Beyond the vessel's open ends, and on its centreline, the gap is 1 (no contact)."""
    P = inputs.contact_points
    rad = inputs.contact_radii
    p0 = inputs.contact_range[o, 0]
    last = inputs.contact_range[o, 1] - 2
    j = inputs.contact_segment[a, o]
    lo = max(j - _VESSEL_WINDOW, 0)
    hi = min(j + _VESSEL_WINDOW, last)
    best = lo
    bd = math.inf
    for jj in range(lo, hi + 1):
        d2, t = _segment_projection(P, p0 + jj, x0, x1, x2)
        if d2 < bd:
            bd = d2
            best = jj
    while best == lo and lo > 0:
        lo -= 1
        d2, t = _segment_projection(P, p0 + lo, x0, x1, x2)
        if d2 <= bd:  # ties to the lower index, as a search from the start would find
            bd = d2
            best = lo
    while best == hi and hi < last:
        hi += 1
        d2, t = _segment_projection(P, p0 + hi, x0, x1, x2)
        if d2 < bd:
            bd = d2
            best = hi
    inputs.contact_segment[a, o] = best
    d2, t = _segment_projection(P, p0 + best, x0, x1, x2)
    if (best == 0 and t < 0.0) or (best == last and t > 1.0):
        return 1.0, 0.0, 0.0, 0.0
    tc = min(max(t, 0.0), 1.0)
    k = p0 + best
    c0 = P[k, 0] + tc * (P[k + 1, 0] - P[k, 0]) - x0
    c1 = P[k, 1] + tc * (P[k + 1, 1] - P[k, 1]) - x1
    c2 = P[k, 2] + tc * (P[k + 1, 2] - P[k, 2]) - x2
    d = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    if not d > 0.0:
        return 1.0, 0.0, 0.0, 0.0
    radius = rad[k] + tc * (rad[k + 1] - rad[k])
    return radius - ra - d, c0 / d, c1 / d, c2 / d


@njit(**_INLINE)
def _union_gap(a, o, x0, x1, x2, ra, inputs):
    """Gap [m] and inward unit normal of node a in the union of the vessels of columns o and o + 1
    (a bifurcation, docs/lgvi.md §2.11): the larger of their gaps, so that a node inside either
    (gap >= 0) touches no wall. Its normal (inside too: predictive contact) is that vessel's,
    blended with the other's where their gaps differ by less than UNION_BLEND ra (weights
    1 - difference / (UNION_BLEND ra)), so that a node on the crease between the two walls is pushed
    straight back from it. Both vessels' tracked segments are updated."""
    g, n0, n1, n2 = _vessel_gap(a, o, x0, x1, x2, ra, inputs)
    h, m0, m1, m2 = _vessel_gap(a, o + 1, x0, x1, x2, ra, inputs)
    best = max(g, h)
    width = UNION_BLEND * ra
    u = max(0.0, 1.0 - (best - g) / width)
    w = max(0.0, 1.0 - (best - h) / width)
    b0 = u * n0 + w * m0
    b1 = u * n1 + w * m1
    b2 = u * n2 + w * m2
    size = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
    if not size > 0.0:  # opposite normals: no direction to push
        return (best if best >= 0.0 else 1.0), 0.0, 0.0, 0.0
    return best, b0 / size, b1 / size, b2 / size


@njit(**_INLINE)
def _mesh_layout(o, inputs):
    """Where mesh column o's arrays start in contact_mesh_index (I) and contact_mesh_values (X):
    faces, neighbours, ring offsets, ring faces, seed grid (I); vertices, face normals, vertex
    pseudonormals (X); and the grid's shape (``rod.contact.mesh_arrays``)."""
    i0 = inputs.contact_range[o, 0]
    x0 = inputs.contact_range[o, 1]
    idx = inputs.contact_mesh_index
    nv = idx[i0]
    nf = idx[i0 + 1]
    fb = i0 + 5
    nb = fb + 3 * nf
    ro = nb + 3 * nf
    rg = ro + nv + 1
    cb = rg + 3 * nf
    return fb, nb, ro, rg, cb, x0, x0 + 3 * nv, x0 + 3 * nv + 3 * nf, idx[i0 + 2], idx[i0 + 3], idx[i0 + 4]


@njit(**_INLINE)
def _triangle_closest(idx, val, fb, xv, f, p0, p1, p2):
    """Squared distance [m^2] from p to face f, its closest point q and feature (0 inside, 1 + k
    vertex k, 4 + k edge k from vertex k to k + 1; Ericson, Real-Time Collision Detection 5.1.5)."""
    ia = xv + 3 * idx[fb + 3 * f]
    ib = xv + 3 * idx[fb + 3 * f + 1]
    ic = xv + 3 * idx[fb + 3 * f + 2]
    a0 = val[ia]
    a1 = val[ia + 1]
    a2 = val[ia + 2]
    ab0 = val[ib] - a0
    ab1 = val[ib + 1] - a1
    ab2 = val[ib + 2] - a2
    ac0 = val[ic] - a0
    ac1 = val[ic + 1] - a1
    ac2 = val[ic + 2] - a2
    ap0 = p0 - a0
    ap1 = p1 - a1
    ap2 = p2 - a2
    d1 = ab0 * ap0 + ab1 * ap1 + ab2 * ap2
    d2 = ac0 * ap0 + ac1 * ap1 + ac2 * ap2
    ft = 0
    v = 0.0
    w = 0.0
    d3 = d1 - (ab0 * ab0 + ab1 * ab1 + ab2 * ab2)       # ab . (p - b)
    d4 = d2 - (ac0 * ab0 + ac1 * ab1 + ac2 * ab2)       # ac . (p - b)
    d5 = d1 - (ab0 * ac0 + ab1 * ac1 + ab2 * ac2)       # ab . (p - c)
    d6 = d2 - (ac0 * ac0 + ac1 * ac1 + ac2 * ac2)       # ac . (p - c)
    vc = d1 * d4 - d3 * d2
    vb = d5 * d2 - d1 * d6
    va = d3 * d6 - d5 * d4
    if d1 <= 0.0 and d2 <= 0.0:
        ft = 1
    elif d3 >= 0.0 and d4 <= d3:
        ft = 2
        v = 1.0
    elif d6 >= 0.0 and d5 <= d6:
        ft = 3
        w = 1.0
    elif vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        ft = 4
        v = d1 / (d1 - d3)
    elif va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0:
        ft = 5
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        v = 1.0 - w
    elif vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        ft = 6
        w = d2 / (d2 - d6)
    else:
        total = va + vb + vc
        v = vb / total
        w = vc / total
    q0 = a0 + v * ab0 + w * ac0
    q1 = a1 + v * ab1 + w * ac1
    q2 = a2 + v * ab2 + w * ac2
    e0 = p0 - q0
    e1 = p1 - q1
    e2 = p2 - q2
    return e0 * e0 + e1 * e1 + e2 * e2, q0, q1, q2, ft


@njit(**_INLINE)
def _mesh_walk(idx, val, lay, f, stop, p0, p1, p2):
    """The closest face to p found by descent from face f over the face adjacency: step to the
    nearest of the faces across f's edges while one is nearer than f, and where none is, to the
    nearest face around f's vertices (its 1-ring) while one is; stop where none is nearer, or on
    face ``stop`` (a local minimum found before; -1: none). Returns the face, the squared distance
    [m^2], the closest point and its feature."""
    fb, nb, ro, rg, cb, xv, xn, xw, gx, gy, gz = lay
    d2, q0, q1, q2, ft = _triangle_closest(idx, val, fb, xv, f, p0, p1, p2)
    for _ in range(_MESH_WALK):
        if f == stop:
            break
        best = f
        e2 = d2
        r0 = r1 = r2 = 0.0
        gt = 0
        for k in range(3):
            g = idx[nb + 3 * f + k]
            c2, c0, c1, cc, ct = _triangle_closest(idx, val, fb, xv, g, p0, p1, p2)
            if c2 < e2:
                best = g
                e2, r0, r1, r2, gt = c2, c0, c1, cc, ct
        if best == f:
            for k in range(3):
                vert = idx[fb + 3 * f + k]
                for j in range(idx[ro + vert], idx[ro + vert + 1]):
                    g = idx[rg + j]
                    c2, c0, c1, cc, ct = _triangle_closest(idx, val, fb, xv, g, p0, p1, p2)
                    if c2 < e2:
                        best = g
                        e2, r0, r1, r2, gt = c2, c0, c1, cc, ct
            if best == f:
                break
        f = best
        d2, q0, q1, q2, ft = e2, r0, r1, r2, gt
    return f, d2, q0, q1, q2, ft


@njit(**_INLINE)
def _mesh_gap(a, o, x0, x1, x2, ra, inputs):
    """Gap [m] and unit normal into the lumen of node a (centreline point x, rod radius ra) in mesh
    column o: the exact distance to the closest face, signed by the pseudonormal of its closest
    feature (face, edge: the sum of its faces' normals, vertex: angle-weighted), minus ra. The face
    comes from walks from the node's tracked face (inputs.contact_segment[a, o], updated) and from
    the seed grid's face of the node's cell (docs/guide/navigation.md, "Vessels from meshes")."""
    idx = inputs.contact_mesh_index
    val = inputs.contact_mesh_values
    lay = _mesh_layout(o, inputs)
    fb, nb, ro, rg, cb, xv, xn, xw, gx, gy, gz = lay
    geom = inputs.contact_geom
    f, d2, q0, q1, q2, ft = _mesh_walk(idx, val, lay, inputs.contact_segment[a, o], -1, x0, x1, x2)
    cell = geom[o, 3]
    ix = min(max(int(math.floor((x0 - geom[o, 0]) / cell)), 0), gx - 1)
    iy = min(max(int(math.floor((x1 - geom[o, 1]) / cell)), 0), gy - 1)
    iz = min(max(int(math.floor((x2 - geom[o, 2]) / cell)), 0), gz - 1)
    seed = idx[cb + ix + gx * (iy + gy * iz)]
    near = (2.0 * ra + _MESH_MARGIN * cell) ** 2
    if seed >= 0 and seed != f:
        e2, r0, r1, r2, et = _triangle_closest(idx, val, fb, xv, seed, x0, x1, x2)
        if e2 < d2 or d2 < near:  # a nearer start, or a node near the wall: walk from the cell's face too
            g, e2, r0, r1, r2, et = _mesh_walk(idx, val, lay, seed, f, x0, x1, x2)
            if e2 < d2:
                f, d2, q0, q1, q2, ft = g, e2, r0, r1, r2, et
    inputs.contact_segment[a, o] = f
    if ft == 0:
        k = xn + 3 * f
        m0 = val[k]
        m1 = val[k + 1]
        m2 = val[k + 2]
    elif ft >= 4:
        k = xn + 3 * f
        g = xn + 3 * idx[nb + 3 * f + ft - 4]
        m0 = val[k] + val[g]
        m1 = val[k + 1] + val[g + 1]
        m2 = val[k + 2] + val[g + 2]
    else:
        k = xw + 3 * idx[fb + 3 * f + ft - 1]
        m0 = val[k]
        m1 = val[k + 1]
        m2 = val[k + 2]
    c0 = x0 - q0
    c1 = x1 - q1
    c2 = x2 - q2
    d = math.sqrt(d2)
    if not d > 0.0:  # on the wall: the normal is the feature's, inward
        size = math.sqrt(m0 * m0 + m1 * m1 + m2 * m2)
        return -ra, -m0 / size, -m1 / size, -m2 / size
    if c0 * m0 + c1 * m1 + c2 * m2 < 0.0:  # inside the lumen
        return d - ra, c0 / d, c1 / d, c2 / d
    return -d - ra, -c0 / d, -c1 / d, -c2 / d


@njit(**_INLINE)
def _friction(a, h, mu, vs, fn, ra, n0, n1, n2, R, v, w, rod):
    """Regularised Coulomb friction f_t = -mu fn v_t / max(|v_t|, v_s') at the contact point -ra n
    of node a (docs/lgvi.md §2.11): v_t the tangential velocity of that point from the staggered
    v (world) and w (body), v_s' = max(v_s, h mu fn / m_eff) with 1/m_eff the node's inverse mass
    along v_t, rotation included. Returns the force and its moment (-ra n) x f_t, world frame."""
    W0 = R[a, 0, 0] * w[a, 0] + R[a, 0, 1] * w[a, 1] + R[a, 0, 2] * w[a, 2]
    W1 = R[a, 1, 0] * w[a, 0] + R[a, 1, 1] * w[a, 1] + R[a, 1, 2] * w[a, 2]
    W2 = R[a, 2, 0] * w[a, 0] + R[a, 2, 1] * w[a, 1] + R[a, 2, 2] * w[a, 2]
    # velocity of the contact point: v + W x (-ra n), then its tangential part
    c0 = v[a, 0] - ra * (W1 * n2 - W2 * n1)
    c1 = v[a, 1] - ra * (W2 * n0 - W0 * n2)
    c2 = v[a, 2] - ra * (W0 * n1 - W1 * n0)
    vn = c0 * n0 + c1 * n1 + c2 * n2
    c0 -= vn * n0
    c1 -= vn * n1
    c2 -= vn * n2
    speed = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    if not speed > 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    # moment axis k = n x v_t/|v_t| in the body frame: 1/m_eff = 1/m + ra^2 k . J^-1 k
    k0 = (n1 * c2 - n2 * c1) / speed
    k1 = (n2 * c0 - n0 * c2) / speed
    k2 = (n0 * c1 - n1 * c0) / speed
    kb0 = R[a, 0, 0] * k0 + R[a, 1, 0] * k1 + R[a, 2, 0] * k2
    kb1 = R[a, 0, 1] * k0 + R[a, 1, 1] * k1 + R[a, 2, 1] * k2
    kb2 = R[a, 0, 2] * k0 + R[a, 1, 2] * k1 + R[a, 2, 2] * k2
    inertia = rod.inertia
    im = 1.0 / rod.mass[a] + ra * ra * (kb0 * kb0 / inertia[a, 0] + kb1 * kb1 / inertia[a, 1]
                                        + kb2 * kb2 / inertia[a, 2])
    s = -mu * fn / max(speed, vs, h * mu * fn * im)
    f0 = s * c0
    f1 = s * c1
    f2 = s * c2
    return f0, f1, f2, -ra * (n1 * f2 - n2 * f1), -ra * (n2 * f0 - n0 * f2), -ra * (n0 * f1 - n1 * f0)


@njit(**_INLINE)
def _obstacle_gap(a, o, x0, x1, x2, ra, inputs):
    """Gap [m] between the surface of node a (centreline point x, rod radius ra) and obstacle o,
    and the obstacle's unit normal at the node, pointing to the rod's side; gap 1 where the normal
    is undefined (a node on a sphere's centre or a cylinder's axis, a vessel's open ends) and in a
    BRANCH column (a bifurcation's gap is its BIFURCATION column's, ``_union_gap``)."""
    geom = inputs.contact_geom
    kd = inputs.contact_kind[o]
    if kd == PLANE:
        n0 = geom[o, 3]
        n1 = geom[o, 4]
        n2 = geom[o, 5]
        return (x0 - geom[o, 0]) * n0 + (x1 - geom[o, 1]) * n1 + (x2 - geom[o, 2]) * n2 - ra, n0, n1, n2
    if kd == VESSEL:
        return _vessel_gap(a, o, x0, x1, x2, ra, inputs)
    if kd == BIFURCATION:
        return _union_gap(a, o, x0, x1, x2, ra, inputs)
    if kd == MESH:
        return _mesh_gap(a, o, x0, x1, x2, ra, inputs)
    if kd == BRANCH or kd == SELF:  # part of the BIFURCATION column's gap; self-contact: ``_self_contact``
        return 1.0, 0.0, 0.0, 0.0
    q0 = x0 - geom[o, 0]
    q1 = x1 - geom[o, 1]
    q2 = x2 - geom[o, 2]
    if kd == CYLINDER:
        qa = q0 * geom[o, 3] + q1 * geom[o, 4] + q2 * geom[o, 5]
        q0 -= qa * geom[o, 3]
        q1 -= qa * geom[o, 4]
        q2 -= qa * geom[o, 5]
    d = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
    if not d > 0.0:
        return 1.0, 0.0, 0.0, 0.0
    return d - geom[o, 6] - ra, q0 / d, q1 / d, q2 / d


@njit(**_INLINE)
def _segment_pair(p0, p1, q0, q1, r):
    """Parameters (s, t) in [0, 1] of the closest points p0 + s (p1 - p0) and q0 + t (q1 - q0) of
    segments (p0, p1) and (q0, q1) of the rows of r (n, 3); both of nonzero length."""
    d1x = r[p1, 0] - r[p0, 0]
    d1y = r[p1, 1] - r[p0, 1]
    d1z = r[p1, 2] - r[p0, 2]
    d2x = r[q1, 0] - r[q0, 0]
    d2y = r[q1, 1] - r[q0, 1]
    d2z = r[q1, 2] - r[q0, 2]
    ex = r[p0, 0] - r[q0, 0]
    ey = r[p0, 1] - r[q0, 1]
    ez = r[p0, 2] - r[q0, 2]
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    b = d1x * d2x + d1y * d2y + d1z * d2z
    c = d1x * ex + d1y * ey + d1z * ez
    f = d2x * ex + d2y * ey + d2z * ez
    den = a * e - b * b
    s = min(max((b * f - c * e) / den, 0.0), 1.0) if den > 1e-12 * a * e else 0.0
    t = (b * s + f) / e
    if t < 0.0:
        t = 0.0
        s = min(max(-c / a, 0.0), 1.0)
    elif t > 1.0:
        t = 1.0
        s = min(max((b - c) / a, 0.0), 1.0)
    return s, t


@njit(**_INLINE)
def _push_pair(a, wa, f0, f1, f2, row, record, save_slot, inputs, work_f):
    """work_f[a] += wa f (and the saved contact loads of node a at a saved step)."""
    work_f[a, 0] += wa * f0
    work_f[a, 1] += wa * f1
    work_f[a, 2] += wa * f2
    if record and save_slot[a] >= 0:
        smp = inputs.contact_samples
        smp[row, save_slot[a], 0] += wa * f0
        smp[row, save_slot[a], 1] += wa * f1
        smp[row, save_slot[a], 2] += wa * f2


@njit(**_INLINE)
def _self_contact(row, record, r, v, gap_index, inputs, save_slot, work_f):
    """Frictionless contact between the rod's own segments i < j, j - i >= gap_index (docs/lgvi.md
    §2.11): where their closest points P (on i) and Q (on j) are nearer than the sum of the rod
    radii there, fn = max(0, -k gap - c v_n) along n = (P - Q) / |P - Q|, with k and c the series
    combination of the two points' (nodal values interpolated), v_n the normal velocity of P
    relative to Q; +fn n goes to segment i's nodes and -fn n to segment j's, split as the closest
    points divide the segments (the pair's forces sum to zero). Brute force over the pairs, each
    rejected first by its bounding spheres."""
    node = inputs.contact_node
    n = len(r)
    for i in range(n - 1):
        li = math.sqrt((r[i + 1, 0] - r[i, 0]) ** 2 + (r[i + 1, 1] - r[i, 1]) ** 2 + (r[i + 1, 2] - r[i, 2]) ** 2)
        for j in range(i + gap_index, n - 1):
            mx = 0.5 * (r[i, 0] + r[i + 1, 0] - r[j, 0] - r[j + 1, 0])
            my = 0.5 * (r[i, 1] + r[i + 1, 1] - r[j, 1] - r[j + 1, 1])
            mz = 0.5 * (r[i, 2] + r[i + 1, 2] - r[j, 2] - r[j + 1, 2])
            lj = math.sqrt((r[j + 1, 0] - r[j, 0]) ** 2 + (r[j + 1, 1] - r[j, 1]) ** 2 + (r[j + 1, 2] - r[j, 2]) ** 2)
            reach = 0.5 * (li + lj) + max(node[i, 0], node[i + 1, 0]) + max(node[j, 0], node[j + 1, 0])
            if mx * mx + my * my + mz * mz >= reach * reach or not (li > 0.0 and lj > 0.0):
                continue
            s, t = _segment_pair(i, i + 1, j, j + 1, r)
            d0 = (1 - s) * r[i, 0] + s * r[i + 1, 0] - (1 - t) * r[j, 0] - t * r[j + 1, 0]
            d1 = (1 - s) * r[i, 1] + s * r[i + 1, 1] - (1 - t) * r[j, 1] - t * r[j + 1, 1]
            d2 = (1 - s) * r[i, 2] + s * r[i + 1, 2] - (1 - t) * r[j, 2] - t * r[j + 1, 2]
            dist = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            gap = dist - ((1 - s) * node[i, 0] + s * node[i + 1, 0] + (1 - t) * node[j, 0] + t * node[j + 1, 0])
            if gap >= 0.0 or not dist > 0.0:
                continue
            n0 = d0 / dist
            n1 = d1 / dist
            n2 = d2 / dist
            ki = (1 - s) * node[i, 1] + s * node[i + 1, 1]
            kj = (1 - t) * node[j, 1] + t * node[j + 1, 1]
            ci = (1 - s) * node[i, 2] + s * node[i + 1, 2]
            cj = (1 - t) * node[j, 2] + t * node[j + 1, 2]
            u0 = (1 - s) * v[i, 0] + s * v[i + 1, 0] - (1 - t) * v[j, 0] - t * v[j + 1, 0]
            u1 = (1 - s) * v[i, 1] + s * v[i + 1, 1] - (1 - t) * v[j, 1] - t * v[j + 1, 1]
            u2 = (1 - s) * v[i, 2] + s * v[i + 1, 2] - (1 - t) * v[j, 2] - t * v[j + 1, 2]
            vn = u0 * n0 + u1 * n1 + u2 * n2
            fn = -ki * kj / (ki + kj) * gap - (ci * cj / (ci + cj) if ci + cj > 0.0 else 0.0) * vn
            if fn > 0.0:
                f0 = fn * n0
                f1 = fn * n1
                f2 = fn * n2
                _push_pair(i, 1 - s, f0, f1, f2, row, record, save_slot, inputs, work_f)
                _push_pair(i + 1, s, f0, f1, f2, row, record, save_slot, inputs, work_f)
                _push_pair(j, t - 1, f0, f1, f2, row, record, save_slot, inputs, work_f)
                _push_pair(j + 1, -t, f0, f1, f2, row, record, save_slot, inputs, work_f)


@njit(**_INLINE)
def _node_contact(a, h, R, r, v, w, rod, inputs, coef_k, linear):
    """The contact force and torque (world) of node a (``_contact_loads``), whether it touches, and
    the tangent S = sum over touching obstacles of (coef_k k_a + h c_a) n n^T of its normal spring
    and damper (six entries: S00, S11, S22, S01, S02, S12). ``linear``: the normal force
    -k_a (gap + h v_n) - c_a v_n wherever gap < 0, also where it is negative (the implicit step's
    linear spring on the end-of-step gap and damper; friction from -k_a gap - c_a v_n, where that
    is positive), and then also the gap
    [m] and normal of the obstacle the node, not in its wall, nears most within the step (the least
    gap + h v_n; gap 1 and a zero normal: none), for predictive contact (``rod.implicit``)."""
    node = inputs.contact_node
    fric = inputs.contact_friction
    x0 = r[a, 0]
    x1 = r[a, 1]
    x2 = r[a, 2]
    ra = node[a, 0]
    touched = False
    f0 = f1 = f2 = t0 = t1 = t2 = 0.0
    s00 = s11 = s22 = s01 = s02 = s12 = 0.0
    ahead = pg = 1.0
    p0 = p1 = p2 = 0.0
    for o in range(len(inputs.contact_kind)):
        gap, n0, n1, n2 = _obstacle_gap(a, o, x0, x1, x2, ra, inputs)
        if gap >= 0.0:
            if linear and gap + h * (n0 * v[a, 0] + n1 * v[a, 1] + n2 * v[a, 2]) < ahead:
                ahead = gap + h * (n0 * v[a, 0] + n1 * v[a, 1] + n2 * v[a, 2])
                pg, p0, p1, p2 = gap, n0, n1, n2
        else:
            fn = -node[a, 1] * gap - node[a, 2] * (n0 * v[a, 0] + n1 * v[a, 1] + n2 * v[a, 2])
            if fn > 0.0 or linear:
                touched = True
                push = fn
                if linear:  # the spring on the end-of-step gap: its v_n part here, its u_n - v_n the tangent's
                    push = fn - h * node[a, 1] * (n0 * v[a, 0] + n1 * v[a, 1] + n2 * v[a, 2])
                f0 += push * n0
                f1 += push * n1
                f2 += push * n2
                q = coef_k * node[a, 1] + h * node[a, 2]
                s00 += q * n0 * n0
                s11 += q * n1 * n1
                s22 += q * n2 * n2
                s01 += q * n0 * n1
                s02 += q * n0 * n2
                s12 += q * n1 * n2
                if fric[o, 0] > 0.0 and fn > 0.0:
                    ft0, ft1, ft2, m0, m1, m2 = _friction(a, h, fric[o, 0], fric[o, 1], fn, ra, n0, n1, n2,
                                                          R, v, w, rod)
                    f0 += ft0
                    f1 += ft1
                    f2 += ft2
                    t0 += m0
                    t1 += m1
                    t2 += m2
    return touched, f0, f1, f2, t0, t1, t2, s00, s11, s22, s01, s02, s12, pg, p0, p1, p2


@njit(**_INLINE)
def _apply_contact(a, row, record, save_slot, touched, f0, f1, f2, t0, t1, t2, inputs, work_f):
    """At a saved step (``record``) keep node a's applied loads before the contact
    (inputs.contact_applied) and its contact loads (inputs.contact_samples[row]); then work_f[a] +=
    the contact loads where it ``touched``."""
    if record:
        slot = save_slot[a]
        if slot >= 0:
            for c in range(6):
                inputs.contact_applied[a, c] = work_f[a, c]
            smp = inputs.contact_samples
            smp[row, slot, 0] = f0
            smp[row, slot, 1] = f1
            smp[row, slot, 2] = f2
            smp[row, slot, 3] = t0
            smp[row, slot, 4] = t1
            smp[row, slot, 5] = t2
    if touched:
        work_f[a, 0] += f0
        work_f[a, 1] += f1
        work_f[a, 2] += f2
        work_f[a, 3] += t0
        work_f[a, 4] += t1
        work_f[a, 5] += t2


@njit(**_INLINE)
def _last_self_contact(row, record, r, v, inputs, save_slot, work_f):
    """``_self_contact`` when the last obstacle column is SELF."""
    last = len(inputs.contact_kind) - 1
    if inputs.contact_kind[last] == SELF:
        _self_contact(row, record, r, v, int(inputs.contact_geom[last, 0]), inputs, save_slot, work_f)


@njit(**_INLINE)
def _contact_loads(row, record, h, R, r, v, w, rod, inputs, save_slot, work_f):
    """work_f += the contact force and torque (world) of every node (docs/lgvi.md §2.11): penalty
    normal force fn = max(0, -k_a gap - c_a v_n) along the obstacle normal at the node, and
    friction (``_friction``), from the configuration (R, r) and the staggered velocities v (world)
    and w (body). At a saved step (``record``), the saved nodes' applied loads before the contact
    (inputs.contact_applied) and their contact loads (inputs.contact_samples[row]) are kept."""
    for a in range(len(r)):
        touched, f0, f1, f2, t0, t1, t2, _, _, _, _, _, _, _, _, _, _ = _node_contact(a, h, R, r, v, w, rod,
                                                                                     inputs, 0.0, False)
        _apply_contact(a, row, record, save_slot, touched, f0, f1, f2, t0, t1, t2, inputs, work_f)
    _last_self_contact(row, record, r, v, inputs, save_slot, work_f)


@njit(**_INLINE)
def _contact_loads_tangent(row, record, h, R, r, v, w, rod, inputs, save_slot, work_f, coef_k, tangent):
    """``_contact_loads``, and tangent (n, 12)[:, :11] <- each node's normal spring and damper
    tangent (``_node_contact``; zero where it touches nothing), then the gap [m] and normal of its
    nearest-ahead obstacle and its stiffness k [N/m], for the linearly implicit and predictive
    contact of ``rod.implicit``. Self-contact stays explicit."""
    node = inputs.contact_node
    for a in range(len(r)):
        touched, f0, f1, f2, t0, t1, t2, s00, s11, s22, s01, s02, s12, pg, p0, p1, p2 = _node_contact(
            a, h, R, r, v, w, rod, inputs, coef_k, True)
        _apply_contact(a, row, record, save_slot, touched, f0, f1, f2, t0, t1, t2, inputs, work_f)
        tangent[a, 0] = s00
        tangent[a, 1] = s11
        tangent[a, 2] = s22
        tangent[a, 3] = s01
        tangent[a, 4] = s02
        tangent[a, 5] = s12
        tangent[a, 6] = pg
        tangent[a, 7] = p0
        tangent[a, 8] = p1
        tangent[a, 9] = p2
        tangent[a, 10] = node[a, 1]
    _last_self_contact(row, record, r, v, inputs, save_slot, work_f)


@njit(**_INLINE)
def _applied_outputs(row, inputs, out):
    """out.forces[row], out.torques[row] <- the saved nodes' applied loads without the contact
    loads (kept by ``_contact_loads`` at this saved step)."""
    save_slot = out.save_slot
    for a in range(len(save_slot)):
        slot = save_slot[a]
        if slot >= 0:
            for c in range(3):
                out.forces[row, slot, c] = inputs.contact_applied[a, c]
                out.torques[row, slot, c] = inputs.contact_applied[a, 3 + c]


def _contact_loads_if_any(row, record, h, R, r, v, w, rod, inputs, save_slot, work_f):
    """``_contact_loads``; nothing for inputs without obstacles. Compiled code only."""
    raise NotImplementedError("compiled code only")


def _applied_outputs_if_any(row, inputs, out):
    """``_applied_outputs``; nothing for inputs without obstacles. Compiled code only."""
    raise NotImplementedError("compiled code only")


def _contact_loads_tangent_if_any(row, record, h, R, r, v, w, rod, inputs, save_slot, work_f, coef_k, tangent):
    """``_contact_loads_tangent``; nothing for inputs without obstacles. Compiled code only."""
    raise NotImplementedError("compiled code only")


@overload(_contact_loads_if_any, jit_options=_INLINE)
def _contact_loads_if_any_impl(row, record, h, R, r, v, w, rod, inputs, save_slot, work_f):
    if absent(inputs, "contact_kind"):
        return lambda row, record, h, R, r, v, w, rod, inputs, save_slot, work_f: None

    def loads(row, record, h, R, r, v, w, rod, inputs, save_slot, work_f):
        _contact_loads(row, record, h, R, r, v, w, rod, inputs, save_slot, work_f)
    return loads


@overload(_applied_outputs_if_any, jit_options=_INLINE)
def _applied_outputs_if_any_impl(row, inputs, out):
    if absent(inputs, "contact_kind"):
        return lambda row, inputs, out: None

    def outputs(row, inputs, out):
        _applied_outputs(row, inputs, out)
    return outputs


@overload(_contact_loads_tangent_if_any, jit_options=_INLINE)
def _contact_loads_tangent_if_any_impl(row, record, h, R, r, v, w, rod, inputs, save_slot, work_f, coef_k, tangent):
    if absent(inputs, "contact_kind"):
        return lambda row, record, h, R, r, v, w, rod, inputs, save_slot, work_f, coef_k, tangent: None

    def loads(row, record, h, R, r, v, w, rod, inputs, save_slot, work_f, coef_k, tangent):
        _contact_loads_tangent(row, record, h, R, r, v, w, rod, inputs, save_slot, work_f, coef_k, tangent)
    return loads
