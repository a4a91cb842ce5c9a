"""The ``exoleg`` command line: a thin layer over the library.

Exit status: 0 done; 1 a validation that failed or a run that could not finish (the
message says why); 2 a bad option or input (one line naming it and what is allowed);
130 interrupted (Ctrl-C). Never a traceback: an unexpected error is one line too, with
``EXOLEG_DEBUG=1`` to see the traceback. Outputs are written whole or not at all
(:class:`exoleg.io.OutputFolder`): an error or Ctrl-C leaves the previous output.

Tables and progress bars use rich, imported only when something is printed.
"""

from __future__ import annotations

import _thread
import argparse
import gc
import os
import sys
import threading
from collections.abc import Sequence
from typing import Any

from exoleg.cli import (
    assess,
    child,
    design,
    detect,
    export,
    fit,
    hmi,
    identify,
    log,
    population,
    report,
    run,
    simulate,
    sweep,
    validate,
)
from exoleg.cli._common import _negative_values, _Parser

#: the commands, one module each, in the order of the help
COMMANDS = (validate, simulate, fit, assess, population, design, sweep, run, hmi, log,
            report, child, detect, identify, export)


def build_parser() -> argparse.ArgumentParser:
    ap = _Parser(prog="exoleg", description="Pediatric single-leg exoskeleton: model, control, "
                 "simulation (Sarajchi & Sirlantzis, Sensors 2023).")
    sub = ap.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for command in COMMANDS:
        command.add_parser(sub)
    return ap


def _terminated(signum: int, frame: object) -> None:
    """SIGTERM: what was staged goes and the process ends at once (exit 130, as Ctrl-C
    ends a command) -- without raising through code a signal may land in anywhere (a
    compiler's callback swallows an exception and leaves its state broken). A worker
    ends with its parent; a session's loop has its own handler (a controlled stop)."""
    from exoleg.io import remove_staging

    remove_staging()
    os.write(2, b"exoleg: interrupted (SIGTERM): what was staged is removed; earlier "
                b"outputs are unchanged\n")
    os._exit(130)


class _InterruptsKept:
    """``sys.unraisablehook`` while a command runs. A Ctrl-C whose KeyboardInterrupt lands
    in Python code that C code called -- numba's compiler storing or loading its cache
    through ctypes' callbacks -- is swallowed there ("Exception ignored on calling ctypes
    callback function") and the command went on: a ``simulate`` interrupted 3 s into its
    start on a busy machine ran to its end and exited 0 (the suite with two CPU-bound
    processes beside it); an ``exoleg run`` so would have armed the device. The interrupt
    is given again to the main thread from a thread of its own, as a signal is, once the
    main thread has left this hook (:func:`_give_again`): the handler then in force takes
    it -- KeyboardInterrupt, or a session loop's controlled stop; landed in another
    callback, it comes here again. Anything else goes on to the hook before."""

    def __init__(self, previous: Any) -> None:
        self.previous = previous
        self.done = threading.Event()  # the command has ended: nothing more is given

    def __call__(self, unraisable: Any) -> None:
        if not isinstance(unraisable.exc_value, KeyboardInterrupt):
            self.previous(unraisable)
            return
        threading.Thread(target=_give_again, args=(self.done,), daemon=True).start()


def _give_again(done: threading.Event, poll: float = 0.001) -> None:
    """Interrupt the main thread once none of its frames is :class:`_InterruptsKept`'s
    hook, unless ``done`` is set first. Given while the main thread is still in the hook
    (starting this thread: a busy machine may leave it there for milliseconds), the
    interrupt landed in the hook, whose own exception is ignored too, and was lost: a
    ``simulate`` interrupted in a fresh clone's CI ran to its end and exited 0."""
    main, hook = threading.main_thread().ident or 0, _InterruptsKept.__call__.__code__
    while not done.is_set():
        f = sys._current_frames().get(main)
        while f is not None and f.f_code is not hook:
            f = f.f_back
        if f is None:
            _thread.interrupt_main()
            return
        done.wait(poll)


def main(argv: Sequence[str] | None = None) -> int:
    if threading.current_thread() is not threading.main_thread():
        return _main(argv)  # signals come to the main thread alone
    import signal

    signal.signal(signal.SIGTERM, _terminated)
    kept = _InterruptsKept(sys.unraisablehook)
    sys.unraisablehook = kept
    try:
        return _main(argv)
    finally:  # a call from Python (a test, a notebook) gets its own hook back
        sys.unraisablehook = kept.previous
        kept.done.set()


def _main(argv: Sequence[str] | None) -> int:
    try:  # a signal while the parser is built: the same one line as later
        ap = build_parser()
        args = ap.parse_args(_negative_values(sys.argv[1:] if argv is None else argv))
        from exoleg.errors import ExolegError
    except KeyboardInterrupt:
        print("exoleg: interrupted; nothing was written", file=sys.stderr)
        return 130

    try:
        return int(args.func(args))
    except ExolegError as e:
        kind = "error" if isinstance(e, ValueError) else "failed"
        print(f"exoleg: {kind}: {e}", file=sys.stderr)
        return 2 if isinstance(e, ValueError) else 1
    except KeyboardInterrupt:
        print("exoleg: interrupted; nothing was written (any previous output is unchanged)",
              file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader (e.g. `| head`) stopped reading: not an error of ours
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except ImportError as e:
        print(f"exoleg: error: {e}", file=sys.stderr)
        return 2
    except MemoryError:
        print("exoleg: failed: out of memory (shorten --duration or raise --dt)", file=sys.stderr)
        return 1
    except OSError as e:
        where = f" ({e.filename})" if getattr(e, "filename", None) else ""
        print(f"exoleg: failed: {e.strerror or e}{where}", file=sys.stderr)
        return 1
    except Exception as e:  # a bug: one line, the traceback on request
        if os.environ.get("EXOLEG_DEBUG"):
            raise
        print(f"exoleg: internal error: {type(e).__name__}: {e} (EXOLEG_DEBUG=1 shows the "
              "traceback; please report it)", file=sys.stderr)
        return 1


def console() -> int:
    """The ``exoleg`` console command: :func:`main`, then a quick exit. Freezing the
    heap first spares the interpreter's final collection (a few hundred ms with numba,
    MuJoCo and matplotlib loaded); exit handlers still run. A Ctrl-C that comes as the
    command has ended (one given again by :class:`_InterruptsKept` a moment late, or a
    new one) ends it with 130 and one line, not a traceback."""
    try:
        code = main()
        gc.freeze()
        try:
            sys.stdout.flush()
        except BrokenPipeError:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except KeyboardInterrupt:
        print("exoleg: interrupted as it ended; what it wrote is whole", file=sys.stderr)
        return 130
    return code

