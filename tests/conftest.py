import os

# Tests run headless and single-threaded; keep BLAS from oversubscribing the 2 cores.
os.environ.setdefault("OMP_NUM_THREADS", "1")
