"""``remote-trigger jacobian DUMP [-o OUT.npz]``: stiffness matrix and spectrum of a dump.

Reads an equilibrium dump (``docs/conventions.md`` section 3, with its
sidecar ``DUMP.json``), assembles K = -dG/dq (paper Appendix C), removes
rattlers, computes the eigenvalues of M^-1 K and decides whether a complex
pair is present; writes everything to a NumPy ``.npz`` file (keys in
``docs/analysis.md``; default: the dump's name with ``.npz`` for its
extension, beside it) and prints a one-screen summary.

A dump of spheres (docs/driver.md "Spheres": the columns z, fz, tqx ...,
d2_mindlin_tx[*], ...) is read as such
(:func:`~remote_trigger.analysis.state.dumpfile.dump_dimension`): K over
q = (r, R theta) with 6 dofs per sphere (``jacobian3d``), rattlers below 3
contacts, M = diag(m, m, m, 2m/5, 2m/5, 2m/5).

It refuses (exit status 2, nothing written) a dump whose residual is far
above the round-off floor (:func:`~remote_trigger.analysis.stability.residual.check_equilibrium`):
the spectrum of a state that is not an equilibrium means nothing.
``--allow-residual`` analyses it anyway and prints a warning. A ``--k-n``,
``--k-t`` or ``--mu`` that contradicts the sidecar is refused unless
``--override``.

One point on several cores (docs/analysis.md, "One large point on many
cores"): ``--part-size P`` scans the sliced verdict in parts of about P
eigenvalues (``VerdictOptions.part_size``), and ``--np K`` re-launches the
command under ``mpirun -np K`` (or run it under ``mpirun -np K`` yourself):
rank 0 reads, decides and writes, every rank runs parts
(:mod:`~remote_trigger.pywrap.runtime.rankmap`). The partition depends on
the matrix and P only: the verdict, eigenvalues and margins are the same,
bit for bit, on any number of ranks. ``--np K > 1`` needs ``--part-size``;
under ``mpirun`` without it rank 0 works alone.

``--method auto`` decides on the whole spectrum: dense LAPACK up to 3000
dofs, spectrum slicing above (:mod:`~remote_trigger.analysis.stability.sliced`).
Only ``--method sparse`` decides on the ``--k`` eigenvalues nearest a shift:
that is printed and stored as a **partial** decision (``coverage =
'partial'``, ``complex_pair = -1``, its own answer in
``partial_complex_pair``), never as the stability verdict.
"""
from __future__ import annotations

import math
import os
import sys

import numpy as np

from remote_trigger.analysis.stability.analyze import analyze
from remote_trigger.analysis.state.dumpfile import dump_dimension, read_dump, read_dump3d


def register(subparsers):
    """Add the ``jacobian`` subcommand to an argparse subparsers object."""
    p = subparsers.add_parser(
        "jacobian", help="stiffness matrix K = -dG/dq and eigenvalues of an equilibrium dump",
        description="Assemble K = -dG/dq over q = (x, y, R theta) per disk (spheres: "
                    "q = (x, y, z, R theta), 6 per sphere) from an equilibrium dump (with "
                    "contact history), remove rattlers, compute the eigenvalues of M^-1 K and "
                    "write them to an .npz file.")
    p.add_argument("dump", help="text dump (dump custom, %%.17g, sorted by id) with the "
                                "history columns; parameters from DUMP.json")
    p.add_argument("-o", "--output", default=None,
                   help="output .npz file (default: DUMP with its extension replaced by "
                        ".npz, e.g. out/relax/equilibrium.npz)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace an existing output file (default: refuse, exit status 2)")
    p.add_argument("--frame", type=int, default=-1, help="snapshot index (default: last)")
    for name, hlp in (("k-n", "normal stiffness k_n"), ("k-t", "tangential stiffness k_t"),
                      ("mu", "friction coefficient"), ("wall-y", "height of the flat wall")):
        p.add_argument(f"--{name}", type=float, default=None,
                       help=f"{hlp} (default: the sidecar JSON's; a different value "
                            f"needs --override)")
    p.add_argument("--override", action="store_true",
                   help="use --k-n/--k-t/--mu/--wall-y even where they contradict the sidecar")
    p.add_argument("--allow-residual", action="store_true",
                   help="analyse a state whose residual is far above the round-off floor "
                        "(not an equilibrium of its parameters), with a warning")
    p.add_argument("--method", choices=("auto", "dense", "sliced", "sparse"), default="auto",
                   help="dense LAPACK or spectrum slicing (both the whole-spectrum certified "
                        "verdict), or ARPACK shift-invert (a partial decision on --k "
                        "eigenvalues near --sigma, labelled so); default auto: dense up to "
                        "3000 dofs, sliced above")
    p.add_argument("--k", type=int, default=40, help="sparse path: eigenvalues per shift "
                                                     "(default 40)")
    p.add_argument("--sigma", type=float, default=None,
                   help="sparse path: shift in units of 1/time^2 (default: 0.25 x the largest "
                        "diagonal entry of M^-1 K after rattler removal, inside the band "
                        "where pairs coalesce)")
    p.add_argument("--min-contacts", type=int, default=None,
                   help="rattler criterion: fewer contacts than this (default 2 for disks, "
                        "3 for spheres)")
    p.add_argument("--no-eigen", action="store_true", help="write K only")
    p.add_argument("--part-size", type=int, default=None,
                   help="sliced verdict in parts of about this many eigenvalues, run side by "
                        "side on the MPI ranks (>= the slice size, 60; the answer depends on "
                        "it, never on the number of ranks; default: one part, the whole scan)")
    p.add_argument("--np", type=int, default=1,
                   help="MPI ranks: re-launch under mpirun -np NP, every rank running parts "
                        "of the sliced verdict (needs --part-size; default 1)")
    p.set_defaults(func=run)


