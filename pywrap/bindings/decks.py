"""The installed LAMMPS decks (``lammps_inputs/``): where they are and their sections.

The driver runs their marked sections
(:meth:`~remote_trigger.pywrap.bindings.engine.Engine.load_deck`);
docs/driver.md, "Decks".
"""
import os

#: folder of the installed decks (package data remote_trigger/lammps_inputs)
DECK_DIR = os.path.join(
    os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "lammps_inputs")


def deck_path(name):
    """Absolute path of an installed deck, e.g. ``deck_path('in.relax')``.

    Raises
    ------
    FileNotFoundError
        If no such deck is installed.
    """
    path = os.path.join(DECK_DIR, name)
    if not os.path.isfile(path):
        raise FileNotFoundError(f"no LAMMPS deck {name!r} in {DECK_DIR}")
    return path


def deck_sections(path):
    """Split a deck into its marked sections.

    A section starts at a line ``#@name`` and runs to the next such line;
    the lines before the first mark are the ``variables`` section. The
    decks' sections (docs/driver.md, "Decks"): ``scene`` (atoms, groups,
    pair style, wall, loads), ``damped`` (damping fixes and the integrator
    of the relaxing decks), ``dynamics`` (what every run needs), ``actions``
    (the standalone run), and the relax protocol's steps ``friction``,
    ``start``, ``compact``, ``lower``, ``shift``, ``press``, ``press_end``,
    ``fire`` (run by the driver too) and the standalone run's own
    ``clearance_test``, ``lower_measure``, ``place``, ``press_loop``,
    ``relax``, ``placement_test``, ``output``.

    Returns
    -------
    dict
        ``{name: str}``; ``variables``, ``scene``, ``dynamics`` and
        ``actions`` are always present (empty strings if missing).
    """
    sections = {"variables": [], "scene": [], "dynamics": [], "actions": []}
    current = "variables"
    with open(path) as fh:
        for line in fh:
            tag = line.strip()
            if tag.startswith("#@"):
                current = tag[2:].split()[0]
                sections.setdefault(current, [])
                continue
            sections[current].append(line)
    return {k: "".join(v) for k, v in sections.items()}
