"""Shared geometry of the rod's world, in space and time: the obstacles (``obstacles``; vessels from
surface meshes in ``mesh``) and the
``Contact`` that holds them (``contact``), and the time functions and target paths (``paths``), each
with its record, the form a data file stores (docs/dataset-format.md). The simulator (``rod``), the
data files (``io``), the pictures (``figures``) and the learned models (``learned``) share them.
"""

from .contact import Contact as Contact
from .contact import contact_from_record as contact_from_record
from .contact import contact_record as contact_record
from .mesh import MeshVessel as MeshVessel
from .mesh import arch_tree as arch_tree
from .mesh import load_mesh as load_mesh
from .obstacles import Bifurcation as Bifurcation
from .obstacles import Cylinder as Cylinder
from .obstacles import Obstacle as Obstacle
from .obstacles import Plane as Plane
from .obstacles import Sphere as Sphere
from .obstacles import Vessel as Vessel
from .paths import function_from_record as function_from_record
from .paths import function_record as function_record
