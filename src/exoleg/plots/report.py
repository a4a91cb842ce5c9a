"""A session report a clinic can file (``exoleg report SESSION``): a PDF of a few pages
in a clinician's words and units, built with ReportLab from the session's figures
(:func:`exoleg.runtime.figures.session_figures`) -- the summary, the joint angles over
the gait cycle against the normative band, the Gait Profile Score, the assistance and the
cuffs' torque per kg against the safety layer's limit, and how the session ended.

The child is named by the pseudonymous id the console's records give (``C3f9a01bc``) --
their name only when asked (``name=True``).
"""

from __future__ import annotations

import datetime
import io
from pathlib import Path
from typing import Any

import numpy as np

from exoleg.io import read_record
from exoleg.params.records import JOINTS
from exoleg.reference import scores

NAMES = {"hip": "Hip flexion", "knee": "Knee flexion", "ankle": "Ankle dorsiflexion"}


def _cycle_figure(fig: dict[str, Any]) -> bytes:
    """The mean gait cycle against the normative mean +- 2 SD, as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    mean, sd = scores.normative_cycle(upright=True)  # the device's hip, zeroed standing
    cycle = np.array(fig["cycle_deg"])
    f, axes = plt.subplots(1, 3, figsize=(9.0, 2.9))
    for j, (ax, joint) in enumerate(zip(axes, JOINTS, strict=True)):
        ax.fill_between(scores.PERCENT, mean[:, j] - 2 * sd[:, j], mean[:, j] + 2 * sd[:, j],
                        color="0.85", label="typically developing, mean +- 2 SD")
        ax.plot(scores.PERCENT, mean[:, j], color="0.5", lw=1)
        ax.plot(scores.PERCENT, cycle[:, j], color="C0", lw=2, label="this session")
        ax.set_title(f"{NAMES[joint]} (GVS {fig['gvs_deg'][joint]:.1f} deg)", fontsize=9)
        ax.set_xlabel("% of the gait cycle", fontsize=8)
        ax.tick_params(labelsize=7)
    axes[0].set_ylabel("deg", fontsize=8)
    axes[0].legend(fontsize=6, loc="upper right")
    f.tight_layout()
    buf = io.BytesIO()
    f.savefig(buf, format="png", dpi=110)
    plt.close(f)
    return buf.getvalue()


def _who(folder: Path, fig: dict[str, Any], name: bool,
         history: dict[str, Any] | None) -> str:
    """The child as the report names them: the records' pseudonymous id, the name if
    asked."""
    child = read_record(folder / "child.json")
    if history and not child:
        child = {"child_id": history["child_id"], "name": history["name"]}
    cid = child.get("child_id")
    who = child.get("name") or fig.get("child")
    if cid:
        return f"{cid} ({who})" if name and who else str(cid)
    if name and who:
        return str(who)
    return "not recorded (a session run without the console's records)"


def write_report(folder: str | Path, path: str | Path, name: bool = False,
                 history: dict[str, Any] | None = None) -> Path:
    """Write the session report of ``folder`` to ``path`` (PDF, whole or not at all).

    Parameters
    ----------
    folder : str or Path
        The session's folder.
    path : str or Path
        The PDF to write.
    name : bool, default False
        Name the child (else only their pseudonymous id).
    history : dict, optional
        The child's sessions up to this one (:func:`exoleg.hmi.history.history_until`),
        shown as their trend; None: none shown.

    Returns
    -------
    Path
        The PDF written.
    """
    from reportlab.lib import colors
    from reportlab.lib.pagesizes import A4
    from reportlab.lib.styles import getSampleStyleSheet
    from reportlab.lib.units import cm
    from reportlab.platypus import (
        Image,
        PageBreak,
        Paragraph,
        SimpleDocTemplate,
        Spacer,
        Table,
        TableStyle,
    )

    from exoleg.io import atomic_path
    from exoleg.runtime.figures import session_figures

    root = Path(folder)
    fig = session_figures(root)
    st = getSampleStyleSheet()
    grid = TableStyle([("GRID", (0, 0), (-1, -1), 0.4, colors.grey),
                       ("BACKGROUND", (0, 0), (-1, 0), colors.whitesmoke),
                       ("FONTSIZE", (0, 0), (-1, -1), 9)])

    def table(rows: list[list[Any]], widths: list[float] | None = None) -> Table:
        t = Table([[Paragraph(str(c), st["BodyText"]) for c in r] for r in rows],
                  colWidths=widths)
        t.setStyle(grid)
        return t

    def num(x: Any, fmt: str = ".1f", unit: str = "") -> str:
        return "-" if x is None else f"{x:{fmt}}{unit}"

    when = (datetime.datetime.fromtimestamp(fig["started"]).strftime("%Y-%m-%d %H:%M")
            if fig["started"] else "-")
    stride = fig["stride_time_s"]
    story: list[Any] = [
        Paragraph("Exoskeleton session report", st["Title"]),
        Paragraph(f"Session {root.name}, {when}. Child: {_who(root, fig, name, history)}.",
                  st["Normal"]),
        Spacer(1, 0.3 * cm),
        Paragraph("Summary", st["Heading2"]),
        table([["", "this session"],
               ["Time with the device on (armed)", f"{fig['up_time_s'] / 60:.1f} min"],
               ["Walking time", f"{fig['walk_time_s'] / 60:.1f} min"],
               ["Steps (either foot)", f"{fig['steps']}"],
               ["Strides walked with the device's leg", f"{fig['strides']}"],
               ["Cadence", num(fig["cadence_steps_per_min"], ".0f", " steps/min")],
               ["Stride time", "-" if stride is None else
                f"{stride[0]:.2f} s (SD {stride[1]:.2f})"],
               ["Stance", num(fig["stance_percent"], ".0f", " % of the stride")],
               ["Gait Profile Score (hip, knee, ankle)", num(fig["gps_deg"], ".1f", " deg")]],
              [9 * cm, 6 * cm]),
        Spacer(1, 0.2 * cm),
        Paragraph("How the session ended: " + fig["stopped_in_words"], st["Normal"]),
        Paragraph(f"<font size=8>(the device's record: {fig['stopped_by'] or '-'})</font>",
                  st["Normal"]),
        Spacer(1, 0.2 * cm),
        Paragraph(f"<font size=8>The Gait Profile Score here is over the three joints the "
                  f"device measures (sagittal hip, knee and ankle), against typically "
                  f"developing children walking at their free speed (Schwartz et al. 2008); "
                  f"a change of {scores.GPS_MCID_DEG} deg is the smallest that matters "
                  f"clinically (Baker et al. 2012, for the nine-variable score). The hip "
                  f"angle is the device's, zeroed with the child standing: it is compared "
                  f"with the typical hip less the pelvis's mean forward tilt.</font>",
                  st["Normal"]),
        PageBreak(),
        Paragraph("Joint angles over the gait cycle", st["Heading2"])]
    if fig["cycle_deg"] is not None:
        story += [Image(io.BytesIO(_cycle_figure(fig)), width=17 * cm, height=5.5 * cm),
                  table([["", "range of motion", "typically developing", "within the band"],
                         *[[NAMES[j], f"{fig['rom_deg'][j]:.0f} deg",
                            f"{fig['normative_rom_deg'][j]:.0f} deg",
                            f"{fig['in_band_percent'][j]:.0f} % of the cycle"]
                           for j in JOINTS]])]
    else:
        story.append(Paragraph("No whole stride was walked: no gait cycle to show.",
                               st["Normal"]))
    story += [Paragraph("Assistance and the cuffs", st["Heading2"])]
    if fig["assistance"]:
        story.append(table([["support (1: full, 0: the child leads)", "loading", "mid-stance",
                             "push-off", "swing"],
                            *[[NAMES[j], *[num(v, ".2f") for v in fig["assistance"][j].values()]]
                              for j in JOINTS]]))
    if fig["cuffs"]:
        story += [Spacer(1, 0.2 * cm),
                  table([["the cuffs' torque on the child", "peak", "RMS while walking",
                          "limit"],
                         *[[NAMES[j], num(c["peak_Nm_per_kg"], ".2f", " N m/kg"),
                            num(c["rms_Nm_per_kg"], ".2f", " N m/kg"),
                            num(c["limit_Nm_per_kg"], ".1f", " N m/kg")]
                           for j, c in fig["cuffs"].items()]])]
    else:
        story.append(Paragraph("The cuffs' torque is not measured by this device.",
                               st["Normal"]))
    if history and history.get("sessions"):
        h = history
        story += [Paragraph("This child's sessions", st["Heading2"]),
                  table([["session", "walking", "steps", "cadence", "GPS"],
                         *[[datetime.datetime.fromtimestamp(s["started"]).strftime(
                             "%Y-%m-%d %H:%M"), num(s["walk_time_s"] and
                                                    s["walk_time_s"] / 60, ".1f", " min"),
                            num(s["steps"], "d"), num(s["cadence_steps_per_min"], ".0f"),
                            num(s["gps_deg"], ".1f", " deg")] for s in h["sessions"][-6:]]]),
                  Paragraph("<font size=8>" + (
                      f"Gait Profile Score {h['gps_change_deg']:+.1f} deg since the first "
                      f"session: {'beyond' if h['beyond_mcid'] else 'within'} the "
                      f"{scores.GPS_MCID_DEG} deg that matters clinically."
                      if h["gps_change_deg"] is not None else "One scored session so far.")
                      + "</font>", st["Normal"])]
    story += [Paragraph("What the safety layer did", st["Heading2"])]
    events = fig["safety_events"]
    story.append(table([["", "first at", "for"],
                        *[[e["text"], f"{e['first_s']:.1f} s",
                           f"{e['ticks'] * fig['period_s']:.1f} s"] for e in events]])
                 if events else
                 Paragraph("Nothing: every command was within the device's limits.",
                           st["Normal"]))
    with atomic_path(path) as tmp:
        SimpleDocTemplate(str(tmp), pagesize=A4, title=f"Session report {root.name}",
                          author="exoleg", leftMargin=2 * cm, rightMargin=2 * cm,
                          topMargin=1.8 * cm, bottomMargin=1.8 * cm).build(story)
    return Path(path)
