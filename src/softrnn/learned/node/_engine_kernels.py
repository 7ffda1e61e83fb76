"""Compiled forward pass of stacked node LSTMs (the inference engine's numba kernels).

The weights of M models of one architecture are packed by ``softrnn.learned.node.engine.pack`` into

* ``params`` (M, S) float32: per model, the LSTM layers (input weights transposed (in, 4U),
  recurrent weights transposed (U, 4U), summed bias (4U)), the wrench and head dense layers
  (transposed (in, out) and bias), the output layer and the linear skip (transposed), then the
  difference scale and shift (P each). Rows of tanh units (the LSTM's cell gate g, the dense layers)
  are stored times 2, so every activation is one logistic: tanh(x) = 2 sigma(2x) - 1.
* ``norm`` (M, Sn) float64: pose mean and std (P each), wrench mean and std (W each), target mean
  and std (3 each).
* ``arch`` (1,) ``ARCHITECTURE`` record: the architecture and the offsets of the output layer, the
  skip and the difference scaling in a params row;
* ``layers`` (NL + wrench dense + head dense,) ``LAYER`` records: per LSTM layer, then per dense
  layer of the wrench branch and of the head, the offsets of its weights and bias in a params row
  and its widths.

The layouts are NumPy structured arrays rather than ``typing.NamedTuple`` records (as the rod
kernels take): numba's dispatcher types an array argument with less work than a named tuple of many
fields, and the batch-1 steppers make one kernel call per step.

The logistic is computed in float32 with a range-reduced degree-7 exponential (max error 9e-8
against the exact logistic), in two passes over a contiguous row so LLVM vectorises both (the
exponent is built in an int32 scratch row and read through a float32 view). Its argument is
clamped to +-30, where the float32 logistic is already 1 (or below 1e-13): with the clamp at the
float range (+-87) a saturated gate makes a subnormal intermediate, which slows the whole forward
pass severalfold.
"""

import numpy as np
from numba import njit, prange

FM = {"contract", "nnan", "ninf", "nsz", "arcp", "afn"}
_LOG2E = np.float32(1.4426950408889634)
_LN2 = np.float32(0.6931471805599453)

ARCHITECTURE = np.dtype([
    ("pose_features", np.int64),     # P: values of input I per window row
    ("wrench_features", np.int64),   # W: values of input II per window row
    ("history", np.int64),           # H: window rows
    ("lstm_layers", np.int64),       # NL: the first NL rows of ``layers``
    ("lstm_units", np.int64),        # U
    ("lstm_inputs", np.int64),       # the first LSTM layer's inputs: P, or 2 P with differences
    ("differences", np.int64),       # 1: input I's scaled differences follow it in the LSTM input
    ("relative", np.int64),          # 1: positions relative to the node's last one
    ("per_node", np.int64),          # values per node in a row of input I: 3 (positions) or 7 (poses)
    ("wrench_dense", np.int64),      # dense layers of the wrench branch: the ``layers`` rows after the LSTM's
    ("head_dense", np.int64),        # dense layers of the head: the rows after those
    ("features", np.int64),          # the head's inputs: the U hidden values, then the wrench branch's
    ("output", np.int64),            # OUT_INCREMENT, OUT_ACCELERATION or OUT_POSE
    ("off_out", np.int64),           # the output layer: weights (out_inputs, 3), then bias (3)
    ("out_inputs", np.int64),
    ("skip", np.int64),              # 1: a linear skip from the normalised windows to the output
    ("off_skip", np.int64),          # its weights (skip_inputs, 3)
    ("skip_inputs", np.int64),
    ("off_delta_scale", np.int64),   # the differences' scale (P)
    ("off_delta_shift", np.int64),   # and shift (P)
    ("params_length", np.int64),     # S: the length of a params row
    ("work_length", np.int64),       # the length of one node's work row (``work_size``)
])
"""The architecture of stacked node models and offsets into their params rows (``engine.pack``)."""

LAYER = np.dtype([
    ("off_w", np.int64),             # input weights, transposed (n_in, n_out)
    ("off_u", np.int64),             # an LSTM layer's recurrent weights, transposed (U, 4 U); -1 for a dense layer
    ("off_b", np.int64),             # bias (n_out)
    ("n_in", np.int64),
    ("n_out", np.int64),             # 4 U for an LSTM layer
])
"""One layer's offsets into a params row and its widths (``engine.pack``)."""