def default_output(dump):
    """The ``-o`` of a ``jacobian`` run without one: ``DUMP`` with ``.npz``
    for its last extension (``a/equilibrium.dump`` -> ``a/equilibrium.npz``;
    a name without an extension gets ``.npz`` appended)."""
    root, ext = os.path.splitext(dump)
    return (root if ext and ext != ".npz" else dump) + ".npz"


def check_parallel(args):
    """Refuse a bad ``--np`` or ``--part-size`` in one line (before any work).

    Raises
    ------
    InputError
        ``--np`` below 1, ``--part-size`` below 2, or ``--np`` above 1
        without ``--part-size``.
    """
    from remote_trigger.analysis.errors import InputError

    if args.np < 1:
        raise InputError(f"--np must be >= 1, got --np {args.np}")
    if args.part_size is not None and args.part_size < 2:
        raise InputError(f"--part-size must be an integer >= 2 (and >= the slice size, 60), "
                         f"got --part-size {args.part_size}")
    if args.np > 1 and args.part_size is None:
        raise InputError(f"--np {args.np} needs --part-size P: the ranks share the parts of "
                         f"the sliced verdict, whose answer depends on P only (e.g. "
                         f"--part-size 2000)")


def run(args):
    """Execute the subcommand on every rank; returns the exit status.

    Rank 0 reads the dump, decides and writes; under MPI the other ranks run
    parts of a sliced verdict with ``--part-size``
    (:func:`~remote_trigger.pywrap.runtime.rankmap.on_rank0_with_ranks`) and
    return rank 0's status or exception.

    Raises
    ------
    InputError
        Bad output name, parameters that contradict the sidecar, a state
        far from equilibrium (without ``--allow-residual``), or a bad
        ``--np`` / ``--part-size``.
    FileNotFoundError, ValueError
        Missing or malformed dump.
    """
    from mpi4py import MPI

    from remote_trigger.pywrap.runtime.relaunch import RELAUNCHED

    check_parallel(args)
    world = MPI.COMM_WORLD
    if args.np > 1 and world.Get_size() == 1 and not os.environ.get(RELAUNCHED):
        from remote_trigger.pywrap.cli import Parser
        from remote_trigger.pywrap.runtime.relaunch import relaunch_words

        return relaunch_words("jacobian", Parser.words, args.np)
    if world.Get_size() == 1:
        return run_rank0(args)
    from remote_trigger.analysis.stability.sliced.parts import PartsProblem
    from remote_trigger.pywrap.runtime.rankmap import on_rank0_with_ranks

    if args.part_size is None:          # rank 0 alone, the others wait
        from remote_trigger.pywrap.runtime.parallel import on_rank0

        return on_rank0(world, run_rank0, args)
    return on_rank0_with_ranks(world, lambda pmap: run_rank0(args, pmap), (PartsProblem,))


