"""The batched step of the navigation environments: B rods of one design in one vessel, each with
its own state, hub motion, tracked vessel segments and contact outputs (the magnetic rod's also its
own coil currents and magnet buffers), advanced by the implicit integrator
(``rod.implicit.advance_implicit_into``) in one call, in parallel over the rods (blocks of rods on
threads, ``rod.threads.over_rods``; the thread count is numba's).

Caching: the kernel compiles the rod kernels' code into itself, so it is built as a closure over a
hash of their files and of ``rod/implicit.py`` (``stamp``), as ``rod.kernels`` does: an edit of any
of them recompiles it.
"""

import hashlib
from pathlib import Path

import numpy as np
from numba import njit

from ..rod import implicit
from ..rod.implicit import ImplicitWork, advance_implicit_into
from ..rod.kernel_records import kernel_stamp
from ..rod.kernels import magnet_rows, rod_inputs, rod_samples, rod_state


def stamp() -> int:
    """A non-negative 60-bit hash of the rod kernels (``kernel_stamp``) and ``rod/implicit.py``."""
    digest = hashlib.sha256(str(kernel_stamp()).encode())
    try:
        digest.update(Path(implicit.__file__).read_bytes())
    except OSError:  # no source file (frozen or zipped install): nothing to track
        digest.update(b"implicit")
    return int(digest.hexdigest()[:15], 16)


def _build(stamp_value):
    """``advance_rods`` closed over ``stamp_value``."""

    @njit(nogil=True, cache=True)
    def advance_rods(rod, state, inputs, out, h, k0, n_steps, stride, s0, work, beta, theta, tau, status, b0, b1):
        """Advance rods b0 .. b1 - 1 of B rods of one ``rod`` (an elastic ``LumpedRod``) by ``n_steps``
        implicit steps, without the GIL (``rod.threads.over_rods`` runs blocks of rods at once).

        state, work (``ImplicitWork``) and out (except save_slot) carry a leading batch axis (B, ...);
        so do inputs' ext_w, pd_target, presc_r, presc_R, tendon_tension, tendon_displacement,
        contact_segment, contact_samples and contact_applied, and with magnets source_currents and the
        magnets' buffers magnet_positions .. magnet_failed (``rod.kernels.magnet_rows``; the rest, the
        obstacles, magnets and coils included, is shared; each rod's record by ``rod.kernels.rod_inputs``).
        Per rod as ``advance_implicit_into``; status (B, 2) int64 receives (code, step) per rod."""
        if stamp_value < 0:  # never true: references the stamp so that it is a closure variable
            return
        inp = inputs
        for b in range(b0, b1):
            contact = (inp.contact_kind, inp.contact_geom, inp.contact_range, inp.contact_friction, inp.contact_points,
                       inp.contact_radii, inp.contact_mesh_index, inp.contact_mesh_values, inp.contact_node,
                       inp.contact_segment[b], inp.contact_samples[b], inp.contact_applied[b])
            code, step = advance_implicit_into(
                rod, rod_state(state, b), rod_inputs(inp, b, contact, magnet_rows(inp, b)), rod_samples(out, b), h,
                k0, n_steps, stride, s0,
                ImplicitWork(work.applied[b], work.force[b], work.strain_map[b], work.diag[b], work.upper[b],
                             work.rhs[b], work.u[b], work.known[b], work.fixed[b], work.pivot[b], work.weighted[b],
                             work.contact_tangent[b]),
                beta, theta, tau)
            status[b, 0] = code
            status[b, 1] = step

    return advance_rods


advance_rods = _build(stamp())


def stacked_work(n_rods: int, n_nodes: int, implicit_contact: bool = False) -> ImplicitWork:
    """Zeroed ``ImplicitWork`` arrays for ``n_rods`` rods of ``n_nodes`` nodes, (B, ...) each
    (``implicit_contact``: ``implicit.work_arrays``)."""
    one = implicit.work_arrays(n_nodes, implicit_contact)
    return ImplicitWork(*(np.zeros((n_rods,) + a.shape, dtype=a.dtype) for a in one))