OUT_INCREMENT, OUT_ACCELERATION, OUT_POSE = 0, 1, 2

# work row regions: see ``work_size``


@njit(fastmath=FM, cache=True, inline="always")
def _logistic(a, lo, n, eb, ebf):
    """a[lo:lo+n] <- sigma(a[lo:lo+n]) in place (eb int32 scratch, ebf its float32 view).

    Indices are unsigned so numba emits no negative-index wraparound (which would turn the
    vectorised loads and stores into gathers and scatters)."""
    o = np.uint64(lo)
    for i in range(np.uint64(n)):
        x = -a[o + i]
        x = np.float32(30.0) if x > np.float32(30.0) else x
        x = np.float32(-30.0) if x < np.float32(-30.0) else x
        k = np.floor(x * _LOG2E + np.float32(0.5))
        r = x - k * _LN2
        p = np.float32(1.0 / 5040.0)
        p = p * r + np.float32(1.0 / 720.0)
        p = p * r + np.float32(1.0 / 120.0)
        p = p * r + np.float32(1.0 / 24.0)
        p = p * r + np.float32(1.0 / 6.0)
        p = p * r + np.float32(0.5)
        p = p * r + np.float32(1.0)
        p = p * r + np.float32(1.0)
        a[o + i] = p
        eb[i] = np.int32((k + np.float32(127.0)) * np.float32(8388608.0))
    for i in range(np.uint64(n)):
        a[o + i] = np.float32(1.0) / (np.float32(1.0) + a[o + i] * ebf[i])


@njit(fastmath=FM, cache=True, inline="always")
def _accumulate(p, off_w, n_in, n_out, x, xlo, y, ylo):
    """y[ylo:ylo+n_out] += W x[xlo:xlo+n_in] with W stored transposed (n_in, n_out) at off_w;
    unsigned indices as in ``_logistic``."""
    no = np.uint64(n_out)
    yl = np.uint64(ylo)
    xl = np.uint64(xlo)
    ow = np.uint64(off_w)
    for i in range(np.uint64(n_in)):
        xi = x[xl + i]
        o = ow + i * no
        for j in range(no):
            y[yl + j] += xi * p[o + j]


@njit(fastmath=FM, cache=True, inline="always")
def _affine(p, off_w, off_b, n_in, n_out, x, xlo, y, ylo):
    """y[ylo:ylo+n_out] = W x[xlo:xlo+n_in] + b (off_b < 0: no bias); see ``_accumulate``."""
    no = np.uint64(n_out)
    yl = np.uint64(ylo)
    if off_b >= 0:
        ob = np.uint64(off_b)
        for j in range(no):
            y[yl + j] = p[ob + j]
    else:
        for j in range(no):
            y[yl + j] = np.float32(0.0)
    _accumulate(p, off_w, n_in, n_out, x, xlo, y, ylo)


@njit(fastmath=FM, cache=True, inline="always")
def _cell(wk, o_g, o_c, o_f, U):
    """Cell update from the activated gates i, f, g (g stored as sigma(2x): tanh = 2 sigma - 1), o at
    wk[o_g:o_g+4U]: c <- f c + i g at wk[o_c:o_c+U]; wk[o_f:o_f+U] <- 2c (for tanh(c) by the logistic)."""
    g, c0, f0, u_n = np.uint64(o_g), np.uint64(o_c), np.uint64(o_f), np.uint64(U)
    for u in range(u_n):
        c = wk[g + u_n + u] * wk[c0 + u] + wk[g + u] * (np.float32(2.0) * wk[g + np.uint64(2) * u_n + u]
                                                         - np.float32(1.0))
        wk[c0 + u] = c
        wk[f0 + u] = np.float32(2.0) * c


@njit(fastmath=FM, cache=True, inline="always")
def _hidden(wk, o_o, o_f, o_h, U):
    """h = o tanh(c) into wk[o_h:o_h+U], with sigma(2c) at wk[o_f:] and the o gate at wk[o_o:]."""
    a, f0, h0 = np.uint64(o_o), np.uint64(o_f), np.uint64(o_h)
    for u in range(np.uint64(U)):
        wk[h0 + u] = wk[a + u] * (np.float32(2.0) * wk[f0 + u] - np.float32(1.0))


