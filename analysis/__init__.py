"""remote_trigger.analysis: equilibria, Jacobians and eigenvalues of frictional packings.

Modules (docs/analysis.md):

``state``         read an equilibrium dump (with contact history) into a float64 State
``jacobian``      K = -dG/dq (paper Appendix C), residual G, rattler removal
``eigen``         eigenvalues of M^-1 K: dense LAPACK, ARPACK shift-invert, omega, growth
``exceptional``   certified complex-pair decision near exceptional points
``analyze``       the whole pipeline for one state or dump
``forcelaw_ref``  independent complex-step-capable force law (tests)
``cli_jacobian``  ``remote-trigger jacobian DUMP -o OUT.npz``

Imports are lazy: importing this package loads nothing heavy.
"""
