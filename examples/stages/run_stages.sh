#!/bin/sh
# The three stages as plain LAMMPS runs of the project's decks (no Python
# driver): relax a generated packing, one ramp step, one perturbation run.
#
#   sh run_stages.sh [N] [SEED] [DECKS]      (defaults 40, 1, ../../lammps_inputs)
#
# `remote-trigger`, `lmp` and `mpirun` are in .venv/bin (make install).
# Outputs in the current folder: packing.data, relaxed.{data,dump,dump.json},
# step.{data,dump,dump.json}, perturb.txt (step time D v_top mu).
set -e
N=${1:-40}
SEED=${2:-1}
DECKS=${3:-$(dirname "$0")/../../lammps_inputs}
remote-trigger generate --n "$N" --seed "$SEED" --output packing.data --overwrite
# (i)-(iv) of the driver's relax protocol; stops with status 3 if fmin is not reached
lmp -in "$DECKS/in.relax" -log relax.log -var datafile packing.data -var out relaxed
# one ramp step: the relaxed state at F_x = 0.001 (damped to fmin)
lmp -in "$DECKS/in.ramp_step" -log step.log -var datafile relaxed.data -var Fx 0.001 -var out step
# undamped run from it with f(t) = a cos(wp t), smooth onset, and mu(v)
lmp -in "$DECKS/in.perturb" -log perturb.log -var datafile step.data -var Fx 0.001 \
    -var a 1e-6 -var wp 1.0 -var ton 1.5708 -var muv 1 -var v0 1e-9 \
    -var nsteps 5000 -var every 100 -var out perturb
echo "done: relaxed.dump step.dump perturb.txt"