def work_size(arch, layers) -> int:
    """Length of one node's float32 work row (see ``forward``)."""
    net = arch[0]
    H, U, in1, feat = int(net["history"]), int(net["lstm_units"]), int(net["lstm_inputs"]), int(net["features"])
    widest = max(4 * U, feat, int(net["skip_inputs"]), 8)
    nl = int(net["lstm_layers"])
    for k in range(int(net["wrench_dense"]) + int(net["head_dense"])):
        widest = max(widest, int(layers[nl + k]["n_out"]))
    return H * in1 + 2 * H * U + U + 4 * widest + int(net["wrench_features"]) * H + 8


@njit(fastmath=FM, cache=True)
def forward(p, nrm, arch, layers, xw, ww, wk, eb, ebf, out):
    """One node's next position from its physical window.

    p (S,) float32 params row; nrm (Sn,) float64 normalisation row; arch, layers the layout;
    xw (H, P) float32 physical input I [m, 1]; ww (H, W) float32 physical input II [N, N m];
    wk (work_size,) float32 work row; eb (>= widest,) int32 scratch and ebf its float32 view;
    out (3,) float64 <- the node's position at the next step [m].
    """
    net = arch[0]
    P, W, H, NL, U = net.pose_features, net.wrench_features, net.history, net.lstm_layers, net.lstm_units
    diff, rel, per = net.differences, net.relative, net.per_node
    in1 = net.lstm_inputs
    G = 4 * U
    # regions of the work row
    o_x = 0                         # (H, in1) LSTM input sequence, then the skip input
    o_h = o_x + H * in1             # (2, H, U) hidden sequences of two layers (ping-pong)
    o_c = o_h + 2 * H * U           # (U,) cell state
    o_g = o_c + U                   # (widest,) gates / dense activations
    widest = (wk.shape[0] - o_g - W * H - 8) // 4
    o_f = o_g + widest              # (widest,) features
    o_d = o_f + widest              # (widest,) dense buffer
    o_s = o_d + widest              # (widest,) skip input (x flat then wrench flat)
    o_w = o_s + widest              # (H*W,) normalised wrenches
    # ---- input I normalised (float64 like Normalizer, then float32)
    lx0 = np.float64(xw[H - 1, 0])
    lx1 = np.float64(xw[H - 1, 1])
    lx2 = np.float64(xw[H - 1, 2])
    for j in range(H):
        for c in range(P):
            wk[o_x + j * in1 + c] = np.float32((np.float64(xw[j, c]) - nrm[c]) / nrm[P + c])
        if rel != 0:   # positions relative to the node's last one (the first 3 values of each node)
            for a in range(0, P, per):
                for q, last in ((0, lx0), (1, lx1), (2, lx2)):
                    c = a + q
                    wk[o_x + j * in1 + c] = np.float32((np.float64(xw[j, c]) - last - nrm[c]) / nrm[P + c])
    if diff != 0:
        ods, odsh = net.off_delta_scale, net.off_delta_shift
        for c in range(P):
            wk[o_x + P + c] = np.float32(0.0)
        for j in range(1, H):
            for c in range(P):
                wk[o_x + j * in1 + P + c] = ((wk[o_x + j * in1 + c] - wk[o_x + (j - 1) * in1 + c]) * p[ods + c]
                                             - p[odsh + c])
    # ---- input II normalised
    for j in range(H):
        for c in range(W):
            wk[o_w + j * W + c] = np.float32((np.float64(ww[j, c]) - nrm[2 * P + c]) / nrm[2 * P + W + c])
    # ---- LSTM layers over the window, zero initial state
    src, n_src = o_x, in1
    for layer in range(NL):
        rec = layers[layer]
        off_ih, off_hh, off_b, n_in = rec.off_w, rec.off_u, rec.off_b, rec.n_in
        dst = o_h + (layer % 2) * H * U
        for u in range(U):
            wk[o_c + u] = np.float32(0.0)
        for j in range(H):
            _affine(p, off_ih, off_b, n_in, G, wk, src + j * n_src, wk, o_g)
            if j > 0:
                _accumulate(p, off_hh, U, G, wk, dst + (j - 1) * U, wk, o_g)   # + W_hh h
            _logistic(wk, o_g, G, eb, ebf)
            _cell(wk, o_g, o_c, o_f, U)
            _logistic(wk, o_f, U, eb, ebf)
            _hidden(wk, o_g + 3 * U, o_f, dst + j * U, U)
        src, n_src = dst, U
    # ---- features: last hidden state, then the wrench branch
    for u in range(U):
        wk[o_f + u] = wk[src + (H - 1) * U + u]
    n_feat = U
    nwd, nhd = net.wrench_dense, net.head_dense
    if W > 0:
        cur, n_cur = o_w, H * W
        for k in range(nwd):
            r = layers[NL + k]
            _affine(p, r.off_w, r.off_b, r.n_in, r.n_out, wk, cur, wk, o_d)
            _logistic(wk, o_d, r.n_out, eb, ebf)
            for q in range(r.n_out):
                wk[o_g + q] = np.float32(2.0) * wk[o_d + q] - np.float32(1.0)
            cur, n_cur = o_g, r.n_out
        for q in range(n_cur):
            wk[o_f + n_feat + q] = wk[cur + q]
        n_feat += n_cur
    # ---- head dense layers
    cur = o_f
    for k in range(nhd):
        r = layers[NL + nwd + k]
        _affine(p, r.off_w, r.off_b, r.n_in, r.n_out, wk, cur, wk, o_d)
        _logistic(wk, o_d, r.n_out, eb, ebf)
        dst = o_g if cur != o_g else o_s
        for q in range(r.n_out):
            wk[dst + q] = np.float32(2.0) * wk[o_d + q] - np.float32(1.0)
        cur = dst
    # ---- output layer (+ linear skip of the LSTM input window and the wrench window)
    _affine(p, net.off_out, net.off_out + 3 * net.out_inputs, net.out_inputs, 3, wk, cur, wk, o_d)
    if net.skip != 0:
        n_x = H * in1
        off = net.off_skip
        for i in range(n_x):
            xi = wk[o_x + i]
            for q in range(3):
                wk[o_d + q] += xi * p[off + i * 3 + q]
        for i in range(H * W):
            xi = wk[o_w + i]
            for q in range(3):
                wk[o_d + q] += xi * p[off + (n_x + i) * 3 + q]
    # ---- denormalise (float64, like Normalizer.denormalise_outputs)
    tm = 2 * P + 2 * W
    mode = net.output
    for q in range(3):
        y = np.float64(wk[o_d + q]) * nrm[tm + 3 + q] + nrm[tm + q]
        if mode == OUT_INCREMENT:
            y += np.float64(xw[H - 1, q])
        elif mode == OUT_ACCELERATION:
            y += 2.0 * np.float64(xw[H - 1, q]) - np.float64(xw[H - 2, q])
        out[q] = y


