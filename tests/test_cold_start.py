"""What a fresh process pays before its first increment (issue 35; docs/validation/solver-and-speed.md,
"Cold start"): which libraries a command line start and a simulation import, and numba's cache folder
on a read-only install. Nothing here is timed: the modules a fresh interpreter holds are counted."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np

from indentation_studio.forward import numba_cache

#: heavy libraries no simulation needs: optional (learning, sampling, tables) or for figures only
NOT_FOR_A_SIMULATION = ("torch", "sklearn", "pandas", "dask", "emcee", "matplotlib", "scipy.optimize")


def _modules_after(code: str) -> set[str]:
    """The modules a fresh interpreter has imported after running ``code`` (a module that
    ``lazy_loader.load`` put in ``sys.modules`` and nothing has used yet is not imported)."""
    probe = (
        f"{code}\nimport json, sys\n"
        "print(json.dumps(sorted(n for n, m in sys.modules.items() if type(m).__name__ != '_LazyModule')))"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    return set(json.loads(out.stdout.splitlines()[-1]))


def test_importing_the_command_line_imports_no_heavy_library():
    """``indent-studio --help`` and every command start here: neither the solver (numba, scipy's
    sparse solvers) nor a learning, sampling, table or figure library is imported."""
    loaded = _modules_after("import indentation_studio.studio.cli")
    assert not loaded & {*NOT_FOR_A_SIMULATION, "numba", "pypardiso", "scipy.sparse"}


def test_a_simulation_on_a_feb_mesh_imports_no_optimiser_or_figures(febio_baseline):
    """What ``simulate --mesh-from`` imports (the command's workflow and the solver) and the mesh
    it reads: no scipy.optimize (only the graded presets' root finder needs it), no matplotlib."""
    feb = febio_baseline / "baseline.feb"
    loaded = _modules_after(
        "from indentation_studio.forward import simulation_run, solver\n"
        "from indentation_studio.forward.mesh import build_mesh\n"
        "from indentation_studio.forward.spec import MeshChoice, ModelSpec\n"
        f"build_mesh(ModelSpec(mesh=MeshChoice(feb_file={str(feb)!r})))"
    )
    assert not loaded & set(NOT_FOR_A_SIMULATION)


def test_the_command_callback_sets_the_figure_backend_without_importing_matplotlib():
    """The command line's callback names the Agg backend through ``MPLBACKEND`` when matplotlib is
    not imported yet (importing it there cost every command 0.15 to 0.2 s)."""
    loaded = _modules_after(
        "import os\n"
        "from typer.testing import CliRunner\n"
        "from indentation_studio.studio.cli import app\n"
        "CliRunner().invoke(app, ['campaign', '--help'])\n"
        "assert os.environ['MPLBACKEND'] == 'Agg', os.environ.get('MPLBACKEND')"
    )
    assert "matplotlib" not in loaded


def test_a_graded_preset_still_finds_its_root():
    """The graded axis reaches brentq through the lazily loaded scipy.optimize: the same
    coordinates, to the bit, as brentq imported the usual way."""
    from scipy.optimize import brentq

    from indentation_studio.forward.mesh import axis_coordinates
    from indentation_studio.forward.mesh_presets import MESH_PRESETS

    axis, length = MESH_PRESETS["fine"].xy, 20.0
    n, rest = axis.n_graded, length - axis.h0 * axis.n_core
    r = brentq(lambda r: axis.h0 * (r**n - 1.0) / (r - 1.0) - rest, 1.0 + 1e-12, 10.0)
    expected = np.concatenate([[0.0], np.cumsum([axis.h0] * axis.n_core + list(axis.h0 * r ** np.arange(n)))])
    expected[-1] = length
    np.testing.assert_array_equal(axis_coordinates(axis, length), expected)


def test_numba_keeps_its_own_choice_where_the_source_folder_is_writable(monkeypatch):
    """A writable ``__pycache__`` beside the kernels (a checkout, an editable install) or a
    ``NUMBA_CACHE_DIR`` of the user's: nothing is changed."""
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setattr(numba_cache, "_writable", lambda folder: True)
    assert numba_cache.ensure_numba_cache_dir() is None
    assert "NUMBA_CACHE_DIR" not in numba_cache.os.environ
    monkeypatch.setenv("NUMBA_CACHE_DIR", "/somewhere")
    monkeypatch.setattr(numba_cache, "_writable", lambda folder: False)
    assert numba_cache.ensure_numba_cache_dir() is None
    assert numba_cache.os.environ["NUMBA_CACHE_DIR"] == "/somewhere"


def test_a_read_only_install_gets_a_cache_folder(monkeypatch, tmp_path):
    """Source folder read-only, no NUMBA_CACHE_DIR: the user's cache folder, else a private one
    under the temporary folder; numba's configuration follows if numba is imported."""
    import numba

    # set, then deleted: monkeypatch records the variable as the process had it (a delenv of an
    # absent variable records nothing), so that the folder the function sets below does not stay in
    # the environment of the later tests' subprocesses (campaign workers, the docs build), each of
    # which would then compile the kernels again into it (about 15 s each)
    monkeypatch.setenv("NUMBA_CACHE_DIR", "")
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    monkeypatch.setattr(numba.config, "CACHE_DIR", numba.config.CACHE_DIR)
    monkeypatch.setattr(numba_cache, "_writable", lambda folder: False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    folder = numba_cache.ensure_numba_cache_dir()
    assert folder == tmp_path / "cache" / "indentation-studio" / "numba"
    assert folder.is_dir()
    assert numba.config.CACHE_DIR == str(folder)

    monkeypatch.delenv("NUMBA_CACHE_DIR")
    monkeypatch.setattr(numba_cache, "_user_cache_folder", lambda: tmp_path / "unwritable" / "home")
    monkeypatch.setattr(numba_cache.os, "access", lambda path, mode: "unwritable" not in str(path))
    monkeypatch.setattr(numba_cache.tempfile, "gettempdir", lambda: str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    folder = numba_cache.ensure_numba_cache_dir()
    assert folder.parent == tmp_path / "tmp"
    assert folder.name.startswith("indentation-studio-numba-")
    assert folder.stat().st_mode & 0o077 == 0
