"""The gait animation: frame count and timing, and that blitted frames carry no trace
of earlier frames (each equals a frame drawn from scratch at the same posture)."""

import numpy as np
import pytest
from PIL import Image

import exoleg
from exoleg.plots import animate

LEG = exoleg.paper_leg()


def _frames(path):
    with Image.open(path) as im:
        out = []
        for k in range(im.n_frames):
            im.seek(k)
            out.append(np.asarray(im.convert("RGB")))
        return out, im.info.get("duration")


@pytest.fixture(scope="module")
def moving_then_still(tmp_path_factory):
    # 2 s at 1 ms: the leg swings during the first second, then holds the last posture
    t = np.arange(2001) * 1e-3
    s = np.clip(t, 0.0, 1.0)[:, None]
    q = s * np.radians([25.0, -60.0, 10.0])
    path = animate(LEG, t, q, tmp_path_factory.mktemp("anim") / "a.gif", fps=10)
    return t, q, path


def test_one_frame_per_tenth_of_a_second(moving_then_still):
    # Reference: fps = 10 over t = 0..2 s gives frames at 0, 0.1, ..., 2.0 s (21), each
    # shown 1000 / fps ms, at the figure's 4 x 5 in and 80 dpi.
    _, _, path = moving_then_still
    frames, duration = _frames(path)
    assert len(frames) == 21
    assert duration == 100
    assert frames[0].shape == (400, 320, 3)


def test_blitted_frames_leave_no_trail(moving_then_still, tmp_path):
    # Reference: the same posture and time drawn without any earlier frame (a leg held
    # still from the start); the moving leg's frames must not show where it has been.
    t, q, path = moving_then_still
    moved, _ = _frames(path)
    still, _ = _frames(animate(LEG, t, np.repeat(q[-1:], len(t), axis=0), tmp_path / "b.gif",
                               fps=10))
    assert not np.array_equal(moved[0], still[0])  # the leg did move
    assert np.array_equal(moved[-1], still[-1])
