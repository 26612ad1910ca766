"""``remote-trigger ensemble`` (docs/ensemble.md).

``config``  :class:`EnsembleConfig` (TOML, ``--set``, ``--quick``)
``onset``   per packing: the coalescing pair, the sqrt-law slope, I0 = 1 re-analysis
``task``    one packing: generate, relax, ramps, the stages it has finished
``job``     packings spread over MPI ranks, resumable; the subcommand
``combine`` ``--combine``: the finished packings of several runs in one folder
``report``  ``ensemble.md``, ``ensemble.h5`` and the figure
"""
