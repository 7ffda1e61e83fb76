"""Trajectory datasets in HDF5 (schema 1, documented in docs/dataset-format.md): one import for all of it.

The parts live in their own modules and are re-exported here:

* ``softrnn.io.schema``: the file format's constants (``SCHEMA_VERSION``, ``TIME_CHUNK``,
  ``POSITION_LIMIT_M``, ``UNITS``, ...) and ``DatasetError``;
* ``softrnn.io.reader``: ``Dataset`` (one trajectory in memory), ``read_dataset``, ``read_node``,
  ``list_groups``;
* ``softrnn.io.writer``: ``DatasetWriter``, ``write_trajectory``, ``write_dataset``;
* ``softrnn.io.sweepfiles``: ``sweep_group_name``, ``trajectories``, ``merge_files``;
* ``softrnn.io.summary``: ``describe`` (``softrnn show``).
"""

from .reader import Dataset as Dataset
from .reader import list_groups as list_groups
from .reader import read_dataset as read_dataset
from .reader import read_node as read_node
from .schema import COMPRESSION as COMPRESSION
from .schema import FIELDS as FIELDS
from .schema import POSITION_LIMIT_M as POSITION_LIMIT_M
from .schema import QUATERNION_TOLERANCE as QUATERNION_TOLERANCE
from .schema import RESERVED_ATTRS as RESERVED_ATTRS
from .schema import SCHEMA_VERSION as SCHEMA_VERSION
from .schema import SWEEP_PREFIX as SWEEP_PREFIX
from .schema import TIME_CHUNK as TIME_CHUNK
from .schema import UNITS as UNITS
from .schema import DatasetError as DatasetError
from .summary import describe as describe
from .sweepfiles import merge_files as merge_files
from .sweepfiles import sweep_group_name as sweep_group_name
from .sweepfiles import trajectories as trajectories
from .writer import DatasetWriter as DatasetWriter
from .writer import write_dataset as write_dataset
from .writer import write_trajectory as write_trajectory
