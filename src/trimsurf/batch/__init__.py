"""Many parts, many jobs: a dask.distributed task graph over tessellate, certify and view.

`run` turns every part (CAD file) and job into a Dask task -- on a
`local_cluster` of worker processes by default, or on any scheduler -- and
writes, as parts finish, ``OUT/<part>/`` (the job's outputs and a record),
the results table ``OUT/results.csv`` / ``OUT/results.parquet`` and the page
``OUT/index.html``. A part that crashes its worker, overruns its time limit
or exhausts memory is retried once and then recorded as failed with the
reason; the batch goes on. A job whose record matches the input's hash and
options (and whose outputs exist) is not run again.
"""

from ._index import write_index
from ._inputs import MANIFEST_COLUMNS, PART_OPTIONS, Part, collect_parts, file_sha256
from ._jobs import COLUMNS, JOBS, MAX_ATTEMPTS, STATUSES, run_job
from ._run import dashboard_link, local_cluster, record_key, run
from ._table import read_table, write_tables

__all__ = ["run", "local_cluster", "dashboard_link", "collect_parts", "Part", "file_sha256", "record_key",
           "run_job", "write_tables", "read_table", "write_index", "JOBS", "COLUMNS", "STATUSES", "MAX_ATTEMPTS",
           "PART_OPTIONS", "MANIFEST_COLUMNS"]
