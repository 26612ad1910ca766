"""remote_trigger.analysis: equilibria, Jacobians and eigenvalues of frictional packings.

Subpackages and modules (docs/analysis.md):

=================================  ==============================================================
``state``                          a packing's State and its file formats
``state.state``                    :class:`~remote_trigger.analysis.state.state.State`, ``build_state``
``state.state3d``                  ``State3D`` for spheres (t vectors, plane walls)
``state.contacts``                 contact finding: geometric contacts, touching band, history, wall
``state.dumpfile``                 the equilibrium dump + sidecar format (read, write)
``state.sidecar``                  the sidecar's model parameters
``state.datafile``                 LAMMPS data files read and checked in float64
``state.trajectory``               LAMMPS dump trajectories with MDAnalysis; D(t), float32 floor
``stability``                      the linear algebra of the stability verdict
``stability.verdict``              the engine: ``decide(system, VerdictOptions)`` -> ``StabilityResult``
``stability.system``               the reduced system: K and M on the kept dofs, rattlers, residual
``stability.residual``             is a state an equilibrium: residual, round-off floor, the check
``stability.jacobian``             K = -dG/dq (paper Appendix C), residual G, rattler removal
``stability.jacobian3d``           the same for spheres: 6N x 6N, 12 x 12 and 6 x 6 blocks
``stability.eigen``                eigenvalues of M^-1 K: dense LAPACK, ARPACK shift-invert
``stability.exceptional``          certified complex-pair decision near exceptional points
``stability.decision``             ``Decision`` (the three-way answer, its codes), the result types
``stability.verification``         its steps for one basis
``stability.basis``                its start from a previous decision's basis
``stability.projected``            a partial decision: the k eigenvalues nearest a shift
``stability.enclosure``            its rigorous float64 bounds
``stability.eigtrack``             the coalescing eigenvalue pair through a ramp (Fig. 3)
``stability.analyze``              the analyzer of ``remote-trigger jacobian``; the saddle screen
``stability.timestep``             the stable time step from the spectrum
``dynamics``                       time series and the normal form
``dynamics.series``                D(t) series: noise level, growth window and rate, saturation
``dynamics.normal_form``           the paper's 2x2 normal form
``forcelaw_ref``                   independent complex-step-capable force law (tests)
``forcelaw_ref3d``                 the same for spheres (3D law, pair style's 3D step)
``output``                         atomic writers (text, JSON, HDF5, npz, figures), output checks
``scaling``                        power laws over system sizes: fits, local slopes, crossover test
``weakest_link``                   the weakest-link (extreme-value) test of a size dependence
``errors``                         the exception hierarchy
=================================  ==============================================================

Imports are lazy: importing this package loads nothing heavy.
"""
