"""The jobs: each a package with its configuration, run, report and figures.

``paper``        ``remote-trigger paper``: the paper end to end (docs/paper.md)
``trigger_map``  ``remote-trigger trigger-map``: forcing amplitude vs load (docs/trigger_map.md)
``ensemble``     ``remote-trigger ensemble``: F_x^c over packings and sizes (docs/ensemble.md)
``accuracy``     ``remote-trigger accuracy``: the numerical accuracy study (docs/accuracy.md)
``demo``         ``remote-trigger demo``: a small settle with the styles

May import: :mod:`remote_trigger.pywrap.stages`, ``runtime``, ``bindings``, ``config``,
:mod:`remote_trigger.analysis`; a job does not import another job except ``paper``
(whose folder the trigger map and the ensemble start from).
"""
