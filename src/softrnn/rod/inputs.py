"""The time-dependent inputs of a setup (nodal loads, PD targets, prescribed boundary motions, a
driven hub's force and torque, tendon tensions and displacements, a time-varying gravity) evaluated
chunk by chunk into the kernels' ``StepInputs`` record, with the setup's obstacles (``rod.contact``)."""

import numpy as np

from ..errors import bad
from .boundary import Clamp
from .contact import kernel_arrays
from .hub import hub_loads
from .kernels import StepInputs
from .loads import PDTracking
from .magnetic import MagneticDipoles
from .tendons import displacement_matrix, prescribed_tensions, routing_arrays, spring_arrays


class SetupInputs:
    """A ``softrnn.rod.Setup``'s inputs, sorted once by kind and node.

    Attributes
    ----------
    ext_idx : (m,) int64
        nodes with ``NodalLoad`` entries, increasing (every node when the setup's gravity is a time
        function: its weight m_a g(t) [N] is a world force added to the node's nodal loads, and the
        lumped rod carries no constant gravity, ``rod.lumped.constant_gravity``)
    pd_idx : (p,) int64
        nodes of the ``PDTracking`` entries, in the setup's order
    pd_gain : (p, 2)
        their stiffness [N/m] and damping [N s/m]
    presc_idx : (q,) int64
        nodes whose Clamp/Pin carries a motion/path, in the setup's order
    tendons : tuple
        the setup's ``Tendon`` entries (m_t of them)
    tendon_route : (m_t, n - 1, 6)
        body-frame routing offset [m] and its rate [-] per segment
        (``rod.tendons.routing_arrays``)
    tendon_end : (m_t,) int64
        termination nodes
    tendon_stiffness : (m_s,)
        series stiffness [N/m] per tendon (0: pulled with a tension); m_s = m_t when a tendon is
        driven by a displacement, else 0 (no arrays)
    tendon_rest : (m_s,)
        the tendons' discrete lengths in the stress-free reference [m]
    contact : dict or None
        the static contact fields of ``StepInputs`` (``rod.contact.kernel_arrays``); None without
        ``Setup.contact``
    magnetic : MagneticDipoles or None
        the setup's magnetic load (``rod.magnetic``), None without; a control loop may replace it
        between runs (e.g. ``MagneticDipoles.with_currents``)
    """

    def __init__(self, setup):
        presc, ext, pd = [], {}, []
        for bc in setup.boundary:
            if (bc.motion if isinstance(bc, Clamp) else bc.path) is not None:
                presc.append((setup.node_index(bc.node), bc))
        magnetic = [load for load in setup.loads if isinstance(load, MagneticDipoles)]
        self.magnetic = magnetic[0] if magnetic else None
        for load in setup.loads:
            if isinstance(load, MagneticDipoles):
                continue
            a = setup.node_index(load.node)
            if isinstance(load, PDTracking):
                pd.append((a, load))
            else:
                ext.setdefault(a, []).append(load)
        for a, load in hub_loads(setup):  # a driven hub's force and torque (rod.hub)
            ext.setdefault(a, []).append(load)
        self._presc, self._ext, self._pd = presc, ext, pd
        self._gravity = setup.gravity if callable(setup.gravity) else None
        self._constant = None if self._gravity is not None else setup.gravity
        weighed = range(setup.rod.n_nodes) if self._gravity is not None else ()
        self.presc_idx = np.array([a for a, _ in presc], dtype=np.int64)
        self.ext_idx = np.array(sorted(set(ext).union(weighed)), dtype=np.int64)
        # node masses (n,) [kg], as in the lumped rod: the weights of a time-varying gravity
        self._mass = setup.rod.lumped()["mass"] if self._gravity is not None else None
        self.pd_idx = np.array([a for a, _ in pd], dtype=np.int64)
        self.pd_gain = np.array([[p.stiffness, p.damping] for _, p in pd], dtype=float).reshape(-1, 2)
        self.tendons = tuple(setup.tendons)
        self.tendon_route, self.tendon_end = routing_arrays(self.tendons, setup.rod.n_nodes,
                                                             setup.rod.segment_length)
        self.displaced = any(td.displacement_controlled for td in self.tendons)
        if self.displaced:
            self.tendon_stiffness, self.tendon_rest = spring_arrays(
                self.tendons, setup.reference.rotations, setup.reference.positions, setup.rod.segment_length)
        else:
            self.tendon_stiffness, self.tendon_rest = np.zeros(0), np.zeros(0)
        self.contact = None if setup.contact is None else kernel_arrays(setup.contact, setup.rod, setup.gravity)
        self._applied = np.zeros((setup.rod.n_nodes, 6))  # the kernels' scratch of contact_applied

    def step_bytes(self) -> int:
        """Bytes of per-step inputs a chunk holds (times, loads, PD targets, prescribed poses and
        the load functions' temporaries)."""
        sources = 0 if self.magnetic is None else self.magnetic.n_sources
        return 8 * (4 + 15 * self.ext_idx.size + 6 * len(self._pd) + 12 * len(self._presc) + 2 * len(self.tendons)
                    + 2 * self.tendon_stiffness.size + sources)

    def prescribed(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Prescribed positions (K, q, 3) [m] and rotations (K, q, 3, 3) at times t (K,) [s]
        (identity rotations for pinned nodes)."""
        q = len(self._presc)
        pos = np.zeros((t.size, q, 3))
        rot = np.broadcast_to(np.eye(3), (t.size, q, 3, 3)).copy()
        for j, (_, bc) in enumerate(self._presc):
            if isinstance(bc, Clamp):
                p, R = bc.motion(t)
                pos[:, j] = p
                rot[:, j] = R
            else:
                pos[:, j] = bc.path(t)
        return pos, rot

    def gravity(self, t: np.ndarray) -> np.ndarray:
        """The setup's gravity (K, 3) [m/s^2] at times t (K,) [s] (a constant broadcast)."""
        if self._gravity is None:
            return np.broadcast_to(np.asarray(self._constant, dtype=float), (t.size, 3)).copy()
        g = np.asarray(self._gravity(t), dtype=float)
        if g.shape != (t.size, 3) or not np.all(np.isfinite(g)):
            got = f"shape {g.shape}" if g.shape != (t.size, 3) else "a value that is not finite"
            raise bad("gravity", self._gravity, f"a time function t (K,) [s] -> (K, 3) of finite values in m/s^2 "
                                                f"(for {t.size} times it gave {got})")
        return g

    def at(self, t: np.ndarray, h: float) -> StepInputs:
        """The inputs of the steps at times t (K,) [s]: loads, tendon tensions and displacements at
        t (the tensions of tendons driven by a displacement are 0 here: the kernel computes them),
        prescribed poses at t and t + h, the magnetic sources' currents at t."""
        K = t.size
        ext_w = np.zeros((K, self.ext_idx.size, 12))
        for j, a in enumerate(self.ext_idx):
            for load in self._ext.get(a, ()):
                off = 0 if load.frame == "world" else 6
                if load.force is not None:
                    ext_w[:, j, off:off + 3] += load.force(t)
                if load.torque is not None:
                    ext_w[:, j, off + 3:off + 6] += load.torque(t)
        if self._gravity is not None:
            ext_w[:, :, 0:3] += self.gravity(t)[:, None, :] * self._mass[None, :, None]
        pd_target = np.zeros((K, len(self._pd), 3))
        for j, (_, p) in enumerate(self._pd):
            pd_target[:, j] = p.target(t)
        presc_r, presc_R = self.prescribed(np.concatenate([t, [t[-1] + h]]))
        return StepInputs(ext_idx=self.ext_idx, ext_w=ext_w, pd_idx=self.pd_idx, pd_target=pd_target,
                          pd_gain=self.pd_gain, presc_idx=self.presc_idx, presc_r=presc_r, presc_R=presc_R,
                          tendon_route=self.tendon_route, tendon_end=self.tendon_end,
                          tendon_tension=prescribed_tensions(self.tendons, t),
                          tendon_stiffness=self.tendon_stiffness, tendon_rest=self.tendon_rest,
                          tendon_displacement=(displacement_matrix(self.tendons, t) if self.displaced
                                               else np.zeros((K, 0))),
                          **({} if self.contact is None else self.contact),
                          **({} if self.magnetic is None else self.magnetic.kernel_arrays(t)))

    def with_contact(self, inputs: StepInputs, segment: np.ndarray, samples: np.ndarray) -> StepInputs:
        """``inputs`` of a setup with contact given the state's tracked vessel segments (n, o) int64
        (updated in place by the kernels) and the buffer (S, s, 6) of the contact force [N] and
        torque [N m] of the saved nodes at the saved steps (``kernels.StepInputs``)."""
        return inputs._replace(contact_segment=segment, contact_samples=samples, contact_applied=self._applied)
