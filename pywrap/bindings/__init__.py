"""LAMMPS and the contact-law kernel from Python.

============  ==================================================================
``engine``    :class:`Engine`: one LAMMPS instance (commands, scatter/gather of the
              state, the plugin loaded), :class:`AtomState`, :class:`EngineError`
``decks``     the installed LAMMPS decks: their folder and marked sections
``kernel``    ctypes binding of the plugin's LAMMPS-free contact law (C API)
``datafile``  checks of a LAMMPS data file before LAMMPS reads it
``_plugin``   where the built plugin lives (the ``lammps.plugins`` entry point)
============  ==================================================================

May import: :mod:`remote_trigger.analysis`, :mod:`remote_trigger.pywrap.config`.
"""
