"""What a Fig. 14 study trains and measures (``StudyConfig``), and the paper's Fig. 14 statements
(``PAPER_FIG14``) its summary is set beside (the study: ``experiments.fig14``)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace

import numpy as np

from ..errors import bad, int_items, integer, is_int
from ..learned.node.data import SampleSpec
from ..learned.node.train import TrainConfig
from ..resume import Settings

GRID = ("units", "history")
"""The settings that may change between runs of a study in one folder (the grid grows or shrinks)."""

PAPER_FIG14 = {
    "source": "Tariverdi et al. 2021, 'A Recurrent Neural-Network-Based Real-Time Dynamic Model for Soft "
              "Continuum Manipulators', Front. Robot. AI 8:631303, section 5.3, Figure 14 (Data-set IV)",
    "bandwidth": "Figure 14A demonstrates the computation bandwidth required for the prediction of the next step "
                 "using the trained model with a different number of LSTM units and a different size of time "
                 "history horizons in Data-set IV. The figure suggests that computation bandwidths are fairly "
                 "unchanged with the number of LSTM units; however, increasing the length of time history reduces "
                 "bandwidth. The optimal region maximizing the bandwidth is approximately with time history size in "
                 "(2, 20) and LSTM unit size in (5, 15).",
    "rms_error": "Figure 14B suggests that RMS error of the prediction decreases by increasing the number of LSTM "
                 "units and the optimal area minimizing RMS errors is approximately with time history size in "
                 "(2, 20) and LSTM unit size in (20, 25).",
    "bandwidth_region": {"history": [2, 20], "lstm_units": [5, 15]},
    "rms_error_region": {"history": [2, 20], "lstm_units": [20, 25]},
}
"""The paper's Fig. 14 statements, quoted, and its two optimal regions (history and LSTM unit ranges)."""


def _grid(name: str, value) -> tuple[int, ...]:
    """A non-empty sequence of distinct positive integers, sorted."""
    expected = "a non-empty list of distinct positive integers, e.g. 5,10,15"
    out = int_items(name, value, expected)
    if not out or not all(is_int(a) and a >= 1 for a in out) or len(set(out)) != len(out):
        raise bad(name, list(out), expected)
    return tuple(sorted(int(a) for a in out))


def _default_train() -> TrainConfig:
    return TrainConfig(rollout_steps=1, max_train_windows=10_000)


@dataclass(frozen=True, kw_only=True)
class StudyConfig:
    """What a Fig. 14 study trains and measures.

    Parameters
    ----------
    node : int
        The predicted rod node (negative: from the rod's end).
    units : tuple of int
        LSTM units per layer of the grid (the paper's axis: 5 .. 25).
    history : tuple of int
        History sizes H (past time steps per window) of the grid (the paper's axis: 2 .. 20).
    epochs : int
        Training epochs of every point. The default, 10, keeps a 5 x 4 study of one case within a
        few minutes on two cores; the project's models train 30.
    seed : int
        Seed of every point's weights and shuffling (the same for all points).
    train : TrainConfig
        The other training settings; its ``epochs`` and ``seed`` are replaced by the fields above.
        Default: one-step training (``rollout_steps=1``, the paper's loss, and the study measures
        one-step errors) on at most 10,000 windows (``max_train_windows``).
    neighbours : tuple of int or None
        Input I's neighbour nodes (None: the adjacent ones, ``SampleSpec``).
    inputs : str
        ``"positions"`` or ``"poses"`` (``SampleSpec.inputs``).
    wrench : str
        ``"none"``, ``"force"`` or ``"wrench"`` (``SampleSpec.wrench``).
    bandwidth_steps : int
        Timed ``NodeStepper.step`` calls per point (after 200 untimed ones).
    torch_steps : int
        Timed eager PyTorch ``predict`` calls per point (0: not measured).
    region_tolerance : float
        A region is the grid points within this fraction of the best value: bandwidth >= (1 - tol)
        x the highest, RMS error <= (1 + tol) x the lowest.
    """

    node: int
    units: tuple[int, ...] = (5, 10, 15, 20, 25)
    history: tuple[int, ...] = (2, 5, 10, 20)
    epochs: int = 10
    seed: int = 0
    train: TrainConfig = field(default_factory=_default_train)
    neighbours: tuple[int, ...] | None = None
    inputs: str = "positions"
    wrench: str = "force"
    bandwidth_steps: int = 2000
    torch_steps: int = 200
    region_tolerance: float = 0.1

    def __post_init__(self):
        if not is_int(self.node):
            raise bad("node", self.node, "an integer node index")
        object.__setattr__(self, "node", int(self.node))
        object.__setattr__(self, "units", _grid("units", self.units))
        object.__setattr__(self, "history", _grid("history", self.history))
        for name, low in (("epochs", 1), ("seed", 0), ("bandwidth_steps", 10), ("torch_steps", 0)):
            object.__setattr__(self, name, integer(name, getattr(self, name), low))
        if not isinstance(self.train, TrainConfig):
            raise bad("train", type(self.train).__name__, "a TrainConfig")
        object.__setattr__(self, "train", replace(self.train, epochs=self.epochs, seed=self.seed))
        tol = self.region_tolerance
        if isinstance(tol, bool) or not isinstance(tol, (int, float, np.floating)) or not 0.0 <= tol < 1.0:
            raise bad("region_tolerance", tol, "a fraction in [0, 1), e.g. 0.1 for within 10 % of the best")
        object.__setattr__(self, "region_tolerance", float(tol))
        spec = self.spec(self.history[0])  # checks neighbours, inputs and wrench
        object.__setattr__(self, "neighbours", spec.neighbours)

    def spec(self, history: int):
        """The ``SampleSpec`` of the grid points of history ``history``."""
        return SampleSpec(node=self.node, neighbours=self.neighbours, history=history, inputs=self.inputs,
                          wrench=self.wrench)

    @property
    def points(self) -> list[tuple[int, int]]:
        """The grid points (units, history), units varying fastest."""
        return [(u, h) for h in self.history for u in self.units]

    def to_dict(self) -> dict:
        """JSON-ready settings."""
        d = asdict(self)
        d["units"], d["history"] = list(self.units), list(self.history)
        d["neighbours"] = None if self.neighbours is None else list(self.neighbours)
        return d

    def settings(self) -> Settings:
        """What every point's result depends on (everything but the grid, ``GRID``): a rerun must
        match it."""
        return Settings.of(self, may_differ=GRID)