def run_rank0(args, map_tasks=None):
    """The command on one process (rank 0): read, decide (the parts of a sliced
    verdict run by ``map_tasks``), write, print; returns the exit status."""
    from remote_trigger.analysis.output import output_file, write_npz_atomic
    from remote_trigger.analysis.stability.decision import Decision
    from remote_trigger.analysis.stability.residual import check_equilibrium
    from remote_trigger.analysis.errors import InputError, NotEquilibriumError
    from remote_trigger.analysis.state.sidecar import merge_model

    if not os.path.exists(args.dump):
        raise FileNotFoundError(f"dump file not found: {args.dump}")
    spheres = dump_dimension(args.dump, args.frame) == 3    # a dump at all (its header)
    if args.output is None:
        args.output = default_output(args.dump)
    output = output_file(args.output, "-o/--output", suffix=".npz")
    if os.path.exists(output) and not args.overwrite:
        raise InputError(f"-o/--output {args.output!r} exists; choose another file or add "
                         f"--overwrite (nothing was written)")
    given = {"k_n": args.k_n, "k_t": args.k_t, "mu": args.mu, "wall_y": args.wall_y}
    merge_model(given, args.dump, flags={"k_n": "--k-n", "k_t": "--k-t", "mu": "--mu",
                                         "wall_y": "--wall-y"},
                override=args.override, keys=("k_n", "k_t", "mu", "wall_y"))
    state = (read_dump3d if spheres else read_dump)(
        args.dump, frame=args.frame, k_n=args.k_n, k_t=args.k_t, mu=args.mu, wall_y=args.wall_y)
    try:
        check_equilibrium(state, what=args.dump)
        warning = None
    except NotEquilibriumError as exc:
        if not args.allow_residual:
            raise NotEquilibriumError(f"{exc}; --allow-residual analyses it anyway") from None
        warning = f"WARNING: {exc}; the eigenvalues of this run do not describe its motion"
        print(f"remote-trigger jacobian: {warning}", file=sys.stderr, flush=True)
    bar = []                    # a progress bar for a sliced verdict (minutes at N >= 6400)

    def progress(done, n):
        if not bar:
            from remote_trigger.pywrap.stages.common import progress_bar

            bar.append(progress_bar(n, "verdict", False, 0, unit=" eigenvalues"))
        bar[0].update(done - bar[0].n)
        if done == n:
            bar[0].refresh()        # the last count shown, whatever tqdm's interval

    try:
        res = analyze(state, eigenvalues=not args.no_eigen, decide=not args.no_eigen,
                      method=args.method, k=args.k, sigma=args.sigma,
                      min_contacts=args.min_contacts, progress=progress,
                      part_size=args.part_size, map_tasks=map_tasks)
    finally:
        if bar:
            bar[0].close()
    sigma = res.eigen.sigma if res.eigen is not None and res.eigen.sigma is not None \
        else np.nan
    K = res.K
    lam = res.eigenvalues if res.eigen is not None else np.zeros(0, complex)
    dec = res.decision
    # the stored verdict: a partial decision (k eigenvalues near a shift) is no
    # verdict, so complex_pair is -1 then and its own answer goes to partial_complex_pair
    flag = int(Decision.UNDECIDED if dec is None else dec.decision)
    partial = dec is not None and not dec.is_verdict
    out = {
        "K_data": K.data, "K_indices": K.indices, "K_indptr": K.indptr,
        "K_shape": np.array(K.shape, dtype=np.int64),
        "mass": res.mass, "ids": state.dof_ids(), "rattlers": res.rattlers.ids,
        "keep_dofs": res.system.keep_dofs, "tied": res.system.tied, "eigenvalues": lam,
        "complex_pair": np.int64(-1 if partial else flag),
        "coverage": np.str_("none" if dec is None else dec.coverage),
        "partial_complex_pair": np.int64(flag if partial else -1),
        "confidence": np.float64(np.nan if dec is None else dec.confidence),
        "growth_rate": np.float64(np.nan if res.eigen is None else res.growth_rate),
        "residual": np.float64(res.max_residual),
        "method": np.str_("none" if res.eigen is None else res.eigen.method),
        "sigma": np.float64(sigma),
        "equilibrium": np.int64(warning is None),
        "part_size": np.int64(-1 if args.part_size is None else args.part_size),
    }
    write_npz_atomic(output, out)
    lines = [
        f"jacobian: {state.n} {'spheres' if spheres else 'disks'}, {state.n_contacts} contacts, "
        f"{state.wall_index.size} wall contacts, K {K.shape[0]}x{K.shape[1]} nnz {K.nnz}",
        f"  residual max |G| = {res.max_residual:.3g}; rattlers removed: "
        f"{res.rattlers.ids.size} {res.rattlers.ids.tolist()[:20]}"
        f"{' ...' if res.rattlers.ids.size > 20 else ''}",
    ]
    if res.eigen is not None and lam.size:
        # the sliced verdict's list: S's Ritz values where a strip holds one
        # eigenvalue (A's own is real, in the strip, moved by W at second order)
        what = (" approximate (the symmetric part's Ritz values outside pairs)"
                if res.eigen.method == "sliced" else "")
        lines.append(f"  eigenvalues ({res.eigen.method}): {lam.size}{what}, Re in "
                     f"[{lam.real.min():.6g}, {lam.real.max():.6g}], growth rate max Im omega "
                     f"= {res.growth_rate:.6g}")
        lines.append(f"  {dec.describe()}" if dec is not None else "  complex pair: not tested")
        if dec is not None and dec.is_verdict and dec.decision is Decision.COMPLEX:
            # are the complex pairs soft (near-floppy modes; docs/driver.md "Soft pairs")?
            from remote_trigger.analysis.stability import verdict

            top = (dec.lambda_max if math.isfinite(dec.scanned_below)
                   else float(lam.real.max()))
            word, soft = verdict.collective_decision(dec, top)
            answer = {Decision.COMPLEX: "yes", Decision.REAL: "no"}.get(word, word.label)
            lines.append(f"  soft pairs (|Re lambda| < {verdict.SOFT_MODE_REL:g} lambda_max): "
                         f"{soft}; a complex pair that is not soft: {answer}")
    if warning:
        lines.append(f"  {warning}")
    lines.append(f"  written: {args.output}")
    print("\n".join(lines))
    return 0
