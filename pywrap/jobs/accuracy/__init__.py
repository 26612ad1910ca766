"""``remote-trigger accuracy`` (docs/accuracy.md).

``job``             the accuracy checks and the subcommand
``jacobian_check``  the Jacobian section (finite differences through LAMMPS)
``report``          the table rows (``Row``) and ``accuracy.md``, ``.h5``, ``.png``
"""
