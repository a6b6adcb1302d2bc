# Generated from solutions/__init__.py by `make modules` (every homework stubbed): do not edit by hand.
"""mbd-course reference solver: data input, equation build-up and numerical solution of multibody systems.

The matrices of a teaching model are small (tens to hundreds of rows): multi-threaded BLAS only adds
overhead there, and on a busy two-core machine it made one 195 x 195 LU factorization 100 times slower.
Unless the user chose otherwise, BLAS runs on one thread (this takes effect when ``solutions`` is imported
before numpy).
"""

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")
