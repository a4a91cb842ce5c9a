"""What every command of the command line shares: the one-line-error parser, printing
(rich, imported only when something is printed), the option types that check what a
person typed, the progress bar, reading a leg file."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

from exoleg.entry import BODY_MASS

if TYPE_CHECKING:
    from rich.console import Console


#: Stride times a child can walk (as exoleg.reference.gait.STRIDE_TIME_RANGE, kept here
#: so that the parser does not import numpy); gait SD offsets: mean +- 3 SD.
STRIDE_TIME_RANGE = (0.4, 4.0)


SD_RANGE = (-3.0, 3.0)


class _Parser(argparse.ArgumentParser):
    """argparse, but an error is one line (``exoleg: error: ...``) and exit status 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"exoleg: error: {message}\n")


def _console() -> Console:
    from rich.console import Console

    # on a terminal rich fits its width; piped or redirected, wide lines are kept whole
    return Console(highlight=False, width=None if sys.stdout.isatty() else 200)


def _table(rows: list[list[str]], header: list[str], title: str | None = None) -> None:
    """Print a table (rich; plain columns when not on a terminal) under its ``title``, a
    line of its own: a table's title is cut to the table's width (80 columns when the
    output is not a terminal), and what it says is not to be lost."""
    from rich import box
    from rich.table import Table

    if title:
        _say(title)
    t = Table(*header, box=box.SIMPLE_HEAD, header_style="bold", pad_edge=False)
    for r in rows:
        t.add_row(*r)
    _console().print(t)


def _say(text: str = "", flush: bool = False) -> None:
    print(text, flush=flush)


def _url(host: str, port: int, tls: object) -> str:
    return f"{'https' if tls else 'http'}://{f'[{host}]' if ':' in host else host}:{port}"


# --------------------------------------------------------------------------- option types
def _floats(text: str, n: int | None = None) -> list[float]:
    try:
        vals = [float(v) for v in text.replace(" ", "").split(",") if v != ""]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated numbers, got {text!r}") from None
    if not vals:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}")
    if n is not None and len(vals) != n:
        raise argparse.ArgumentTypeError(f"expected {n} comma-separated numbers, got {text!r}")
    if not all(math.isfinite(v) for v in vals):
        raise argparse.ArgumentTypeError(f"numbers must be finite, got {text!r}")
    return vals


def _three(text: str) -> list[float]:
    return _floats(text, 3)


def _postures(text: str) -> list[list[float]]:
    out = [_floats(p, 3) for p in text.split(";") if p.strip()]
    if not out:
        raise argparse.ArgumentTypeError(f"expected postures 'h,k,a;h,k,a', got {text!r}")
    return out


def _number(text: str) -> float:
    return _floats(text, 1)[0]


def _positive(text: str) -> float:
    v = _number(text)
    if v <= 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text!r}")
    return v


def _within(lo: float, hi: float, unit: str = "") -> Callable[[str], float]:
    def parse(text: str) -> float:
        v = _number(text)
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"{text} is outside {lo:g}-{hi:g}{unit}")
        return v
    parse.__name__ = "number"
    return parse


_body_mass = _within(BODY_MASS[0], BODY_MASS[1], " " + BODY_MASS[2])


def _count(lo: int, hi: int) -> Callable[[str], int]:
    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"{v} is outside {lo}-{hi}")
        return v
    parse.__name__ = "count"
    return parse


def _percentile(text: str) -> float:
    v = _number(text)
    if not 0.0 < v < 100.0:
        raise argparse.ArgumentTypeError(
            f"a percentile is between 0 and 100 (exclusive), got {text!r}")
    return v


def _once(vals: list[float], what: str) -> list[float]:
    """A list of a population's values, each once (a value twice counts its children
    twice in every share)."""
    from exoleg.checks import repeated

    twice = repeated(vals)
    if twice is not None:
        raise argparse.ArgumentTypeError(f"{twice:g} is given twice (each {what} once)")
    return vals


def _percentiles(text: str) -> list[float]:
    vals = _floats(text)
    bad = [v for v in vals if not 0.0 < v < 100.0]
    if bad:
        raise argparse.ArgumentTypeError(
            f"percentiles are between 0 and 100 (exclusive), got {bad[0]:g}")
    return _once(vals, "percentile")


def _ages(text: str) -> list[float]:
    vals = _floats(text)
    bad = [v for v in vals if not 2.0 <= v <= 20.0]
    if bad:
        raise argparse.ArgumentTypeError(f"ages are 2-20 years (the growth charts), got {bad[0]:g}")
    return _once(vals, "age")


class _Progress:
    """A rich progress bar on stderr, only when stderr is a terminal."""

    def __init__(self) -> None:
        self.bar: Any = None
        self.tasks: dict[str, Any] = {}
        if sys.stderr.isatty():
            from rich.console import Console
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

            self.bar = Progress(TextColumn("{task.description:<10}"), BarColumn(),
                                TextColumn("{task.percentage:>5.1f}%"), TimeElapsedColumn(),
                                console=Console(stderr=True), transient=True)
            self.bar.start()

    def __call__(self, stage: str, fraction: float) -> None:
        if self.bar is None:
            return
        if stage not in self.tasks:
            self.tasks[stage] = self.bar.add_task(stage, total=1.0)
        self.bar.update(self.tasks[stage], completed=fraction)

    def stop(self) -> None:
        if self.bar is not None:
            self.bar.stop()


