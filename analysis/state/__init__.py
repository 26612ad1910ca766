"""A packing's state and its file formats.

==============  ==============================================================
``state``       :class:`State` (float64 positions, radii, masses, contacts with
                tangential displacements, wall contacts), ``build_state``
``state3d``     :class:`State3D` for spheres (tangential displacement vectors t,
                plane walls, I0 = 2/5), ``build_state3d``
``contacts``    the contacts it is built from: ``find_contacts``, ``minimum_image``,
                the touching band, the pair style's history and the wall's
``dumpfile``    the equilibrium dump + JSON sidecar format (read, write)
``sidecar``     the sidecar's model parameters (k_n, k_t, mu, F_x, F_y)
``datafile``    LAMMPS data files read and checked in float64
``trajectory``  LAMMPS dumps as MDAnalysis Universes; D(t)
==============  ==============================================================

May import: numpy, scipy, MDAnalysis, :mod:`remote_trigger.analysis.errors`,
:mod:`remote_trigger.analysis.output`.
"""
