"""Orthoglide online logging and IDIM-TLS identification of drive gains and dynamic parameters."""
import os as _os

__version__ = "0.1.0"

# One BLAS thread, set here because this runs before any submodule imports numpy (the console
# script, the `ros2 run` launchers and `python -m` all import this package first), and OpenBLAS
# reads its thread count only when it loads. The identification's matrices are narrow (tens of
# columns): threads gain nothing, and beside another busy process OpenBLAS's spinning threads
# made `orthoglide-ident identify` 8x slower (16.5 s instead of 2.0 s, issue 35). A user's own
# OPENBLAS_NUM_THREADS, OMP_NUM_THREADS or MKL_NUM_THREADS is the override: any one of them set
# leaves all three as the user has them.
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
if not any(v in _os.environ for v in BLAS_THREAD_VARIABLES):
    for _v in BLAS_THREAD_VARIABLES:
        _os.environ[_v] = "1"