@njit(cache=True)
def predict_windows(params, norm, arch, layers, which, X, Wr, wk, eb, out):
    """Batched stateless prediction: window b uses model ``which[b]``.

    X (B, H, P) float32; Wr (B, H, W) float32; wk (work_size,) float32; eb int32 scratch;
    out (B, 3) float64 [m]."""
    ebf = eb.view(np.float32)
    o3 = np.empty(3)
    for b in range(X.shape[0]):
        m = which[b]
        forward(params[m], norm[m], arch, layers, X[b], Wr[b], wk, eb, ebf, o3)
        for q in range(3):
            out[b, q] = o3[q]


@njit(cache=True)
def gather_window(pos, quat, rows, cols, per, xw):
    """xw (H, P) <- the window of one node: for each of the H ``rows`` of pos (T, N, 3) and quat
    (T, N, 4) float32, the ``cols`` nodes' positions (per = 3) or positions then quaternions (per = 7)."""
    for j in range(rows.shape[0]):
        k = rows[j]
        for a in range(cols.shape[0]):
            col = cols[a]
            for c in range(3):
                xw[j, a * per + c] = pos[k, col, c]
            if per == 7:
                for c in range(4):
                    xw[j, a * per + 3 + c] = quat[k, col, c]


@njit(cache=True, inline="always")
def _window_rows(k, H):
    """The rows k-H .. k-1 (H,) int64 a prediction of row k reads."""
    rows = np.empty(H, np.int64)
    for j in range(H):
        rows[j] = k - H + j
    return rows


