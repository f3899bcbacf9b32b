"""The data stage: recordings on disk (docs/data-format.md).

``read_run`` / ``write_run``: one run file (the thesis's LabVIEW xlsx, or CSV);
``read_dataset``: a directory of runs with their commands and setups;
``group_runs``: the repeated trials of each command; ``files``: atomic writes
and the unfinished-output marker.
"""

from skidsteer.data.dataset import (Dataset, Group, RunInfo, group_runs, read_dataset,
                                    run_file_name, write_runs_csv)
from skidsteer.data.files import INCOMPLETE_MARKER, write_atomically, write_json
from skidsteer.data.recording import (DataError, Recording, m_s2_to_volts, read_run,
                                      volts_to_m_s2, write_run, write_run_csv, write_run_xlsx)

__all__ = ["DataError", "Dataset", "Group", "INCOMPLETE_MARKER", "Recording", "RunInfo",
           "group_runs", "m_s2_to_volts", "read_dataset", "read_run", "run_file_name",
           "volts_to_m_s2", "write_atomically", "write_json", "write_run", "write_run_csv",
           "write_run_xlsx", "write_runs_csv"]
