"""remote_trigger.analysis: equilibria, Jacobians and eigenvalues of frictional packings."""
