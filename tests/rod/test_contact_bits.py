"""The shipped contact scenarios keep their results to the bit: the first samples of each, run
through the Python API, hash (SHA-256 of their positions, rotations, velocities, reactions and
contact loads, float64) to the digests recorded before predictive contact came in (for
mesh-arch-guidewire-1m, when it came in). They cover the implicit integrator with explicit contact
(with Kelvin-Voigt damping in contact-capstan) and with implicit contact, and the explicit integrator
with contact (contact-plane, the magnetic rod). A change of the compiled code that was not meant
to change the physics (a sum fused or rounded otherwise) fails here, with the recorded values that
show how far it moved.

The bits are those of one compiler and CPU: the kernels let LLVM contract a * b + c into one fused
multiply-add, and which products it fuses is its choice, so another numba or llvmlite, or another
CPU, may round otherwise. Where numba, llvmlite and the host CPU are not those of ``RECORDED_ON``,
the recorded values are checked to ``ELSEWHERE_RTOL`` instead of the digests."""

import hashlib
from dataclasses import replace

import llvmlite
import llvmlite.binding
import numba
import numpy as np
import pytest

from softrnn.rod import Simulator
from softrnn.scenarios.scenario import load_scenario

RECORDED_ON = ("0.68.1", "0.50.0", "rocketlake")
"""numba, llvmlite and the host CPU (as LLVM names it) on which the digests were recorded."""
ELSEWHERE_RTOL = 1e-9
"""Relative tolerance of the recorded values on another compiler or CPU (the fused multiply-adds
move a run by about 1e-13 of its values over these spans)."""
HASHED = ("positions", "quaternions", "velocities", "angular_velocities", "reaction_forces", "contact_forces",
          "contact_torques")
"""The trajectory arrays the digest covers, in this order."""

CASES = {
    # scenario: (saved samples, SHA-256 of HASHED, the last sample's mean node position [m] and sum of
    # the contact forces [N])
    "contact-capstan": (21, "566b2a8ff5a865af23008723807cd3a4bbb6cb933cc58071418c6ae04028c6ab",
        (0.0001414819368037545, 0.0, -0.0053380425106949346,
         -8.955845707955086e-05, 0.0, 0.010679597620462833)),
    "vessel-guidewire": (11, "95e50c216697fefbd513892e6f73b1bc577a3e54222406649ef89fc682b01f04",
        (-0.1699699778198242, -9.540498150076975e-11, -0.00255000602774931,
         -0.0003674253190711326, 3.3787274876056755e-10, 0.0036742531909337178)),
    "vessel-guidewire-twist": (11, "169c788ac8521a095636b12ecaede5a3e2544c5316a060b27755c8695a52b3f7",
        (-0.16996999260645604, -5.1625865766024994e-05, -0.00254940405094041,
         -0.00033801918366537095, -5.0635082747881097e-05, 0.0036737875767982814)),
    "contact-plane": (11, "0e91d4d3af82f8c55c67f802a467d3f723045189b336eaaeff2c8f0f8cab618d",
        (0.25000002747083244, 0.0, 0.004993806301244521,
         0.0006499945742311433, 0.0, 0.36398649945506617)),
    "magnetic-bifurcation": (13, "e33e28a5ad5be6b7ddd587519af2a4ed02ee3047f18ef376de09fe1e926c1035",
        (-8.055663775260453e-06, 0.0, -0.000609499054377808,
         -0.0008783291742773272, 0.0, 0.0020256587850801915)),
    "mesh-arch-guidewire": (11, "663ea45ad3bbcc2c7659c3598d2f4c08b48fe47507947ca69ab803df86448ffc",
        (-1.668188853239295e-06, -0.0055051493263572416, -0.0999851237086859,
         -2.345481601472976e-06, 0.0017747599396946937, -0.00017700878039399637)),
    "mesh-arch-guidewire-1m": (11, "f63c4db5a00359f0d6cdb865cb6d94c564a1eaac3f3a9085ffb82fc8883de068",
        (-7.430539278288059e-06, -0.005456874957565913, -0.5199903994754932,
         -1.4301174350634891e-05, 0.012883518550651967, -0.0005042763664800767)),
}


def _run(name, samples):
    """The first ``samples`` saved samples of shipped scenario ``name``: the digest of their HASHED
    arrays and the recorded values (the last sample's mean node position and contact force sum)."""
    sc = load_scenario(name)
    traj = Simulator(sc.setup).run(replace(sc.config, n_samples=samples))
    digest = hashlib.sha256()
    for field in HASHED:
        digest.update(np.ascontiguousarray(getattr(traj, field), dtype="<f8").tobytes())
    values = (*traj.positions[-1].mean(axis=0), *traj.contact_forces[-1].sum(axis=0))
    return digest.hexdigest(), tuple(float(v) for v in values)


def _recorded_here():
    return (numba.__version__, llvmlite.__version__, llvmlite.binding.get_host_cpu_name()) == RECORDED_ON


@pytest.mark.parametrize("name", sorted(CASES))
def test_a_shipped_contact_scenario_keeps_its_bits(name):
    samples, digest, values = CASES[name]
    got_digest, got_values = _run(name, samples)
    if not _recorded_here():
        assert got_values == pytest.approx(values, rel=ELSEWHERE_RTOL, abs=1e-12)
        return
    moved = max(abs(a - b) for a, b in zip(got_values, values))
    assert got_digest == digest, f"{name}: the first {samples} samples moved (recorded values by up to {moved:.3g})"
    assert got_values == values
