"""feedsim from Python: the runs, statics and modes of the ``master`` tool, in-process.

A scene is a path to a scene file (TOML) or a dict of the same keys. Options are the command
line's, by their flag names with ``_`` for ``-`` (``t_end``, ``h_min``, ``iqn_reuse``, ...),
with the same defaults and checked by the same checks (the library's, not the command line's
parser): ``True`` gives a flag, a list a list option. Every number the functions return is
the one the ``master`` command prints for the same scene and options.

Errors: :class:`SceneError` (a ``ValueError``) for a scene that cannot be read or is not valid,
naming the file, the key and the value; :class:`RunError` (a ``RuntimeError``) for a run that
cannot start or stops, with the time and the cause; ``ValueError`` for an unknown or bad option.
The GIL is released while a model computes, so threads run in parallel.
"""

from __future__ import annotations

import io
import json
import os
from typing import Any, Callable, Mapping

from . import _feedsim

__all__ = ["Result", "RunError", "SceneError", "modes", "run", "run_system", "statics", "sweep"]

SceneError = _feedsim.SceneError
RunError = _feedsim.RunError

#: The label a scene given as a dict carries in error messages.
DICT_LABEL = "<dict>"


def _source(scene: str | os.PathLike | Mapping[str, Any]) -> tuple[str | None, str | None, str]:
    """(path, TOML text, label) of a scene given as a path or a dict."""
    if isinstance(scene, Mapping):
        return None, _toml(scene), DICT_LABEL
    if isinstance(scene, (str, os.PathLike)):
        path = os.fspath(scene)
        return path, None, path
    raise TypeError(f"scene: give a path or a dict of the scene's keys, not {type(scene).__name__}")


def _toml(scene: Mapping[str, Any]) -> str:
    """The TOML text of a dict of scene keys (tables, arrays of numbers and strings, scalars)."""
    lines: list[str] = []

    def value(v: Any, key: str) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, int):
            return str(int(v))
        if isinstance(v, float):
            v = float(v)  # numpy's float64 is a float whose repr names numpy
            return repr(v) if v == v and v not in (float("inf"), float("-inf")) else _nonfinite(v)
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(value(x, key) for x in v) + "]"
        if isinstance(v, Mapping):
            return "{" + ", ".join(f"{json.dumps(str(k))} = {value(x, key)}" for k, x in v.items()) + "}"
        if hasattr(v, "tolist"):  # numpy scalars and arrays
            return value(v.tolist(), key)
        raise SceneError(f"{DICT_LABEL}: key `{key}`: a {type(v).__name__} is not a scene value")

    def table(d: Mapping[str, Any], prefix: str) -> None:
        scalars = [(k, v) for k, v in d.items() if not isinstance(v, Mapping)]
        tables = [(k, v) for k, v in d.items() if isinstance(v, Mapping)]
        if prefix and (scalars or not tables):
            lines.append(f"[{prefix}]")
        for k, v in scalars:
            lines.append(f"{json.dumps(str(k))} = {value(v, f'{prefix}.{k}' if prefix else str(k))}")
        for k, v in tables:
            name = json.dumps(str(k))
            table(v, f"{prefix}.{name}" if prefix else name)

    table(scene, "")
    return "\n".join(lines) + "\n"


def _nonfinite(v: float) -> str:
    return "nan" if v != v else ("inf" if v > 0 else "-inf")


def _columns(csv: str) -> dict[str, Any]:
    """The CSV's columns as numpy arrays, in order: float64 where every cell is a number (as
    printed: round-trip exact; an empty cell is NaN), else the text (a system's String outputs)."""
    import csv as csvlib

    import numpy as np

    rows = list(csvlib.reader(io.StringIO(csv)))
    names, body = (rows[0], rows[1:]) if rows else ([], [])
    columns: dict[str, Any] = {}
    for k, name in enumerate(names):
        cells = [row[k] for row in body]
        try:
            columns[name] = np.array([float(c) if c else float("nan") for c in cells], dtype=np.float64)
        except ValueError:
            columns[name] = np.array(cells, dtype=object)
    return columns


class Result:
    """A finished run: ``summary`` (the keys of ``master run --json``), ``csv`` (the text of
    ``--out``), ``frame`` (a pandas DataFrame of the CSV's columns) and ``arrays()``."""

    def __init__(self, summary: dict[str, Any], csv: str, net=None):
        self.summary = summary
        self.csv = csv
        self._frame = None
        self._net = net

    def net(self):
        """The cable net at every sample of a run made with ``net=True``: a numpy array of shape
        ``(samples, cables, elements + 1, 3)``, each cable's points (m, world frame) from its
        anchor to its attachment point on the cabin, at the times of ``frame["t"]``."""
        import numpy as np

        if self._net is None:
            raise ValueError("this run kept no net: run it with net=True (--scheme monolithic or cable)")
        times, data, cables, points = self._net
        return np.frombuffer(data, dtype="<f8").reshape(len(times), cables, points, 3)

    def arrays(self) -> dict[str, Any]:
        """The time histories as numpy arrays by column name (``t`` first), without pandas."""
        return _columns(self.csv)

    @property
    def frame(self):
        """The time histories as a pandas DataFrame, the CSV's columns in its order."""
        if self._frame is None:
            import pandas as pd

            self._frame = pd.DataFrame(self.arrays())
        return self._frame

    def __repr__(self) -> str:
        s = self.summary
        peak = f", peak {s['peak_disp_mm']} mm" if "peak_disp_mm" in s else ""
        return f"<feedsim.Result {s.get('scene', s.get('system'))} {s.get('scheme')}: {s.get('steps')} steps{peak}>"


