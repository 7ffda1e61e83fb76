"""A hub's channels as the whole-manipulator model's inputs: a data set that records a prescribed
hub's insertion and rotation gives them to the model beside the wrenches (drive 'wrench' reads as
'both' with those channels), a driven hub's force and torque instead of its measured pose (the
rod's state), with every drive; a data set without a hub is read as before; the encoding keeps
them through a model folder's record."""

import numpy as np
import pytest

from softrnn.io import Dataset
from softrnn.io.schema import hub_inputs
from softrnn.learned.whole.artifact import encoding_from_dict, encoding_to_dict
from softrnn.learned.whole.encoding import make_encoding

T, N, DT = 41, 6, 0.01


def _dataset(channels: dict) -> Dataset:
    """A rod of N nodes along x whose tip moves, with the actuation ``channels`` {name: (unit, (T,))}."""
    time = DT * np.arange(T)
    positions = np.zeros((T, N, 3))
    positions[..., 0] = np.linspace(0.0, 0.1, N)
    positions[:, -1, 1] = 0.01 * np.sin(time)
    quaternions = np.zeros((T, N, 4))
    quaternions[..., 0] = 1.0
    zeros = np.zeros((T, N, 3))
    return Dataset(time=time, nodes=np.arange(N), positions=positions, quaternions=quaternions, forces=zeros,
                   torques=zeros, attrs={"dt": DT},
                   actuation=np.stack([v for _, v in channels.values()], axis=1) if channels else None,
                   actuation_units={k: u for k, (u, _) in channels.items()} or None)


def test_a_prescribed_hubs_insertion_and_rotation_are_inputs_beside_the_wrenches():
    time = DT * np.arange(T)
    ds = _dataset({"tendon_a": ("N", np.ones(T)), "hub_insertion": ("m", 0.1 * time),
                   "hub_rotation": ("rad", np.sin(time))})
    enc = make_encoding([ds], model_dt=2 * DT, node_stride=2, length=0.1)
    assert enc.drive == "both" and enc.channels == ("hub_insertion", "hub_rotation") and enc.load_width == 8
    loads = enc.trajectory(ds).loads
    assert loads.shape == (21, enc.n_kept, 8)
    np.testing.assert_allclose(loads[:-1, 0, 6], 0.1 * (time[0:40:2] + time[1:41:2]) / 2, rtol=1e-6)
    np.testing.assert_allclose(loads[:, 3, 6:], loads[:, 0, 6:])             # the same at every kept node
    assert encoding_from_dict(encoding_to_dict(enc)).channels == enc.channels
    every = make_encoding([ds], model_dt=2 * DT, node_stride=2, length=0.1, drive="actuation")
    assert every.channels == ("tendon_a", "hub_insertion", "hub_rotation")


def test_a_driven_hubs_force_and_torque_are_the_inputs_not_its_measured_pose():
    time = DT * np.arange(T)
    ds = _dataset({"hub_insertion": ("m", 0.1 * time ** 2), "hub_rotation": ("rad", time),
                   "hub_force": ("N", np.full(T, 0.2)), "hub_torque": ("N m", np.full(T, 1e-4))})
    assert hub_inputs(ds.actuation_names) == ("hub_force", "hub_torque")
    for drive, width in (("wrench", 8), ("actuation", 2), ("both", 8)):
        enc = make_encoding([ds], model_dt=DT, node_stride=1, length=0.1, drive=drive)
        assert enc.channels == ("hub_force", "hub_torque") and enc.load_width == width, drive
    pushed = _dataset({"hub_insertion": ("m", time), "hub_rotation": ("rad", time), "hub_force": ("N", time)})
    assert hub_inputs(pushed.actuation_names) == ("hub_rotation", "hub_force")


def test_a_data_set_without_a_hub_is_read_as_before():
    ds = _dataset({"tendon_a": ("N", np.ones(T))})
    enc = make_encoding([ds], model_dt=DT, node_stride=1, length=0.1)
    assert enc.drive == "wrench" and enc.channels == () and enc.load_width == 6
    assert make_encoding([ds], model_dt=DT, node_stride=1, length=0.1, drive="actuation").channels == ("tendon_a",)
    with pytest.raises(Exception, match="no actuation inputs"):
        make_encoding([_dataset({})], model_dt=DT, node_stride=1, length=0.1, drive="both")
