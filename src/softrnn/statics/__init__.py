"""Static Cosserat rod solver (paper appendix): RK4 shooting with Levenberg-Marquardt on the base
wrench, point loads and magnets, stiff segments (the Fig. 13 timing study is softrnn.experiments.fig13)."""

from .rod import (PointLoad as PointLoad, PointMagnet as PointMagnet, RigidSegment as RigidSegment,
                  StaticLoads as StaticLoads, StaticRod as StaticRod)
from .solver import (Grid as Grid, StaticSolution as StaticSolution, StaticSolver as StaticSolver, Status as Status,
                     build_grid as build_grid, solve as solve)
