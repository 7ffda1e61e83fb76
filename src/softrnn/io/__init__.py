"""Dataset files: trajectories in HDF5 and lab data imported from CSV (``csv_import``).

The HDF5 parts live in their own modules: the file format's constants and ``DatasetError``
(``schema``), ``Dataset`` and reading (``reader``), writing (``writer``), sweep files
(``sweepfiles``) and summaries (``summary``); their public names are imported here.

See docs/dataset-format.md and docs/csv-format.md.
"""

from .csv_import import export_csv as export_csv
from .csv_import import import_csv as import_csv
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
