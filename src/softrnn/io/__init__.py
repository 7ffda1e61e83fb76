"""Dataset files: trajectories in HDF5 (``dataset``) and lab data imported from CSV (``csv_import``).

``dataset`` re-exports the HDF5 parts: the format (``schema``), ``reader``, ``writer``, sweep
files (``sweepfiles``) and summaries (``summary``).

See docs/dataset-format.md and docs/csv-format.md.
"""

from .csv_import import export_csv as export_csv
from .csv_import import import_csv as import_csv
from .dataset import SCHEMA_VERSION as SCHEMA_VERSION
from .dataset import Dataset as Dataset
from .dataset import DatasetError as DatasetError
from .dataset import DatasetWriter as DatasetWriter
from .dataset import describe as describe
from .dataset import list_groups as list_groups
from .dataset import merge_files as merge_files
from .dataset import read_dataset as read_dataset
from .dataset import read_node as read_node
from .dataset import sweep_group_name as sweep_group_name
from .dataset import trajectories as trajectories
from .dataset import write_dataset as write_dataset
from .dataset import write_trajectory as write_trajectory
