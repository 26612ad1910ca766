"""remote_trigger.analysis: equilibria, Jacobians and eigenvalues of frictional packings.

Modules (docs/analysis.md):

``state``         read an equilibrium dump (with contact history) into a float64 State
``jacobian``      K = -dG/dq (paper Appendix C), residual G, rattler removal
``eigen``         eigenvalues of M^-1 K: dense LAPACK, ARPACK shift-invert, omega, growth
``exceptional``   certified complex-pair decision near exceptional points
``analyze``       the whole pipeline for one state or dump
``forcelaw_ref``  independent complex-step-capable force law (tests)
``stability``     the ramp's verdict: certified decision, its codes, growth rate
``eigtrack``      the coalescing eigenvalue pair through a ramp (Fig. 3)
``series``        D(t) series: noise level, growth window and rate, saturation
``trajectory``    LAMMPS dump trajectories with MDAnalysis; D(t) and its float32 floor
``output``        atomic writers (text, JSON, HDF5, npz, figures) and output checks
``cli_jacobian``  ``remote-trigger jacobian DUMP -o OUT.npz``

Imports are lazy: importing this package loads nothing heavy.
"""
