"""Static Cosserat rod solver (paper appendix): RK4 shooting with Levenberg-Marquardt on the base
wrench, point loads and magnets, stiff segments (the Fig. 13 timing study is softrnn.experiments.fig13)."""

from .grid import Grid as Grid
from .grid import build_grid as build_grid
from .rod import PointLoad as PointLoad
from .rod import PointMagnet as PointMagnet
from .rod import RigidSegment as RigidSegment
from .rod import SectionStiffness as SectionStiffness
from .rod import StaticLoads as StaticLoads
from .rod import StaticRod as StaticRod
from .solution import StaticSolution as StaticSolution
from .solution import Status as Status
from .solver import StaticSolver as StaticSolver
from .solver import solve as solve
from .start import static_problem as static_problem
from .start import static_solution as static_solution
from .start import static_start as static_start
