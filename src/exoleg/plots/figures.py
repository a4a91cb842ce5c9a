"""The paper's Figs 13-15 drawn from a :class:`~exoleg.sim.scenario.ScenarioReport`.

Fig. 13: A-C joint angles (reference, exoleg, engine), D |detailed - simplified|,
E |exoleg - engine|, F |reference - exoleg|, all in degrees, errors on log axes.
Error panels show the largest |error| per time bin (an envelope). Fig. 14: the
verification signal dq^T (Mdot - 2C) dq. Fig. 15: control torques.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from exoleg.params.records import JOINTS  # noqa: E402
from exoleg.sim.scenario import ScenarioReport  # noqa: E402

_BINS = 600  # points drawn per curve


def _envelope(t: np.ndarray, err: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Largest |err| in each of about _BINS time bins (exact zeros, which a log axis
    cannot show, become gaps)."""
    n = max(1, len(t) // _BINS)
    m = len(t) // n * n
    tb = t[:m].reshape(-1, n).mean(axis=1)
    eb = np.abs(err[:m]).reshape(-1, n, err.shape[1]).max(axis=1)
    return tb, np.where(eb > 0, eb, np.nan)


def _thin(t: np.ndarray, *ys: np.ndarray) -> tuple[np.ndarray, ...]:
    """Every k-th sample so a curve has at most about 3 * _BINS points (smooth curves)."""
    k = max(1, len(t) // (3 * _BINS))
    return (t[::k], *(y[::k] for y in ys))


def _log_error(ax: plt.Axes, t: np.ndarray, err: np.ndarray, title: str) -> None:
    tb, eb = _envelope(t, err)
    for i, j in enumerate(JOINTS):
        ax.semilogy(tb, eb[:, i], lw=0.8, label=j)
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("error (deg)")
    ax.legend(fontsize=7)


def fig13(report: ScenarioReport) -> Figure:
    """Paper Fig. 13 A-F."""
    r = report.result
    fig, axes = plt.subplots(2, 3, figsize=(13, 7))
    fig.subplots_adjust(left=0.06, right=0.98, top=0.95, bottom=0.08, wspace=0.28, hspace=0.35)
    eq = report.engine_q if report.engine_q is not None else r.q
    t, qr, q, qe = _thin(r.t, np.degrees(r.q_ref), np.degrees(r.q), np.degrees(eq))
    for i, j in enumerate(JOINTS):
        ax = axes[0, i]
        ax.plot(t, qr[:, i], "k--", lw=1, label="reference")
        ax.plot(t, q[:, i], lw=1.2, label="exoleg")
        if report.engine_q is not None:
            ax.plot(t, qe[:, i], ":", lw=1.5, label=report.engine_name)
        ax.set_title(f"({'ABC'[i]}) {j} position", fontsize=9)
        ax.set_xlabel("time (s)")
        ax.set_ylabel("angle (deg)")
        ax.legend(fontsize=7)
    if report.detailed is not None:
        _log_error(axes[1, 0], r.t, np.degrees(report.detailed.q - r.q),
                   "(D) detailed (2x torque) - simplified")
    else:
        axes[1, 0].set_axis_off()
    if report.engine_q is not None:
        _log_error(axes[1, 1], r.t, np.degrees(report.engine_q - r.q),
                   f"(E) {report.engine_name} - exoleg")
    else:
        axes[1, 1].set_axis_off()
    _log_error(axes[1, 2], r.t, np.degrees(r.error), "(F) reference - exoleg")
    return fig


def fig14(report: ScenarioReport) -> Figure:
    """Paper Fig. 14: the verification signal."""
    r = report.result
    fig, ax = plt.subplots(figsize=(7, 3.5))
    fig.subplots_adjust(left=0.14, right=0.97, top=0.9, bottom=0.14)
    tb, vb = _envelope(r.t, r.verification[:, None])
    ax.plot(tb, vb[:, 0], lw=0.8, label="max |signal| per bin")
    ax.legend(fontsize=7)
    ax.set_title("verification signal  dq^T (Mdot - 2C) dq", fontsize=9)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("W")
    return fig


def fig15(report: ScenarioReport) -> Figure:
    """Paper Fig. 15: control torques (non-zero at rest: G(q))."""
    r = report.result
    fig, ax = plt.subplots(figsize=(7, 3.5))
    fig.subplots_adjust(left=0.12, right=0.97, top=0.9, bottom=0.14)
    t, u = _thin(r.t, r.u)
    for i, j in enumerate(JOINTS):
        ax.plot(t, u[:, i], lw=1, label=j)
    ax.set_title("control torques", fontsize=9)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("torque (N m)")
    ax.legend(fontsize=7)
    return fig


def save_figures(report: ScenarioReport, folder: str | Path,
                 formats: tuple[str, ...] = ("png",)) -> list[Path]:
    """Write Figs 13, 14 and 15 in each format; returns the paths."""
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, make in (("fig13", fig13), ("fig14", fig14), ("fig15", fig15)):
        fig = make(report)
        for fmt in formats:
            p = out / f"{name}.{fmt}"
            fig.savefig(p, dpi=120)
            paths.append(p)
        plt.close(fig)
    return paths