def run(
    scene,
    scheme: str = "ijcsa",
    *,
    dt: float | None = None,
    t_end: float | None = None,
    progress: Callable[[float, float], Any] | None = None,
    net: bool = False,
    **options,
) -> Result:
    """One run of a scene, as ``master run --scene F --scheme S``.

    ``scheme``: ``monolithic``, ``jacobi``, ``gauss-seidel``, ``gauss-seidel-reversed``,
    ``iterative``, ``ijcsa``, ``iqn-ils``, ``decoupled`` or ``cable``. ``dt`` and ``t_end``
    default to the scene's ``solver.dt_s`` and ``solver.t_end_s``. ``compensation="off"``: the
    scene with its second level switched off (its uncompensated reference); ``wind_seed=N``:
    another record of the scene's wind (``[wind] seed``). ``options``: the
    command line's scheme options (``adaptive=True``, ``rtol``, ``atol``, ``h_min``, ``h_max``,
    ``watch=[...]``, ``estimate``, ``tol``, ``max_iter``, ``relaxation``, ``jacobian``,
    ``extrapolation``, ``iqn_reuse``, ``iqn_filter``, ``iqn_relaxation``). The co-simulation
    schemes load the FMUs the scene's ``[system]`` names (relative to the scene file; for a
    dict, to the working folder).

    ``progress(t, t_end)``, if given, is called about ten times a second of wall time with the
    simulated time reached; an exception it raises stops the run and propagates, and so does
    Ctrl-C (``KeyboardInterrupt``).

    ``net=True`` (``monolithic`` and ``cable``) keeps the cable net at every sample:
    :meth:`Result.net`.
    """
    path, toml, label = _source(scene)
    options = {"scheme": scheme, "dt": dt, "t_end": t_end, **options}
    summary, csv, kept = _feedsim.run(path, toml, label, options, progress, bool(net))
    return Result(json.loads(summary), csv, kept)


def run_system(path, scheme: str = "ijcsa", *, dt: float | None = None, t_end: float | None = None, **options) -> Result:
    """A run of an SSP 1.0 system (an ``.ssp`` archive, or an ``.ssd`` with its FMUs beside it),
    as ``master run --system``: ``summary`` holds the keys of its ``--json``, ``frame`` the
    columns of its ``--out`` (``time``, with the adaptive step then ``h_s``, and every output as
    ``<component>.<variable>``). ``dt`` is the macro step (not with ``adaptive=True``); ``t_end``
    defaults to the system's DefaultExperiment stopTime. ``options``: the scheme options of
    :func:`run`, and ``allow_external_fmus``, ``max_archive_entries``, ``max_unpacked_mb``; for
    Model Exchange components ``interface`` (``"me"``, or ``"COMPONENT=me,..."``),
    ``me_solver`` (``"dopri5"`` or ``"esdirk3"``), ``me_rtol``, ``me_atol``."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path: give the path of an .ssp or .ssd file, not {type(path).__name__}")
    summary, csv = _feedsim.run_system(os.fspath(path), {"scheme": scheme, "dt": dt, "t_end": t_end, **options})
    return Result(json.loads(summary), csv)


def statics(scene) -> dict[str, Any]:
    """The form-finding statics of the scene's target pose: the dict of ``master statics --json``."""
    path, toml, label = _source(scene)
    return json.loads(_feedsim.statics(path, toml, label))


def modes(scene, count: int = 6) -> dict[str, Any]:
    """The lowest ``count`` natural modes (platform locked): the dict of
    ``master modes --count N --json`` (``frequencies_hz``, per mode its cabin share and shape,
    the damping fit)."""
    path, toml, label = _source(scene)
    return json.loads(_feedsim.modes(path, toml, label, int(count)))


def sweep(
    scene,
    grid: Mapping[str, Any],
    *,
    run: str | None = None,
    t_end: float = 2.0,
    modes: int = 3,
    jobs: int | None = None,
    surface: str | None = None,
    tilt_share: float | None = None,
    **options,
):
    """Statics, the first ``modes`` frequencies and, with ``run`` (a scheme), a short run of
    ``t_end`` s at every point of a grid, on ``jobs`` threads (default: every core), as
    ``master sweep``: a pandas DataFrame of the columns of its ``sweep.csv``, one row per point.

    ``grid``: axis name → values (a list, or ``"start:stop:count"``); names ``x``, ``y``, ``z``
    (m, the cabin centre's world position), ``mass`` (factor on the platform's masses and
    inertias), ``dt`` (s, the run's step). Points are all combinations, the first axis varying
    slowest. ``surface``, ``tilt_share`` and ``options``: as the command's flags.
    """
    import pandas as pd

    specs = []
    for name, values in grid.items():
        text = values if isinstance(values, str) else ",".join(repr(float(v)) for v in values)
        specs.append(f"{name}={text}")
    path, toml, label = _source(scene)
    flags = {"run": run, "t_end": t_end, "modes": modes, "jobs": jobs, "surface": surface, "tilt_share": tilt_share}
    columns, rows = _feedsim.sweep(path, toml, label, specs, {**flags, **options})
    frame = pd.DataFrame(rows, columns=columns)
    for name in columns:
        if name == "feasible":
            frame[name] = frame[name] == "true"
        elif name != "note":
            frame[name] = pd.to_numeric(frame[name].replace("", float("nan")))
    return frame
