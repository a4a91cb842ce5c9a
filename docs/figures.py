"""The documentation's drawn figures, made from the code they describe:

* ``docs/img/architecture.png``: the floors of ``tests/test_floors.py`` (the declaration
  the suite enforces) as rows, bottom to top, each package a box, and every import
  between packages the source makes today (the same AST walk as the floors' test) as a
  line -- so the picture cannot drift from the code;
* ``docs/img/device.png``: the device's block diagram -- the operator, the 1 kHz loop and
  its controller (supervisor, gait phases, support, safety layer), the drives on their
  bus, the actuation units and the foot board -- with the figures of the shipped device
  files (motors, gears, encoders, the loop's rate) read from them.

Run: ``.venv/bin/python docs/figures.py`` (the suite runs it into a temporary folder:
``tests/test_docs_site.py``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def _floors() -> tuple[tuple[tuple[str, tuple[str, ...]], ...], dict[str, set[str]]]:
    """The declared floors and the package -> packages it imports, from the suite's own
    floor test (its declaration and its import walk)."""
    sys.path.insert(0, str(ROOT / "tests"))
    import test_floors as tf

    mods = tf._modules()
    edges: dict[str, set[str]] = {}
    for m, targets in tf._imports(mods).items():
        a = m.split(".")[1] if m.count(".") else m
        for t in targets:
            b = t.split(".")[1] if t.count(".") else t
            if a != b and a in tf.LEVEL and b in tf.LEVEL:
                edges.setdefault(a, set()).add(b)
    return tf.FLOORS, edges


def architecture(path: Path) -> Path:
    floors, edges = _floors()
    fig, ax = plt.subplots(figsize=(11, 8))
    where: dict[str, tuple[float, float]] = {}
    for level, (name, pkgs) in enumerate(floors):
        y = level * 1.0
        ax.text(-0.2, y, name, ha="right", va="center", fontsize=10, color="#555")
        shown = [p for p in pkgs if not p.startswith("_")]
        for i, p in enumerate(shown):
            x = i * 1.45
            where[p] = (x + 0.6, y)
            ax.add_patch(FancyBboxPatch((x, y - 0.3), 1.2, 0.6,
                                        boxstyle="round,pad=0.02", fc="#e8eef7", ec="#36c"))
            ax.text(x + 0.6, y, p, ha="center", va="center", fontsize=9)
    for a, targets in edges.items():
        for b in targets:
            if a in where and b in where:
                (x0, y0), (x1, y1) = where[a], where[b]
                ax.add_patch(FancyArrowPatch((x0, y0 - 0.3), (x1, y1 + 0.3),
                                             arrowstyle="-|>", mutation_scale=6, lw=0.4,
                                             color="#89a", alpha=0.3,
                                             connectionstyle="arc3,rad=0.08"))
    ax.set_xlim(-2.2, 8.8)
    ax.set_ylim(-0.7, len(floors) - 0.3)
    ax.axis("off")
    ax.set_title("exoleg's floors (tests/test_floors.py): a package imports only from its "
                 "own floor and below;\nlines: the imports between packages the source "
                 "makes today", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def device(path: Path) -> Path:
    from exoleg.device.actuator import paper_actuators
    from exoleg.device.sensors import FootSensors
    from exoleg.tick import SENSOR_POINTS

    acts = paper_actuators()
    foot = FootSensors.default()
    units = "\n".join(f"{a.joint}: {a.motor.split(',')[0]}, 1:{a.ratio:g}" for a in acts)
    boxes = {
        "operator": ((0.0, 4.2), "operator console\n(exoleg hmi: E-stop, arm,\nwalk, stand, "
                                  "support)"),
        "loop": ((0.0, 2.4), "1 kHz loop (exoleg run)\nread -> update -> write,\n"
                             "session log"),
        "control": ((3.6, 2.4), "controller\nsupervisor -> gait phases ->\nimpedance / "
                                "transparent / AAN\n-> safety layer"),
        "drives": ((7.2, 2.4), f"3 x {acts[0].drive}\nCiA 402 torque mode\n"
                               "CANopen or EtherCAT"),
        "units": ((7.2, 0.4), f"actuation units\n{units}"),
        "leg": ((3.6, 0.4), "the child's leg\nin the device (cuffs)"),
        "sensors": ((0.0, 0.4), f"{acts[0].encoder_bits}-bit encoders;\nfoot board: "
                                f"{len(SENSOR_POINTS)} FSRs ({foot.adc_bits}-bit)\n"
                                "+ IMU (CAN)"),
    }
    fig, ax = plt.subplots(figsize=(11, 6))
    for (x, y), text in boxes.values():
        ax.add_patch(FancyBboxPatch((x, y), 3.0, 1.3, boxstyle="round,pad=0.05",
                                    fc="#eef5ea", ec="#3a7"))
        ax.text(x + 1.5, y + 0.65, text, ha="center", va="center", fontsize=8.5)

    def arrow(a: str, b: str, label: str) -> None:
        (xa, ya), (xb, yb) = boxes[a][0], boxes[b][0]
        start = (xa + 1.5 + (1.5 if xb > xa else -1.5 if xb < xa else 0),
                 ya + 0.65 + (0.65 if yb > ya else -0.65 if yb < ya else 0))
        end = (xb + 1.5 + (-1.5 if xb > xa else 1.5 if xb < xa else 0),
               yb + 0.65 + (-0.65 if yb > ya else 0.65 if yb < ya else 0))
        ax.add_patch(FancyArrowPatch(start, end, arrowstyle="-|>", mutation_scale=12,
                                     color="#333"))
        ax.text((start[0] + end[0]) / 2, (start[1] + end[1]) / 2 + 0.12, label,
                ha="center", fontsize=7.5, color="#333")

    arrow("operator", "loop", "commands, heartbeat")
    arrow("loop", "control", "readings")
    arrow("control", "drives", "torque, enable")
    arrow("drives", "units", "current")
    arrow("units", "leg", "joint torque")
    arrow("leg", "sensors", "angles, foot load")
    arrow("sensors", "loop", "q, dq, FSRs, gyro")
    ax.set_xlim(-0.3, 10.5)
    ax.set_ylim(0.0, 5.8)
    ax.axis("off")
    ax.set_title("The device as exoleg drives it (the shipped device files' parts)",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(folder: Path) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    return [architecture(folder / "architecture.png"), device(folder / "device.png")]


if __name__ == "__main__":
    for p in main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "img"):
        print("wrote", p)
