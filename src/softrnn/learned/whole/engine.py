"""``DynamicEngine``: a trained whole-manipulator model in NumPy, stepping free on one core.

The same arithmetic as ``DynamicNet.forward`` (NumPy, no PyTorch; the envelope gate is one small
numba kernel, ``envelope_gate_into``): the global linear term is one
matrix-vector product, each convolution along the rod one small matrix product over a sliding
window of the padded node axis. It is what ``softrnn dynamic rollout``, the evaluation and the
benchmark run, and what a control loop would call.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.lib.stride_tricks import as_strided

from ...errors import SimulationError, bad
from .. import horizons
from .config import conv_channels, path_columns

DIVERGED_M = horizons.DIVERGED_M
"""A state component beyond this (m or rad) ends a free run as diverged (the node models' limit,
``softrnn.learned.horizons.DIVERGED_M``)."""
_C = float(np.sqrt(2.0 / np.pi))


def _twice_gelu_(x: np.ndarray) -> None:
    """2 GELU(x) (tanh form, as ``nn.GELU(approximate="tanh")``) in place; the factor 2 is taken out
    of the next layer's weights (one array operation less per layer)."""
    t = x * x
    t *= 0.044715 * _C
    t += _C
    t *= x
    np.tanh(t, out=t)
    t += 1.0
    x *= t


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return 0.5 * (1.0 + np.tanh(0.5 * x))


@njit(cache=True, error_model="numpy")
def envelope_gate_into(g, lo, hi, inv, gate):
    """The envelope (``DynamicNet.envelope_gate``) in one pass: ``gate`` (M, 1) <- max(0, 1 - the
    largest over channels of (distance outside [lo, hi]) inv) per node; ``g`` (M, G) clipped in
    place at 1 / inv beyond the range (a channel with inv 0 to the range itself, and it never
    gates). Returns whether any node is outside (gate below 1)."""
    M, G = g.shape
    outside = False
    for i in range(M):
        worst = 0.0
        for c in range(G):
            if inv[c] == 0.0:                       # a channel the data never vary: held in its range
                g[i, c] = min(max(g[i, c], lo[c]), hi[c])
            else:
                x = g[i, c]
                d = lo[c] - x if x < lo[c] else x - hi[c]
                if d > 0.0:
                    d *= inv[c]
                    if d > worst:
                        worst = d
                    if d > 1.0:                     # clip at the margin (d = 1)
                        g[i, c] = lo[c] - 1.0 / inv[c] if x < lo[c] else hi[c] + 1.0 / inv[c]
        gate[i, 0] = max(0.0, 1.0 - worst)
        if worst > 0.0:
            outside = True
    return outside


class Diverged(SimulationError):
    """A free run left the range of a rod (non-finite or beyond ``DIVERGED_M``) at model ``step``."""

    def __init__(self, message: str, step: int):
        super().__init__(message)
        self.step = int(step)


