"""Navigation environments (gymnasium): a guidewire with a shaped tip steered through a vessel from
its hub, toward a target branch (docs/guide/envs.md).

* ``NavigateEnv``: one environment; ``NavigateVectorEnv``: N of them stepped in one batched kernel
  call (gymnasium's vector API, next-step autoreset);
* ``NavigateConfig`` (the task) and ``Guidewire`` (the device); the vessel is a ``Bifurcation``, a
  ``Vessel`` or any ``Track`` (its obstacles, branches and centrelines), ``default_vessel()`` by
  default;
* ``MeshTrack``: a vessel from a surface mesh as a ``Track``; ``arch_track()`` the shipped aortic arch
  with its three branches, ``arch_config()`` a task sized for it;
* ``HubMotion``: the hub's insertion and rotation (a thin adapter over ``softrnn.rod.Hub.commanded``,
  which the environments drive);
* ``ScriptedNavigator``: a hand-written controller, the baseline;
* ``MagneticNavigateEnv``, ``MagneticNavigateVectorEnv`` (``MagneticNavigateConfig``, ``MagneticRod``,
  ``magnetic_vessel()``, ``MagneticNavigator``): the magnetic manipulator's rod steered by the
  coils' field;
* ``Fluoroscopy``: the fluoroscopy image observation's settings (``observation="image"``).

Registered with gymnasium as ``softrnn/Navigate-v0`` and ``softrnn/MagneticNavigate-v0``
(``gymnasium.make`` and ``make_vec``).
Needs the optional extra ``envs`` (gymnasium); importing this package without it raises the
one-line ``missing_extra`` error.
"""

from ..errors import missing_extra

try:
    import gymnasium  # optional extra: envs
except ImportError as err:  # pragma: no cover - the extra is installed in the tests' environment
    raise (missing_extra(err) or err) from None

from .config import Guidewire as Guidewire
from .config import NavigateConfig as NavigateConfig
from .episodes import Episodes as Episodes
from .fluoro import Fluoroscopy as Fluoroscopy
from .hub import HubMotion as HubMotion
from .magnetic import MagneticNavigateConfig as MagneticNavigateConfig
from .magnetic import MagneticNavigateEnv as MagneticNavigateEnv
from .magnetic import MagneticNavigateVectorEnv as MagneticNavigateVectorEnv
from .magnetic import MagneticNavigator as MagneticNavigator
from .magnetic import MagneticRod as MagneticRod
from .magnetic import magnetic_vessel as magnetic_vessel
from .mesh_track import MeshTrack as MeshTrack
from .mesh_track import arch_config as arch_config
from .mesh_track import arch_track as arch_track
from .navigate import NavigateEnv as NavigateEnv
from .scripted import ScriptedNavigator as ScriptedNavigator
from .track import BifurcationTrack as BifurcationTrack
from .track import Track as Track
from .track import default_vessel as default_vessel
from .vector import NavigateVectorEnv as NavigateVectorEnv

ENV_ID = "softrnn/Navigate-v0"
"""The id the environments are registered under with gymnasium."""

if ENV_ID not in gymnasium.registry:
    gymnasium.register(id=ENV_ID, entry_point="softrnn.envs.navigate:NavigateEnv",
                       vector_entry_point="softrnn.envs.vector:NavigateVectorEnv")

MAGNETIC_ENV_ID = "softrnn/MagneticNavigate-v0"
"""The id the magnetic environments are registered under with gymnasium."""

if MAGNETIC_ENV_ID not in gymnasium.registry:
    gymnasium.register(id=MAGNETIC_ENV_ID, entry_point="softrnn.envs.magnetic:MagneticNavigateEnv",
                       vector_entry_point="softrnn.envs.magnetic:MagneticNavigateVectorEnv")
