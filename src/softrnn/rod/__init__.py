"""The Lie-group Cosserat rod simulator ("analytical dynamic model" of Tariverdi et al. 2021)."""

from .boundary import Clamp as Clamp, Pin as Pin
from .loads import (Constant as Constant, NodalLoad as NodalLoad, PDTracking as PDTracking,
                    Piecewise as Piecewise, Sampled as Sampled, Sinusoid as Sinusoid,
                    SquarePath as SquarePath, Window as Window)
from .shapes import RodShape as RodShape, arc as arc, ellipse as ellipse, polyline as polyline, straight as straight
from .simulation import (Damping as Damping, RunConfig as RunConfig, Setup as Setup, Simulator as Simulator,
                         Trajectory as Trajectory, simulate as simulate)
from .spec import NodeOverride as NodeOverride, RodSpec as RodSpec
from .batch import simulate_batch as simulate_batch