@njit(cache=True, inline="always")
def _gather_node(pos, quat, wrench, rows, cols, b, per, xw, ww):
    """Node b's windows: xw (H, P) as ``gather_window``, ww (H, W) <- its wrench rows ``rows`` of
    ``wrench`` (T, B, W)."""
    gather_window(pos, quat, rows, cols, per, xw)
    for j in range(rows.shape[0]):
        for c in range(ww.shape[1]):
            ww[j, c] = wrench[rows[j], b, c]


@njit(cache=True, inline="always")
def _first_beyond(pred, n, limit):
    """(1, b) for the first of the n nodes b whose prediction pred (n, 3) is not finite or beyond
    ``limit`` [m]; (0, -1) when none is."""
    for b in range(n):
        for q in range(3):
            if not (abs(pred[b, q]) <= limit):
                return 1, b
    return 0, -1


@njit(cache=True, inline="always")
def _write_row(pos, k, tgt_cols, pred):
    """Row k of pos (T, N, 3) float32 <- the predictions pred (B, 3) at columns ``tgt_cols``."""
    for b in range(tgt_cols.shape[0]):
        for q in range(3):
            pos[k, tgt_cols[b], q] = np.float32(pred[b, q])


@njit(cache=True)
def rollout_steps(params, norm, arch, layers, which, in_cols, tgt_cols, pos, quat, wrench, k0, k1, limit, pred, wk,
                  eb):
    """Free-running steps k0 .. k1-1 of the rows of ``pos`` (T, N, 3) float32, in place.

    At step k every modelled node b (model ``which[b]``, window columns ``in_cols[b]``, own column
    ``tgt_cols[b]``) reads rows k-H .. k-1 of pos and quat (T, N, 4) and its wrench rows of
    ``wrench`` (T, B, W) float32; all predictions (pred (B, 3) float64 scratch) are computed before
    any is written to row k (synchronous update). Returns (status, b, k): status 0 done, 1 a
    prediction was not finite or beyond ``limit`` [m] (node b, step k)."""
    for k in range(k0, k1):
        status, b = predict_row(params, norm, arch, layers, which, in_cols, pos, quat, wrench, k, limit, pred, wk, eb)
        if status != 0:
            return status, b, k
        _write_row(pos, k, tgt_cols, pred)
    return 0, -1, k1


# ---------------------------------------------------------------------- one node, one call per step
# A NodeStepper keeps its arrays in two buffers so a step costs one dispatch with few arguments:
# f32 = [params row (S) | window I (H*P) | window II (H*W) | work row | exponent scratch (work row's length)],
# f64 = [norm row | out (3)].


@njit(cache=True)
def node_step(f32, f64, arch, layers, pose, wrench, push):
    """Append ``pose`` (P,) and ``wrench`` (W,) to the windows (if ``push``) and predict the next
    position into the last 3 values of f64."""
    net = arch[0]
    H, P, W, S, n_work = net.history, net.pose_features, net.wrench_features, net.params_length, net.work_length
    o_x = S
    o_w = o_x + H * P
    o_wk = o_w + H * W
    o_eb = o_wk + n_work
    o_out = f64.shape[0] - 3
    x = f32[o_x:o_x + H * P].reshape(H, P)
    w = f32[o_w:o_w + H * W].reshape(H, W)
    if push:
        for j in range(H - 1):
            for c in range(P):
                x[j, c] = x[j + 1, c]
            for c in range(W):
                w[j, c] = w[j + 1, c]
        for c in range(P):
            x[H - 1, c] = pose[c]
        for c in range(W):
            w[H - 1, c] = wrench[c]
    scratch = f32[o_eb:o_eb + n_work]
    forward(f32[:S], f64[:o_out], arch, layers, x, w, f32[o_wk:o_wk + n_work], scratch.view(np.int32), scratch,
            f64[o_out:o_out + 3])


