"""Type stubs of the compiled part of feedsim (python/src/lib.rs). Each function takes a scene as
a path or as TOML text with a label for errors, and the command line's flags as a list."""

class SceneError(ValueError):
    """A scene that cannot be read or is not valid: the file, the key, the value and why."""

class RunError(RuntimeError):
    """A run that cannot start, or stopped: the time and the cause."""

from typing import Any, Callable

def run(
    path: str | None,
    toml: str | None,
    label: str,
    argv: list[str],
    progress: Callable[[float, float], Any] | None = None,
    net: bool = False,
) -> tuple[str, str, tuple[list[float], bytes, int, int] | None]:
    """`master run`: (the --json summary, the --out CSV, with `net` the net at every sample: its
    times, every cable point as little-endian float64 x, y, z, the cables, the points per cable);
    `progress(t, t_end)` about every 0.1 s."""

def run_system(path: str, argv: list[str]) -> tuple[str, str]:
    """`master run --system`: (the --json summary, the --out CSV)."""

def statics(path: str | None, toml: str | None, label: str) -> str:
    """`master statics --json`."""

def modes(path: str | None, toml: str | None, label: str, count: int) -> str:
    """`master modes --count N --json`."""

def sweep(path: str | None, toml: str | None, label: str, argv: list[str]) -> tuple[list[str], list[list[str]]]:
    """`master sweep`: the columns of sweep.csv and its rows as text."""
