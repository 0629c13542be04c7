"""Run a model spec on real FEBio 4 and read the result back into the studio's schema.

The ``febio4`` executable is found through the ``FEBIO_PATH`` environment variable (the
executable itself or the folder that holds it) or else on ``PATH``. Each run gets its own work
folder holding the ``.feb``, FEBio's log and plot file; FEBio is started with an argument list
(never through a shell) and a timeout. Normal and error termination are told apart by the log;
a failure raises :class:`FebioError`, which names the depth reached, quotes the log's last
lines and carries the steps that did converge.

Every must point is checked for equilibrium (:mod:`forward.febio.equilibrium`). When FEBio
accepted steps off equilibrium, the model is run once more with
:meth:`FebSettings.tightened` (smaller increments, tighter convergence norms) in ``rerun/`` of
the work folder, and the run with fewer flagged steps is kept (the first on a tie, or when the
rerun fails); ``solver['rerun']`` of the result records what changed and what each run gave.
The flagged steps that remain have NaN forces.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path

from ..mesh import BlockMesh
from ..result import SimulationResult
from ..solver import SimulationError
from ..spec import ModelSpec
from .equilibrium import DEFAULT_EQUILIBRIUM_TOLERANCE, EquilibriumTolerance, off_equilibrium_message
from .log import FebioLog, FebioLogError, depth_reached, febio_result, read_febio_log
from .writer import FebSettings, write_feb

EXECUTABLE_NAMES = ("febio4", "febio4.exe", "FEBio4", "febio")


class FebioNotFoundError(FileNotFoundError):
    """No FEBio executable: the message says how to point the studio at one."""


class FebioError(SimulationError):
    """A FEBio run that did not terminate normally."""


class OffEquilibriumError(FebioError):
    """A FEBio run whose result still has steps off equilibrium (``partial`` holds it)."""


def require_equilibrium(result: SimulationResult) -> SimulationResult:
    """``result`` unchanged when no step is flagged off equilibrium; else
    :class:`OffEquilibriumError` naming the depths, with the result (NaN there) as ``partial``."""
    message = off_equilibrium_message(result)
    if message is None:
        return result
    rerun = result.solver.get("rerun")
    if rerun:
        message += (
            f" (after a rerun with tightened settings: {rerun['outcome']}, kept the {rerun['kept']} run)"
        )
    raise OffEquilibriumError(message, float(result.depth[-1]), result)


def find_febio(environ: dict[str, str] | None = None) -> Path:
    """The ``febio4`` executable named by ``FEBIO_PATH`` (file or folder), else found on ``PATH``.

    Parameters
    ----------
    environ : dict of str to str, optional
        The environment to read; default ``os.environ``.

    Returns
    -------
    pathlib.Path
        The executable.

    Raises
    ------
    FebioNotFoundError
        If ``FEBIO_PATH`` holds no executable ``febio4``, or none is on ``PATH``.
    """
    env = os.environ if environ is None else environ
    hint = (
        "FEBio 4 not found: set FEBIO_PATH to the febio4 executable (or the folder holding it), "
        "or put febio4 on PATH"
    )
    given = env.get("FEBIO_PATH")
    if given:
        p = Path(given).expanduser()
        candidates = (
            [p]
            if p.is_file()
            else [p / n for n in EXECUTABLE_NAMES] + [p / "bin" / n for n in EXECUTABLE_NAMES]
        )
        for c in candidates:
            if c.is_file() and os.access(c, os.X_OK):
                return c
        raise FebioNotFoundError(f"{hint} (FEBIO_PATH={given} holds no executable febio4)")
    for name in EXECUTABLE_NAMES:
        found = shutil.which(name, path=env.get("PATH"))
        if found:
            return Path(found)
    raise FebioNotFoundError(hint)


def febio_version(executable: Path) -> str | None:
    """The version FEBio prints in its banner, or None when it prints none."""
    try:
        out = subprocess.run(
            [str(executable), "-info"], capture_output=True, text=True, timeout=30, check=False
        ).stdout
    except (OSError, subprocess.TimeoutExpired):
        return None
    for line in out.splitlines():
        if "version" in line.lower():
            return line.split("version", 1)[-1].strip() or None
    return None


class FebioSolver:
    """Solves one :class:`ModelSpec` with FEBio 4: write, run, parse, check equilibrium.

    ``timeout_s`` bounds the whole solve, the rerun included (it gets the time left over).

    Parameters
    ----------
    spec : ModelSpec
        The model.
    mesh : BlockMesh, optional
        The mesh; default the spec's.
    settings : FebSettings, optional
        FEBio's numerics; default ``FebSettings()``.
    executable : str or pathlib.Path, optional
        The FEBio 4 executable; default :func:`find_febio`.
    workdir : str or pathlib.Path, optional
        Where the .feb and log files go; default a temporary folder.
    timeout_s : float or None, default 3600
        Time limit of the whole solve, s.
    tolerance : EquilibriumTolerance
        When a step counts as off equilibrium.
    rerun_off_equilibrium : bool, default True
        Steps off equilibrium make one rerun with tightened settings.
    """

    def __init__(
        self,
        spec: ModelSpec,
        mesh: BlockMesh | None = None,
        settings: FebSettings | None = None,
        executable: str | Path | None = None,
        workdir: str | Path | None = None,
        timeout_s: float | None = 3600.0,
        tolerance: EquilibriumTolerance = DEFAULT_EQUILIBRIUM_TOLERANCE,
        rerun_off_equilibrium: bool = True,
    ) -> None:
        self.spec = spec
        self.mesh = mesh
        self.settings = settings or FebSettings()
        self.executable = Path(executable) if executable else find_febio()
        self.workdir = Path(workdir) if workdir else None
        self.timeout_s = timeout_s
        self.tolerance = tolerance
        self.rerun_off_equilibrium = rerun_off_equilibrium

    def run(self, progress: Callable[[int, int, float], None] | None = None) -> SimulationResult:
        """Run FEBio to the spec's last step: write, run, parse, check equilibrium.

        Steps off equilibrium make one rerun with tightened settings (module docstring).

        Parameters
        ----------
        progress : callable, optional
            ``progress(k, steps, depth)`` after each must point.

        Returns
        -------
        SimulationResult
            The result; steps still off equilibrium carry NaN forces and are flagged.
        """
        workdir = self.workdir or Path(tempfile.mkdtemp(prefix="febio-"))
        first = self._run_once(self.settings, workdir, progress, self.timeout_s)
        flagged = first.off_equilibrium_depths
        if not flagged or not self.rerun_off_equilibrium:
            return first
        remaining = None if self.timeout_s is None else self.timeout_s - first.wall_s
        tighter = self.settings.tightened()
        old, new = asdict(self.settings), asdict(tighter)
        record: dict = {
            "reason": f"off equilibrium at depth {', '.join(f'{d:g}' for d in flagged)} mm",
            "settings_changed": {k: [old[k], new[k]] for k in old if old[k] != new[k]},
            "first_off_equilibrium_depths_mm": flagged,
            "first_log_file": first.solver["log_file"],
        }
        if remaining is not None and remaining <= 0:
            record |= {"outcome": f"not rerun: the {self.timeout_s:g} s timeout is used up", "kept": "first"}
            first.solver["rerun"] = record
            return first
        try:
            second = self._run_once(tighter, workdir / "rerun", progress, remaining)
        except FebioError as exc:
            record |= {"outcome": f"rerun failed: {str(exc).splitlines()[0]}", "kept": "first"}
            first.solver["rerun"] = record
            return first
        better = len(second.off_equilibrium_depths) < len(flagged)
        kept = second if better else first
        record |= {
            "outcome": "rerun finished",
            "rerun_off_equilibrium_depths_mm": second.off_equilibrium_depths,
            "rerun_log_file": second.solver["log_file"],
            "kept": "rerun" if better else "first",
            "wall_s": [first.wall_s, second.wall_s],
        }
        kept.solver["rerun"] = record
        kept.wall_s = first.wall_s + second.wall_s
        return kept

    def _run_once(
        self,
        settings: FebSettings,
        workdir: Path,
        progress: Callable[[int, int, float], None] | None,
        timeout_s: float | None,
    ) -> SimulationResult:
        """Write the .feb with ``settings`` into ``workdir``, run FEBio there (killed after
        ``timeout_s``), read the log."""
        workdir.mkdir(parents=True, exist_ok=True)
        feb = write_feb(self.spec, workdir / "model.feb", mesh=self.mesh, settings=settings)
        log_path = feb.with_suffix(".log")
        log_path.unlink(missing_ok=True)
        steps = self.spec.protocol.steps
        cmd = [str(self.executable), "-i", feb.name, "-silent"]
        t0 = time.perf_counter()
        with open(workdir / "febio.stdout", "wb") as out:
            proc = subprocess.Popen(cmd, cwd=workdir, stdout=out, stderr=subprocess.STDOUT)
            timed_out = False
            done = 0
            while proc.poll() is None:
                if timeout_s is not None and time.perf_counter() - t0 > timeout_s:
                    proc.kill()
                    proc.wait()
                    timed_out = True
                    break
                if progress is not None:
                    done = self._report(log_path, done, steps, progress)
                time.sleep(0.5)
        wall = time.perf_counter() - t0
        if not log_path.is_file():
            raise FebioError(
                f"FEBio ({self.executable}) wrote no log (exit code {proc.returncode}); "
                f"its output: {_tail(workdir / 'febio.stdout')}",
                0.0,
            )
        log = read_febio_log(log_path)
        if timed_out or log.terminated != "normal":
            self._fail(log, feb, wall, f"timed out after {timeout_s:.0f} s" if timed_out else None)
        result = febio_result(
            log, self.spec.to_dict(), feb_file=feb, steps=steps, wall_s=wall, tolerance=self.tolerance
        )
        result.solver["executable"] = str(self.executable)
        result.solver["settings"] = asdict(settings)
        if len(result.depth) != steps + 1:
            self._fail(log, feb, wall, f"the log holds {len(result.depth) - 1} of {steps} steps")
        if progress is not None:
            progress(steps, steps, result.depth[-1])
        return result

    def _report(
        self, log_path: Path, done: int, steps: int, progress: Callable[[int, int, float], None]
    ) -> int:
        try:
            log = read_febio_log(log_path)
        except (FebioLogError, OSError):
            return done
        k = int(sum(abs(t - round(t)) < 1e-6 and t > 0 for t in log.converged_times))
        if k > done:
            progress(min(k, steps), steps, depth_reached(log))
        return max(k, done)

    def _fail(self, log: FebioLog, feb: Path, wall: float, reason: str | None) -> None:
        depth = depth_reached(log)
        partial = None
        try:
            partial = febio_result(
                log,
                self.spec.to_dict(),
                feb_file=feb,
                steps=self.spec.protocol.steps,
                wall_s=wall,
                tolerance=self.tolerance,
            )
        except FebioLogError:
            pass
        what = reason or f"{log.terminated} termination"
        raise FebioError(
            f"FEBio run failed ({what}) at depth {depth:.3f} mm of {self.spec.protocol.max_depth:g} mm; "
            f"log {log.path}, last lines:\n{log.last_lines()}",
            depth,
            partial,
        )


def _tail(path: Path, n: int = 8) -> str:
    try:
        return "\n".join(path.read_text(errors="replace").rstrip().splitlines()[-n:])
    except OSError:
        return "(none)"


def simulate_febio(spec: ModelSpec, workdir: str | Path | None = None, **kwargs) -> SimulationResult:
    """Run one simulation of ``spec`` on FEBio 4."""
    return FebioSolver(spec, workdir=workdir, **kwargs).run()