def _device_option(p: argparse.ArgumentParser, uses: str) -> None:
    """``--device DIR``: a folder of device files replacing the shipped ones, for what the
    command ``uses`` of them (checked when the command reads it)."""
    p.add_argument("--device", type=Path, metavar="DIR",
                   help="a folder of device files (actuators/{hip,knee,ankle}.toml, "
                        "safety.toml, sensors.toml, gait_phase.toml, walking_control.toml, "
                        f"walking.toml, ...) replacing the shipped ones: {uses}")


def _mass_of(child: Any, given: float | None, where: str) -> float:
    """The body mass a child file gives, refusing a ``--body-mass`` that says otherwise
    (a mass given beside a child was silently replaced by theirs)."""
    if given is not None and abs(given - child.mass) > 1e-9:
        from exoleg.errors import ParameterError

        raise ParameterError(where, "--body-mass", f"{given:g} kg, but the child file says "
                             f"{child.mass:g} kg: give one of the two")
    return float(child.mass)


def _child_on_leg(child: Any, leg_path: Path | None, where: str) -> None:
    """Refuse a child file beside a leg fitted for another child: the leg's ``[fit]``
    record (``exoleg fit`` writes the child's height and mass into it) against the child
    file's, within 1 mm and 1 g (both come from the same fit). A leg without them (the
    paper's, an older fit) is not compared."""
    if leg_path is None:
        return
    from exoleg.errors import ParameterError
    from exoleg.params.leg_file import read_leg_file

    meta = read_leg_file(leg_path)[3]
    if "height_m" not in meta or "mass_kg" not in meta:
        return
    if abs(meta["height_m"] - child.height) > 1e-3 or abs(meta["mass_kg"] - child.mass) > 1e-3:
        raise ParameterError(where, "--child", f"the child file is for a {child.height:.2f} m, "
                             f"{child.mass:g} kg child; {leg_path} was fitted for "
                             f"{meta['height_m']:.2f} m, {meta['mass_kg']:g} kg: give the leg "
                             "fitted for this child (exoleg fit writes both)")


def _read_leg(path: Path, refuse_unfit: str = "") -> tuple[Any, str]:
    """A leg file as a :class:`~exoleg.LegModel`, and a warning ('' if none) when it is a
    leg for a child the device does not fit (its ``[fit]`` record) -- refused instead
    (ParameterError) by the command ``refuse_unfit`` names: a device session or an
    export, where the device would be set to a child it does not fit."""
    import exoleg
    from exoleg.errors import ParameterError
    from exoleg.params.leg_file import read_leg_file

    links, g, name, meta = read_leg_file(path)
    leg = exoleg.LegModel(links, g=g, name=name, armature=meta.get("armature"))
    if meta.get("fits", True):
        return leg, ""
    why = (f"{path} is a leg for a child the device does not fit "
           f"({meta.get('note') or 'see its [fit] record'})")
    if refuse_unfit:
        raise ParameterError(refuse_unfit, "--leg", f"{why}: refused (exoleg simulate may "
                             "study it)")
    return leg, f"{why}: the model's telescope settings are clamped to the device's range"


#: the operator interface's address and port when none is given
WEB_HOST, WEB_PORT = "127.0.0.1", 8780


def _web_options(p: argparse.ArgumentParser, host: str, port: str, given: bool = False
                 ) -> None:
    """The web server's options; ``given``: defaults None (:data:`WEB_HOST`,
    :data:`WEB_PORT` filled in later), to tell an option given from one left out."""
    p.add_argument(host, default=None if given else WEB_HOST, help="address to listen on "
                   f"(default {WEB_HOST}: this machine only; another address needs TLS or "
                   "prints a warning)")
    p.add_argument(port, type=_count(1024, 65535), default=None if given else WEB_PORT,
                   help=f"default {WEB_PORT}")
    p.add_argument("--tls-cert", help="TLS certificate (PEM) to serve https")
    p.add_argument("--tls-key", help="the certificate's private key (PEM)")


def _bus_options(command: str, backend: str, **given: Any) -> None:
    """Refuses an option of the bus backends (``given``: name -> value, None when not
    given) on the ``sim`` backend."""
    from exoleg.errors import ParameterError

    for name, value in given.items():
        if backend == "sim" and value is not None:
            raise ParameterError(command, f"--{name.replace('_', '-')}",
                                 "goes with --backend canopen or ethercat")


def _negative_values(argv: Sequence[str]) -> list[str]:
    """``--q0 -10,-40,5`` as ``--q0=-10,-40,5``: argparse takes a value that starts with
    '-' for an option unless it is a single plain number, and exoleg's angles are often
    negative (knee flexion)."""
    out: list[str] = []
    for a in argv:
        if (out and out[-1].startswith("--") and "=" not in out[-1] and len(a) > 1
                and a[0] == "-" and (a[1].isdigit() or a[1] == ".")):
            out[-1] = f"{out[-1]}={a}"
        else:
            out.append(a)
    return out
