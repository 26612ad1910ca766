#!/usr/bin/env python
"""``bench_pair.py --dim 3``: ours vs stock ``pair_style granular`` on spheres.

The same benchmark as ``bench_pair.py`` (see its docstring) on a relaxed 3D
packing (``packing3d.py``); a file of its own so that ``make bench`` records
it as its own block and ``run_all.py --only bench_pair3d`` runs just this.
Every option of ``bench_pair.py`` applies (``--quick``, ``--sizes``, ...).
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import bench_pair  # noqa: E402

if __name__ == "__main__":
    sys.exit(bench_pair.main(["--dim", "3"] + sys.argv[1:]))
