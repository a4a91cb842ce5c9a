"""Serving the operator interface: on loopback or TLS (:func:`bind_check`, :func:`listen`,
:func:`serve`), off the loop's CPU (:func:`keep_off_loop_cpu`), and as the child process
of ``exoleg run --hmi`` (:func:`start_process`)."""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
import signal
import socket
import threading
import time
from pathlib import Path
from typing import Any

from exoleg._parent import when_parent_ends
from exoleg.errors import ParameterError
from exoleg.hmi.routes import app
from exoleg.hmi.server import HMI
from exoleg.runtime.control_api import loopback
from exoleg.runtime.link import LoopLink


def keep_off_loop_cpu() -> set[int] | None:
    """Run the web side off the loop's CPU: off the isolated CPUs, where the loop pins
    itself if the kernel keeps any (:func:`~exoleg.runtime.realtime.realtime_settings`),
    else off the last CPU, left to the loop. Returns the CPUs it had (None if unknown)."""
    from exoleg.runtime.realtime import isolated_cpus

    try:
        before = os.sched_getaffinity(0)
    except (AttributeError, OSError):
        return None
    isolated = isolated_cpus()
    cpus = sorted(before - isolated)
    if not isolated:
        cpus = cpus[:-1]
    if cpus:
        with contextlib.suppress(OSError):
            os.sched_setaffinity(0, set(cpus))
    return before


def bind_check(host: str, certfile: str | None, keyfile: str | None) -> str:
    """'' on loopback or with TLS; else the warning to print. Refuses half a TLS pair."""
    if (certfile is None) != (keyfile is None):
        raise ParameterError("exoleg hmi", "--tls-cert/--tls-key", "give both or neither")
    for f in (certfile, keyfile):
        if f is not None and not Path(f).is_file():
            raise ParameterError("exoleg hmi", "--tls-cert/--tls-key", f"{f}: no such file")
    if certfile is not None:  # loaded now: a pair the server cannot use is said here,
        import ssl  # not as a server that never starts

        try:
            ssl.create_default_context(ssl.Purpose.CLIENT_AUTH).load_cert_chain(certfile,
                                                                                keyfile)
        except (ssl.SSLError, OSError) as e:
            raise ParameterError("exoleg hmi", "--tls-cert/--tls-key",
                                 f"{certfile} and {keyfile} cannot serve https: "
                                 f"{getattr(e, 'reason', None) or e.strerror or e} (a PEM "
                                 "certificate and its private key)") from None
    if loopback(host) or certfile:
        return ""
    return (f"warning: the operator interface listens on {host} without TLS: anyone on "
            "that network who sees the token in transit can control the device (give "
            "--tls-cert and --tls-key)")


def listen(host: str, port: int, what: str = "exoleg hmi") -> Any:
    """A listening socket on ``host``:``port``, or a ParameterError saying why not."""

    try:
        family, kind, proto, _, addr = socket.getaddrinfo(host, port,
                                                          type=socket.SOCK_STREAM)[0]
        sock = socket.socket(family, kind, proto)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(addr)
        sock.listen(64)
    except OSError as e:
        raise ParameterError(what, "--port", f"cannot listen on {host}:{port}: "
                             f"{e.strerror or e}") from None
    return sock


#: how long an idle connection is kept, s: longer than the clients keep theirs (httpx 5 s,
#: uvicorn's own default, the same: a request sent as the server closes is reset)
KEEP_ALIVE_S = 30


def serve(hmi: HMI, host: str = "127.0.0.1", port: int = 8780, certfile: str | None = None,
          keyfile: str | None = None, ready: Any = None, sock: Any = None) -> str:
    """Serve ``hmi`` in this process until SIGINT or SIGTERM (then a running session
    ends, torque off); returns the signal's name. ``sock``: already listening
    (:func:`listen`); ``ready``: a connection told 'ok' once listening, or why not."""

    import uvicorn

    class Server(uvicorn.Server):
        @contextlib.contextmanager
        def capture_signals(self) -> Any:  # the signals are ours (below), not re-raised
            yield

    hmi.cpus = keep_off_loop_cpu()
    hmi.host = host
    try:
        sock = sock if sock is not None else listen(host, port)
    except ParameterError as e:
        if ready is None:
            raise
        ready.send(str(e))
        return ""
    config = uvicorn.Config(app(hmi), log_level="warning", ssl_certfile=certfile,
                            ssl_keyfile=keyfile, lifespan="on",
                            timeout_keep_alive=KEEP_ALIVE_S)
    server = Server(config)
    got: list[str] = []

    def on_signal(signum: int, frame: object) -> None:
        got.append(signal.Signals(signum).name)
        server.force_exit = server.should_exit  # a second Ctrl-C: do not wait for clients
        server.should_exit = True

    old = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    if ready is not None:
        def tell() -> None:
            while not server.started and not server.should_exit:
                time.sleep(0.01)
            ready.send("ok" if server.started else "stopped before it listened")

        threading.Thread(target=tell, daemon=True).start()
    try:
        server.run(sockets=[sock])
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
        hmi.close()
    return got[0] if got else ""


def _serve_process(link: LoopLink, folder: str, token: str, host: str, port: int,
                   certfile: str | None, keyfile: str | None, backend: str,
                   leg_path: str | None, ready: Any,
                   plan: tuple[float | None, float | None] = (None, None)) -> None:
    import exoleg

    leg = exoleg.load_leg(leg_path) if leg_path else None
    hmi = HMI(Path(folder).parent, backend=backend, token=token, fixed=(link, Path(folder)),
              leg=leg, plan=plan)
    # it ends when its run does, however the run ended: no page goes on showing a
    # device that nothing drives, no port stays held
    when_parent_ends(lambda: os.kill(os.getpid(), signal.SIGTERM))
    serve(hmi, host, port, certfile, keyfile, ready)


def start_process(link: LoopLink, folder: Path, token: str, host: str, port: int,
                  certfile: str | None = None, keyfile: str | None = None,
                  backend: str = "sim", leg_path: str | None = None,
                  plan: tuple[float | None, float | None] = (None, None)) -> Any:
    """``exoleg run --hmi``: the server in a child process for the session run here
    (``plan``: its duration, s, and the child's body mass, kg); returns the process once
    it listens (raises with the reason if it cannot)."""
    ctx = mp.get_context("spawn")
    receiver, sender = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_serve_process, name="exoleg-hmi", daemon=True,
                       args=(link, str(folder), token, host, port, certfile, keyfile,
                             backend, leg_path, sender, plan))
    proc.start()
    said = receiver.recv() if receiver.poll(60) else "did not start within 60 s"
    if said != "ok":
        proc.terminate()
        raise ParameterError("exoleg run --hmi", "--hmi-port", said)
    return proc
