"""A ramp point decides the equilibrium LAMMPS holds (``point.held_system``),
built once from the gathered arrays, not read back from its dump: the
reduced system must be the dump's bit for bit (K, M, kept dofs), so that
the verdict, the checkpoint key of a sliced scan and every stored number
are those of the dump a user re-analyses."""
import numpy as np
import pytest


def _same(a, b):
    """The two ReducedSystems are equal bit for bit."""
    assert a.K.shape == b.K.shape
    for name in ("indptr", "indices", "data"):
        assert getattr(a.K, name).tobytes() == getattr(b.K, name).tobytes(), name
    assert a.mass.tobytes() == b.mass.tobytes()
    assert a.keep_dofs.tobytes() == b.keep_dofs.tobytes()
    assert a.residual.tobytes() == b.residual.tobytes()


@pytest.mark.parametrize("F_x", [0.0, 0.02])
def test_the_held_system_is_the_dumps(relaxed, tmp_path, F_x):
    from remote_trigger.analysis.stability.system import reduced_system
    from remote_trigger.analysis.state.dumpfile import read_equilibrium
    from remote_trigger.pywrap.bindings.engine import Engine
    from remote_trigger.pywrap.stages import equilibrium as eq
    from remote_trigger.pywrap.stages.common import load_equilibrium_scene, save_equilibrium
    from remote_trigger.pywrap.stages.config import RampConfig
    from remote_trigger.pywrap.stages.point import held_system

    cfg = RampConfig(datafile=relaxed.datafile)
    prefix = str(tmp_path / "p")
    with Engine() as eng:
        load_equilibrium_scene(eng, cfg, relaxed.datafile, F_x, 2)
        eq.equilibrate(eng, cfg, F_x, newton_first=True)
        save_equilibrium(eng, cfg, F_x, prefix)
        held = held_system(eng, cfg, F_x)()
    read = reduced_system(read_equilibrium(prefix + ".dump"))
    assert held.n > 0 and held.K.nnz > 0
    _same(held, read)


def test_the_check_can_fail(relaxed):
    """Another F_x (the loads in the residual) is seen."""
    from remote_trigger.analysis.stability.system import reduced_system
    from remote_trigger.analysis.state.dumpfile import read_equilibrium

    st = read_equilibrium(relaxed.dumpfile)
    a = reduced_system(st)
    st.external[st.external[:, 0] != 0] *= 1.0 + 1e-15
    st.external[:, 0][np.argmax(np.abs(st.external[:, 1]))] += 1e-12
    with pytest.raises(AssertionError):
        _same(a, reduced_system(st))
