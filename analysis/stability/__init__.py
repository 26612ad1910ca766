"""The linear algebra of the stability verdict.

``jacobian``      K = -dG/dq (paper Appendix C), residual G, rattler removal
``jacobian3d``    the same for spheres: 6 dofs per sphere, 12 x 12 and 6 x 6 blocks
``eigen``         eigenvalues of M^-1 K: dense LAPACK, ARPACK shift-invert, omega, growth
``exceptional``   the certified complex-pair decision near exceptional points (its proof)
``decision``      its results: PairDecision, SpectrumDecision, SpectrumBasis
``verification``  its steps 1-5 for one basis: units, enclosure, pairs, isolation
``basis``         the decision started from a previous decision's basis
``projected``     the decision on the k eigenvalues nearest a shift (sparse, partial)
``sliced``        the whole-spectrum certified verdict by spectrum slicing (sparse; a package)
``enclosure``     the rigorous float64 bounds of both decisions
``verdict``       the ramp's verdict: certified decision, its codes, growth rate
``eigtrack``      the coalescing eigenvalue pair through a ramp (Fig. 3)
``modeshape``     the pair's mode: participation ratio, collective or local
``analyze``       the whole pipeline for one state or dump
``timestep``      the stable time step from the spectrum

May import: numpy, scipy, :mod:`remote_trigger.analysis.state`, ``errors``, ``output``.
"""
