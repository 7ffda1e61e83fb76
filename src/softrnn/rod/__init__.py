"""The Lie-group Cosserat rod simulator ("analytical dynamic model" of Tariverdi et al. 2021)."""

from .batch import simulate_batch as simulate_batch
from .boundary import Clamp as Clamp
from .boundary import Pin as Pin
from .loads import Constant as Constant
from .loads import NodalLoad as NodalLoad
from .loads import PDTracking as PDTracking
from .loads import Piecewise as Piecewise
from .loads import Sampled as Sampled
from .loads import Sinusoid as Sinusoid
from .loads import SquarePath as SquarePath
from .loads import Window as Window
from .shapes import RodShape as RodShape
from .shapes import arc as arc
from .shapes import ellipse as ellipse
from .shapes import polyline as polyline
from .shapes import straight as straight
from .simulation import Damping as Damping
from .simulation import RunConfig as RunConfig
from .simulation import Setup as Setup
from .simulation import Simulator as Simulator
from .simulation import Trajectory as Trajectory
from .simulation import simulate as simulate
from .spec import NodeOverride as NodeOverride
from .spec import RodSpec as RodSpec
from .tendons import Scalar as Scalar
from .tendons import Tendon as Tendon
