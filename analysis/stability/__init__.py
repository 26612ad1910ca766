"""The linear algebra of the stability verdict.

``verdict``       the engine: ``decide(reduced_system(state), VerdictOptions)`` -> StabilityResult
``system``        the reduced system: K, M on the kept dofs, rattlers, residual
``residual``      is a state an equilibrium: residual, round-off floor, the check
``jacobian``      K = -dG/dq (paper Appendix C), residual G, rattler removal
``jacobian3d``    the same for spheres: 6 dofs per sphere, 12 x 12 and 6 x 6 blocks
``eigen``         eigenvalues of M^-1 K: dense LAPACK, ARPACK shift-invert, omega, growth
``exceptional``   the certified complex-pair decision near exceptional points (its proof)
``decision``      Decision (the three-way answer, its codes) and the result types
``verification``  its steps 1-5 for one basis: units, enclosure, pairs, isolation
``basis``         the decision started from a previous decision's basis
``projected``     the decision on the k eigenvalues nearest a shift (sparse, partial)
``sliced``        the whole-spectrum certified verdict by spectrum slicing (sparse; a package)
``enclosure``     the rigorous float64 bounds of both decisions
``eigtrack``      the coalescing eigenvalue pair through a ramp (Fig. 3)
``modeshape``     the pair's mode: participation ratio, collective or local
``analyze``       the analyzer of ``remote-trigger jacobian``; the saddle screen
``timestep``      the stable time step from the spectrum

May import: numpy, scipy, :mod:`remote_trigger.analysis.state`, ``errors``, ``output``.
"""