@njit(cache=True)
def predict_row(params, norm, arch, layers, which, in_cols, pos, quat, wrench, k, limit, pred, wk, eb):
    """pred (B, 3) float64 <- every node's prediction of row k of ``pos`` from rows k-H .. k-1
    (nothing is written to pos). Returns (status, b) as ``rollout_steps``."""
    net = arch[0]
    H, P, W, per = net.history, net.pose_features, net.wrench_features, net.per_node
    ebf = eb.view(np.float32)
    xw = np.empty((H, P), np.float32)
    ww = np.empty((H, W), np.float32)
    rows = _window_rows(k, H)
    o3 = np.empty(3)
    for b in range(which.shape[0]):
        _gather_node(pos, quat, wrench, rows, in_cols[b], b, per, xw, ww)
        forward(params[which[b]], norm[which[b]], arch, layers, xw, ww, wk, eb, ebf, o3)
        for q in range(3):
            if not (abs(o3[q]) <= limit):
                return 1, b
            pred[b, q] = o3[q]
    return 0, -1


@njit(cache=True, parallel=True)
def predict_row_parallel(params, norm, arch, layers, which, in_cols, pos, quat, wrench, k, limit, pred, wk2, eb2,
                         flags):
    """``predict_row`` with the nodes split over numba's threads; wk2 (B, work) float32 and eb2
    (B, work) int32 give every node its own scratch row, flags (B,) int64 scratch."""
    net = arch[0]
    H, P, W, per = net.history, net.pose_features, net.wrench_features, net.per_node
    B = which.shape[0]
    for b in prange(B):
        xw = np.empty((H, P), np.float32)
        ww = np.empty((H, W), np.float32)
        rows = _window_rows(k, H)
        o3 = np.empty(3)
        _gather_node(pos, quat, wrench, rows, in_cols[b], b, per, xw, ww)
        eb = eb2[b]
        forward(params[which[b]], norm[which[b]], arch, layers, xw, ww, wk2[b], eb, eb.view(np.float32), o3)
        flags[b] = 0
        for q in range(3):
            if not (abs(o3[q]) <= limit):
                flags[b] = 1
            pred[b, q] = o3[q]
    for b in range(B):
        if flags[b] != 0:
            return 1, b
    return 0, -1


@njit(cache=True)
def commit_row(pos, quat, wrench, wrench_next, tgt_cols, pred, hold):
    """Close one manipulator sample: row H of pos (H+1, N, 3) gets the boundary positions (or,
    if ``hold``, row H-1) and then the predictions pred (B, 3) at columns ``tgt_cols``; row H of
    quat copies row H-1, row H of wrench (H+1, B, W) becomes ``wrench_next`` (B, W); every array
    moves up one row."""
    H = pos.shape[0] - 1
    if hold:
        for a in range(pos.shape[1]):
            for c in range(3):
                pos[H, a, c] = pos[H - 1, a, c]
    _write_row(pos, H, tgt_cols, pred)
    for a in range(quat.shape[1]):
        for c in range(4):
            quat[H, a, c] = quat[H - 1, a, c]
    for b in range(wrench.shape[1]):
        for c in range(wrench.shape[2]):
            wrench[H, b, c] = wrench_next[b, c]
    for j in range(H):
        for a in range(pos.shape[1]):
            for c in range(3):
                pos[j, a, c] = pos[j + 1, a, c]
            for c in range(4):
                quat[j, a, c] = quat[j + 1, a, c]
        for b in range(wrench.shape[1]):
            for c in range(wrench.shape[2]):
                wrench[j, b, c] = wrench[j + 1, b, c]


# ------------------------------------------------ many nodes, one shared weight set, through BLAS
# For a model shared by many nodes every layer is one matrix product over all nodes (B x in) @
# (in x out): BLAS's sgemm runs it near the machine's peak, and the activations are one vectorised
# pass over the (B, out) block. Equal to ``forward`` within float32 rounding (the sums run in
# another order).


@njit(fastmath=FM, cache=True)
def _mat(p, off, n_in, n_out):
    """The transposed weights (n_in, n_out) stored at ``off`` of a params row, as a view."""
    return p[off:off + n_in * n_out].reshape(n_in, n_out)


@njit(fastmath=FM, cache=True)
def _dense(x, p, off_w, off_b, n_in, n_out):
    """x (B, n_in) @ W (n_in, n_out) + b (off_b < 0: no bias) -> new (B, n_out) float32."""
    y = np.dot(x, _mat(p, off_w, n_in, n_out))
    if off_b >= 0:
        for b in range(y.shape[0]):
            for j in range(n_out):
                y[b, j] += p[off_b + j]
    return y


