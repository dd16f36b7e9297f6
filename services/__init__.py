"""The cell's processes: one package per service, run as ``python -m motocell.services.<name>``.

Before any service imports numpy: one BLAS thread. The services compute on vectors of a few
axes, where OpenBLAS never uses its threads, but its worker spins while numpy starts: 60 ms of
CPU per process measured alone (half its start-up), 0.13 s over a four-group cell starting on
two cores. A value the user set is kept.
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