class DynamicEngine:
    """Step a trained model: ``step(hist, loads)`` and ``run(hist, loads)``.

    Parameters
    ----------
    weights : dict of ndarray
        ``DynamicNet.state_dict()`` as NumPy arrays (``load_dynamic`` reads them from a folder).
    config : DynamicConfig
        The network's configuration (saved with the weights).
    dtype : numpy dtype
        The network's arithmetic (features, linear term, convolution; float32 by default, as the
        network was trained and as ONNX exports it, and faster in BLAS than float64). The
        state update ``x + v + dv`` is always float64. ``np.float64`` reproduces a float64
        ``DynamicNet`` to rounding.
    """

    def __init__(self, weights: dict, config, dtype=np.float32):
        dt = np.dtype(dtype)
        w = {k: np.asarray(v, dtype=np.float64) for k, v in weights.items()}
        self.config = config
        self.dtype = dt
        self.history = int(config.history)
        self.bound = float(config.bound)
        self.node_features = w["node_features"]
        self.fixed = np.asarray(weights["fixed"], dtype=bool)
        self.prescribed = np.asarray(weights.get("prescribed", np.zeros_like(self.fixed)), dtype=bool)
        # the scales under their saved keys (network.SCALE_KEYS)
        self.state_scale, self.velocity_scale, self.load_scale, self.dv_scale = w["sx"], w["sv"], w["su"], w["sa"]
        self.n_kept = M = int(self.node_features.shape[0])
        H = self.history
        self.linear = None
        if "linear.weight" in w:
            self.linear = (w["linear.weight"].T.astype(dt), w["linear.bias"].astype(dt))
        self.cell = None
        if "cell.weight_ih" in w:
            self.cell = (w["cell.weight_ih"].T.astype(dt), w["cell.weight_hh"].T.astype(dt),
                         (w["cell.bias_ih"] + w["cell.bias_hh"]).astype(dt))
        # features (M, C): state, H-1 velocities, load (L channels), constants; the convolution reads all but the load
        self.load_width = L = int(self.load_scale.shape[0])
        self.prescribed_columns = path_columns(self.prescribed, L)   # where each one's path change sits
        C = 6 * H + L + self.node_features.shape[1]
        self._f = np.zeros((M, C), dtype=dt)
        self._f[:, 6 * H + L:] = self.node_features
        self._scale = np.concatenate([1.0 / self.state_scale] + [1.0 / self.velocity_scale] * (H - 1)
                                     + [1.0 / self.load_scale]).astype(dt)
        contact = None                  # the contact inputs among the loads (DynamicNet.contact_columns), if any
        if "contact_columns" in w:
            contact = slice(*(int(v) for v in w["contact_columns"]))
        self._keep = np.asarray(conv_channels(H, config.conv_reads, L, contact))
        self.envelope = None            # the correction's input range (DynamicNet.set_envelope), if any
        if "env_lo" in w:
            self.envelope = tuple(w[k].astype(dt) for k in ("env_lo", "env_hi", "env_inv"))
            self._gate_buf = np.empty((M, 1), dtype=dt)
        convs = sorted({int(k.split(".")[1]) for k in w if k.startswith("conv.")})
        self.convs = []
        for i in convs:
            W = w[f"conv.{i}.weight"]                          # (Cout, Cin, k)
            cout, cin, k = W.shape
            # rows ordered (tap, channel) to match the strided view of the padded buffer below
            Wk = np.ascontiguousarray(W.transpose(2, 1, 0).reshape(k * cin, cout))
            Wk = (0.5 * Wk if self.convs else Wk).astype(dt)     # after a layer: its input is 2 GELU
            pad = k // 2
            buf = np.zeros((M + 2 * pad, cin), dtype=dt)       # zero padding along the rod, reused
            s0, s1 = buf.strides
            # the windows (M, k*cin) overlap in memory; BLAS needs them copied to a contiguous block
            view = as_strided(buf, shape=(M, k * cin), strides=(s0, s1)) if k > 1 else buf
            cols = np.empty((M, k * cin), dtype=dt)
            self.convs.append((Wk, w[f"conv.{i}.bias"].astype(dt), pad, buf, view, cols,
                               np.empty((M, cout), dtype=dt)))

    def _conv(self, g: np.ndarray) -> np.ndarray:
        """(M, Cin) -> (M, 6) through the convolution stack (GELU between layers)."""
        last = len(self.convs) - 1
        for j, (W, b, pad, buf, view, cols, out) in enumerate(self.convs):
            if pad:
                buf[pad:pad + self.n_kept] = g
                cols[...] = view
                g = cols
            np.matmul(g, W, out=out)
            out += b
            if j < last:
                _twice_gelu_(out)
            g = out
        return g

    def _gate(self, g: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """(clipped inputs (M, G), gate (M, 1) or None where every node is inside the data), as
        ``DynamicNet.envelope_gate`` (``envelope_gate_into``)."""
        outside = envelope_gate_into(g, *self.envelope, self._gate_buf)
        return g, (self._gate_buf if outside else None)

    def features(self, hist: np.ndarray, loads: np.ndarray) -> np.ndarray:
        """hist (H, M, 6), loads (M, L) -> (M, C), as ``DynamicNet.features`` (a reused buffer)."""
        f, H, L = self._f, self.history, self.load_width
        f[:, :6] = hist[-1]
        for j in range(H - 1):
            np.subtract(hist[-1 - j], hist[-2 - j], out=f[:, 6 + 6 * j:12 + 6 * j])
        f[:, 6 * H:6 * H + L] = loads
        f[:, :6 * H + L] *= self._scale
        return f

    def _lstm_step(self, inputs: np.ndarray, memory) -> tuple[np.ndarray, tuple]:
        """As ``DynamicNet.lstm_step``: (the inputs with the new hidden state appended (M, G + W),
        the new memory (h, c))."""
        Wi, Wh, b = self.cell
        h, c = memory if memory is not None else (np.zeros((self.n_kept, Wh.shape[0]), dtype=self.dtype),) * 2
        z = inputs @ Wi + h @ Wh + b
        i, fg, gg, o = np.split(z, 4, axis=1)
        c = _sigmoid(fg) * c + _sigmoid(i) * np.tanh(gg)
        h = _sigmoid(o) * np.tanh(c)
        return np.concatenate([inputs, h], axis=1), (h, c)

    def _correction(self, f: np.ndarray, memory) -> tuple[np.ndarray, tuple | None]:
        """As ``DynamicNet.correction``: (the convolution's correction (M, 6), times the envelope
        gate and bounded, the memory for the next step)."""
        inputs, gate = f[:, self._keep], None
        if self.envelope is not None:
            inputs, gate = self._gate(inputs)
        if self.cell is not None:
            inputs, memory = self._lstm_step(inputs, memory)
        out, b = self._conv(inputs), self.bound
        if gate is not None:
            out *= gate
        return (b * np.tanh(out / b) if b > 0 else out), memory

    def step(self, hist: np.ndarray, loads: np.ndarray, memory=None):
        """hist (H, M, 6) states, oldest first; loads (M, L) -> (next state (M, 6), memory), as
        ``DynamicNet.forward``: x + v + dv_scale (linear term + correction), fixed nodes held,
        prescribed nodes moved by their load channels."""
        f = self.features(hist, loads)
        dv = np.zeros((self.n_kept, 6))
        if self.linear is not None:
            dv += (f.reshape(-1) @ self.linear[0] + self.linear[1]).reshape(self.n_kept, 6)
        if self.convs:
            correction, memory = self._correction(f, memory)
            dv += correction
        x = hist[-1]
        nxt = dv
        nxt *= self.dv_scale                    # in place: x + x - x_prev + dv dv_scale
        nxt += x
        nxt += x
        nxt -= hist[-2]
        nxt[self.fixed] = x[self.fixed]          # fixed nodes keep their state
        for m, c in self.prescribed_columns:     # prescribed nodes follow their path
            nxt[m] = x[m] + loads[m, c:c + 6]
        return nxt, memory

    def run(self, hist: np.ndarray, loads: np.ndarray) -> np.ndarray:
        """Free run: history (H, M, 6), loads (K, M, L) of each step -> states (K, M, 6).
        Raises ``Diverged`` (with the states so far as ``.states``) if the run leaves the rod's range."""
        hist = np.array(hist, dtype=np.float64)
        loads = np.asarray(loads, dtype=np.float64)
        if hist.shape != (self.history, self.n_kept, 6):
            raise bad("history", f"array of shape {hist.shape}", f"shape ({self.history}, {self.n_kept}, 6)")
        if loads.ndim != 3 or loads.shape[1:] != (self.n_kept, self.load_width):
            raise bad("loads", f"array of shape {loads.shape}", f"shape (K, {self.n_kept}, {self.load_width})")
        out = np.empty((loads.shape[0], self.n_kept, 6))
        memory = None
        for k in range(loads.shape[0]):
            nxt, memory = self.step(hist, loads[k], memory)
            if not np.all(np.abs(nxt) < DIVERGED_M):
                err = Diverged(f"the free run diverged at model step {k + 1}", k + 1)
                err.states = out[:k]
                raise err
            out[k] = nxt
            hist[:-1] = hist[1:]
            hist[-1] = nxt
        return out