@njit(fastmath=FM, cache=True)
def _sigma_block(y, eb):
    """y (B, n) <- sigma(y) in place (eb int32 scratch of >= B n values)."""
    flat = y.reshape(-1)
    n = flat.shape[0]
    _logistic(flat, 0, n, eb, eb.view(np.float32))


@njit(fastmath=FM, cache=True)
def _tanh_dense(x, p, r, eb):
    """The tanh dense layer r (a ``LAYER``) on x (B, n_in) -> new (B, n_out) float32, as
    2 sigma(.) - 1 of its doubled affine map (eb int32 scratch of >= B n_out values)."""
    y = _dense(x, p, r.off_w, r.off_b, r.n_in, r.n_out)
    _sigma_block(y, eb)
    for b in range(y.shape[0]):
        for q in range(r.n_out):
            y[b, q] = np.float32(2.0) * y[b, q] - np.float32(1.0)
    return y


@njit(fastmath=FM, cache=True)
def forward_gemm(p, nrm, arch, layers, X, Wr, eb, out):
    """``forward`` for B nodes sharing one model, every layer one BLAS product.

    X (B, H, P), Wr (B, H, W) float32 physical windows; eb (>= B * widest,) int32 scratch;
    out (B, 3) float64 [m]."""
    net = arch[0]
    P, W, H, NL, U = net.pose_features, net.wrench_features, net.history, net.lstm_layers, net.lstm_units
    diff, rel, per = net.differences, net.relative, net.per_node
    in1 = net.lstm_inputs
    G = 4 * U
    B = X.shape[0]
    zs = np.empty((H, B, in1), np.float32)                 # LSTM input sequence
    n_skip = H * in1 + H * W
    sk = np.empty((B, n_skip), np.float32)                 # skip input: the window, then the wrenches
    wn = np.empty((B, H * W), np.float32)                  # normalised wrench window
    for b in range(B):
        lx0 = np.float64(X[b, H - 1, 0])
        lx1 = np.float64(X[b, H - 1, 1])
        lx2 = np.float64(X[b, H - 1, 2])
        for j in range(H):
            for c in range(P):
                zs[j, b, c] = np.float32((np.float64(X[b, j, c]) - nrm[c]) / nrm[P + c])
            if rel != 0:
                for a0 in range(0, P, per):
                    for q, last in ((0, lx0), (1, lx1), (2, lx2)):
                        cc = a0 + q
                        zs[j, b, cc] = np.float32((np.float64(X[b, j, cc]) - last - nrm[cc]) / nrm[P + cc])
            for c in range(W):
                wn[b, j * W + c] = np.float32((np.float64(Wr[b, j, c]) - nrm[2 * P + c]) / nrm[2 * P + W + c])
        if diff != 0:
            ods, odsh = net.off_delta_scale, net.off_delta_shift
            for c in range(P):
                zs[0, b, P + c] = np.float32(0.0)
            for j in range(1, H):
                for c in range(P):
                    zs[j, b, P + c] = (zs[j, b, c] - zs[j - 1, b, c]) * p[ods + c] - p[odsh + c]
        for j in range(H):
            for c in range(in1):
                sk[b, j * in1 + c] = zs[j, b, c]
        for i in range(H * W):
            sk[b, H * in1 + i] = wn[b, i]
    seq = zs
    hs = np.empty((H, B, U), np.float32)
    for layer in range(NL):
        rec = layers[layer]
        off_ih, off_hh, off_b, n_in = rec.off_w, rec.off_u, rec.off_b, rec.n_in
        hs = np.empty((H, B, U), np.float32)
        c = np.zeros((B, U), np.float32)
        for j in range(H):
            g = _dense(seq[j], p, off_ih, off_b, n_in, G)
            if j > 0:
                g += np.dot(hs[j - 1], _mat(p, off_hh, U, G))
            _sigma_block(g, eb)
            t = np.empty((B, U), np.float32)
            for b in range(B):
                for u in range(U):
                    cc = g[b, U + u] * c[b, u] + g[b, u] * (np.float32(2.0) * g[b, 2 * U + u] - np.float32(1.0))
                    c[b, u] = cc
                    t[b, u] = np.float32(2.0) * cc
            _sigma_block(t, eb)
            for b in range(B):
                for u in range(U):
                    hs[j, b, u] = g[b, 3 * U + u] * (np.float32(2.0) * t[b, u] - np.float32(1.0))
        seq = hs
    nwd, nhd = net.wrench_dense, net.head_dense
    feat_w = wn
    if W > 0:
        for k in range(nwd):
            feat_w = _tanh_dense(feat_w, p, layers[NL + k], eb)
    n_w = feat_w.shape[1] if W > 0 else 0
    feat = np.empty((B, U + n_w), np.float32)
    for b in range(B):
        for u in range(U):
            feat[b, u] = seq[H - 1, b, u]
        for q in range(n_w):
            feat[b, U + q] = feat_w[b, q]
    cur = feat
    for k in range(nhd):
        cur = _tanh_dense(cur, p, layers[NL + nwd + k], eb)
    y = _dense(cur, p, net.off_out, net.off_out + 3 * net.out_inputs, net.out_inputs, 3)
    if net.skip != 0:
        y += np.dot(sk, _mat(p, net.off_skip, n_skip, 3))
    tm = 2 * P + 2 * W
    mode = net.output
    for b in range(B):
        for q in range(3):
            v = np.float64(y[b, q]) * nrm[tm + 3 + q] + nrm[tm + q]
            if mode == OUT_INCREMENT:
                v += np.float64(X[b, H - 1, q])
            elif mode == OUT_ACCELERATION:
                v += 2.0 * np.float64(X[b, H - 1, q]) - np.float64(X[b, H - 2, q])
            out[b, q] = v


