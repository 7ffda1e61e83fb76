"""Dataset files: trajectories in HDF5 (``dataset``) and lab data imported from CSV (``csv_import``).

``dataset`` re-exports the HDF5 parts: the format (``schema``), ``reader``, ``writer``, sweep
files (``sweepfiles``) and summaries (``summary``).

See docs/dataset-format.md and docs/csv-format.md.
"""

from .dataset import (SCHEMA_VERSION as SCHEMA_VERSION, Dataset as Dataset, DatasetError as DatasetError,
                      DatasetWriter as DatasetWriter, describe as describe, list_groups as list_groups,
                      merge_files as merge_files, read_dataset as read_dataset, read_node as read_node,
                      sweep_group_name as sweep_group_name, trajectories as trajectories,
                      write_dataset as write_dataset, write_trajectory as write_trajectory)
from .csv_import import export_csv as export_csv, import_csv as import_csv
