import os

# Tests run headless and single-threaded; keep BLAS from oversubscribing the 2 cores.
os.environ.setdefault("OMP_NUM_THREADS", "1")
# Mesa's llvmpipe renders with worker threads that a fork does not copy: a forked test child
# that renders after the parent did waits on them for ever (seen with Debian 13's Mesa 25).
# Rendering on the calling thread keeps forked children working.
os.environ.setdefault("LP_NUM_THREADS", "0")
