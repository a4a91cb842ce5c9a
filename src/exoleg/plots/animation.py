"""A sagittal animation of the child's leg in the exoskeleton (paper Fig. 16 / Video S1).

The child's segments are drawn as thick strokes from hip to knee to ankle to toe;
the exoskeleton's telescopic links as a thinner parallel stroke offset behind
them, with the actuators as discs at the joints and the footplate under the
foot. GIF (Pillow) always; MP4 when ffmpeg is on the PATH.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg

from exoleg.dynamics.model import LegModel
from exoleg.plots.figures import new_figure

_EXO_OFFSET = 0.025  # m, drawing offset of the exoskeleton's links behind the leg


def animate(leg: LegModel, t: np.ndarray, q: np.ndarray, path: str | Path, fps: int = 25,
            q_ref: np.ndarray | None = None) -> Path:
    """Write an animation of a run.

    The suffix of ``path`` picks the format: ``.gif`` or ``.mp4`` (needs ffmpeg; without
    it a GIF is written next to it and its path returned).

    Parameters
    ----------
    leg : LegModel
        The leg drawn.
    t : ndarray
        Times, s, (N,).
    q : ndarray
        Joint angles, rad, (N, 3).
    path : str or Path
        The file to write.
    fps : int, default 25
        Frames per second.
    q_ref : ndarray, optional
        The reference, drawn behind, (N, 3).

    Returns
    -------
    Path
        The file written.
    """
    p = Path(path)
    if p.suffix == ".mp4" and shutil.which("ffmpeg") is None:
        p = p.with_suffix(".gif")
    dt = float(t[1] - t[0]) if len(t) > 1 else 1.0 / fps
    step = max(1, round(1.0 / (fps * dt)))  # one frame every 1/fps s
    frames = np.arange(0, len(t), step)
    fk = leg.fk(q[frames])
    ref = leg.fk(q_ref[frames]) if q_ref is not None else None
    reach = float(np.sum(leg.lengths))
    fig = new_figure(4, 5, left=0.2, right=0.97, top=0.97, bottom=0.1)
    fig.set_dpi(80)
    canvas = FigureCanvasAgg(fig)
    ax = fig.subplots()
    ax.set_xlim(-0.7 * reach, 0.7 * reach)
    ax.set_ylim(-1.15 * reach, 0.25 * reach)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    (ghost,) = ax.plot([], [], "--", color="0.7", lw=1, label="reference")
    (exo,) = ax.plot([], [], "-", color="tab:gray", lw=3, alpha=0.8, label="exoskeleton")
    (child,) = ax.plot([], [], "-", color="tab:orange", lw=7, solid_capstyle="round",
                       label="child's leg")
    (joints,) = ax.plot([], [], "o", color="k", ms=9, mfc="tab:blue")
    text = ax.text(0.02, 0.97, "", transform=ax.transAxes, va="top")
    ax.legend(loc="lower left", fontsize=7)

    def chain(points: dict[str, np.ndarray], k: int) -> np.ndarray:
        return np.array([points[n][k] for n in ("hip", "knee", "ankle", "toe")])

    def draw(k: int):  # type: ignore[no-untyped-def]
        c = chain(fk, k)
        child.set_data(c[:, 0], c[:, 1])
        exo.set_data(c[:, 0] - _EXO_OFFSET, c[:, 1])
        joints.set_data(c[:3, 0], c[:3, 1])
        if ref is not None:
            r = chain(ref, k)
            ghost.set_data(r[:, 0], r[:, 1])
        text.set_text(f"t = {t[frames[k]]:.2f} s")
        return ghost, exo, child, joints, text  # in drawing order

    if p.suffix == ".mp4":
        from matplotlib.animation import FFMpegWriter, FuncAnimation

        FuncAnimation(fig, draw, frames=len(frames), blit=True).save(
            str(p), writer=FFMpegWriter(fps=fps))
    else:  # GIF: blit, i.e. render the axes, ticks and legend once and per frame only
        # the moving artists over them
        from PIL import Image

        moving = draw(0)
        for a in moving:
            a.set_animated(True)  # left out of the full draw
        canvas.draw()
        background = canvas.copy_from_bbox(fig.bbox)
        images: list[Image.Image] = []
        for k in range(len(frames)):
            draw(k)
            canvas.restore_region(background)
            for a in moving:
                ax.draw_artist(a)
            frame = Image.fromarray(np.asarray(canvas.buffer_rgba())[..., :3].copy())
            # (a palette per frame: mapping onto the first frame's, PIL merges near-whites)
            images.append(frame.quantize(colors=64, method=Image.Quantize.FASTOCTREE))
        images[0].save(p, save_all=True, append_images=images[1:], duration=round(1000 / fps),
                       loop=0)
    return p
