"""Test data files, looked up by name here and nowhere else.

=====================================  =========================================
name                                   what
=====================================  =========================================
``default_job_mu1_step_00258``         ``remote-trigger paper`` with the default
                                       configuration (N = 100, seed 1): the ramp
                                       at mu = 1, ``ramp_mu1/ramp/step_00258.data``,
                                       F_x = 0.0645, the last ramp step before the
                                       first complex pair; every bisection point
                                       of that ramp starts from it.
``default_job_mu0.8_step_00234``       the same for mu = 0.8:
                                       ``ramp_mu0.8/ramp/step_00234.data``,
                                       F_x = 0.0585.
``saddle_N400_s8_step_00003``          ``remote-trigger ensemble``'s N = 400
                                       packing of seed 8 (relaxed by the
                                       default protocol), ramped at mu = 1 in
                                       steps of 2.5e-4 without the saddle
                                       escape: the step at F_x = 0.00075;
                                       Newton from it to F_x = 0.001 lands on
                                       a saddle (lowest eigenvalue -0.042).
``free_rotation_N400_s5_step_00002``   the same ensemble's seed 5 at
``..._step_00002.dump.json``           mu = 0.8, ramped without the escape:
                                       the equilibrium dump (and sidecar) at
                                       F_x = 0.0005. A disk whose contacts
                                       all slide has a free rotation
                                       (eigenvalue 0 of M^-1 K) and the
                                       symmetric part a negative eigenvalue
                                       (-0.097): no saddle. (Newton reaches
                                       it only along the ramp's own path.)
``tiled3_F0.0625``                     three exact copies of the default job's
``tiled3_F0.0625.dump.json``           packing (N = 100, seed 1) side by side
                                       along x (``benchmarks/degenerate.py``,
                                       ``build('tiled3_F0.0625')``): the
                                       equilibrium dump (and sidecar) at
                                       F_x = 0.0625, 837 kept dofs. A
                                       degenerate spectrum: the cell's Bloch
                                       sectors, split into hundreds of close
                                       pairs, some complex (the cell alone is
                                       real there).
=====================================  =========================================

Files are stored gzip-compressed (LAMMPS ``write_data`` text, 21 kB each at
N = 100, 88 kB at N = 400; the dump 106 kB).
"""
import gzip
import os
import shutil

HERE = os.path.dirname(os.path.abspath(__file__))

FILES = {
    "default_job_mu1_step_00258": "default_job_mu1_step_00258.data.gz",
    "default_job_mu0.8_step_00234": "default_job_mu0.8_step_00234.data.gz",
    "saddle_N400_s8_step_00003": "saddle_N400_s8_step_00003.data.gz",
    "free_rotation_N400_s5_step_00002": "free_rotation_N400_s5_step_00002.dump.gz",
    "free_rotation_N400_s5_step_00002.dump.json":
        "free_rotation_N400_s5_step_00002.dump.json.gz",
    "tiled3_F0.0625": "tiled3_F0.0625.dump.gz",
    "tiled3_F0.0625.dump.json": "tiled3_F0.0625.dump.json.gz",
}


def unpack(name, folder):
    """Decompress data file ``name`` into ``folder``; returns the path of the copy.

    Raises
    ------
    KeyError
        If ``name`` is not a registered data file.
    """
    if name not in FILES:
        raise KeyError(f"no test data file {name!r}; known: {sorted(FILES)}")
    out = os.path.join(str(folder), FILES[name][:-3])
    with gzip.open(os.path.join(HERE, FILES[name]), "rb") as src, open(out, "wb") as dst:
        shutil.copyfileobj(src, dst)
    return out
