"""``remote-trigger trigger-map`` (docs/trigger_map.md).

``config``  :class:`MapConfig` (TOML, ``--set``, ``--quick``)
``loads``   the loads, windows and amplitudes of the map from a paper folder
``job``     the runs, spread over MPI ranks, resumable; the subcommand
``report``  ``trigger_map.md``, the table and the figure
"""