@njit(cache=True)
def _gather_all(arch, in_cols, pos, quat, wrench, k, X, Wr):
    """X (B, H, P) and Wr (B, H, W) <- every node's windows for row k (rows k-H .. k-1)."""
    net = arch[0]
    H, per = net.history, net.per_node
    rows = _window_rows(k, H)
    for b in range(in_cols.shape[0]):
        _gather_node(pos, quat, wrench, rows, in_cols[b], b, per, X[b], Wr[b])


@njit(cache=True)
def predict_row_shared(params, norm, arch, layers, in_cols, pos, quat, wrench, k, limit, pred, X, Wr, eb):
    """``predict_row`` for nodes that all use model 0 of ``params``, through ``forward_gemm``;
    X (B, H, P), Wr (B, H, W) float32 window scratch, eb int32 scratch."""
    B = in_cols.shape[0]
    _gather_all(arch, in_cols, pos, quat, wrench, k, X, Wr)
    forward_gemm(params[0], norm[0], arch, layers, X, Wr, eb, pred)
    return _first_beyond(pred, B, limit)


@njit(cache=True)
def rollout_steps_shared(params, norm, arch, layers, in_cols, tgt_cols, pos, quat, wrench, k0, k1, limit, pred, X,
                         Wr, eb):
    """``rollout_steps`` for nodes that all use model 0, through ``forward_gemm``."""
    for k in range(k0, k1):
        status, b = predict_row_shared(params, norm, arch, layers, in_cols, pos, quat, wrench, k, limit, pred, X, Wr,
                                       eb)
        if status != 0:
            return status, b, k
        _write_row(pos, k, tgt_cols, pred)
    return 0, -1, k1


@njit(cache=True, parallel=True)
def predict_row_shared_parallel(params, norm, arch, layers, in_cols, pos, quat, wrench, k, limit, pred, X, Wr, eb,
                                chunks):
    """``predict_row_shared`` with the nodes cut into ``chunks`` (C+1,) boundaries, one BLAS pass per
    chunk on numba's threads; eb (C, n) int32 scratch, one row per chunk."""
    B = in_cols.shape[0]
    _gather_all(arch, in_cols, pos, quat, wrench, k, X, Wr)
    n_chunks = chunks.shape[0] - 1
    for i in prange(n_chunks):
        lo, hi = chunks[i], chunks[i + 1]
        forward_gemm(params[0], norm[0], arch, layers, X[lo:hi], Wr[lo:hi], eb[i], pred[lo:hi])
    return _first_beyond(pred, B, limit)
