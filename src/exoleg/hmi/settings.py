"""A child's settings carried from one session to the next (issue 42): the walking
controller's support mode, its gains, assist-as-needed's bounds and the transparent
law's inertia share and acceleration estimate as the operator left them when the child's
last session ended.

They are read from the loop's shared block as the session ends (:func:`settings_at_end`)
and kept with that session in the records (``records.sqlite``). The child's next session
starts on the device's defaults and is then given them by the path an operator's change
takes (:func:`apply_settings`): the same bounds -- each gain 0 to twice the device's
default, the shares 0-1, the law's within its gears' bounds --, the supervisor's answer
for the mode, and a line in the session's ``control.log``. Settings kept before the
law's were tunable leave the device's own law. Settings that no longer fit the device's
bounds (a changed ``walking.toml``, another child's gears) are refused with the reason
and the session keeps the defaults.
"""

from __future__ import annotations

import time
from typing import Any

from exoleg.control.gears import LAW_TUNABLE
from exoleg.params.records import JOINTS
from exoleg.runtime.link import GAIN_NAMES, LoopLink
from exoleg.runtime.operator import OperatorRules
from exoleg.tick import SupportMode

#: the support modes in the operator's words
MODE_WORDS = {SupportMode.IMPEDANCE: "impedance (full support)",
              SupportMode.TRANSPARENT: "transparent (the child leads)",
              SupportMode.AAN: "assist as needed"}
#: the gains every kept settings hold: a session kept before the transparent law's share
#: and estimate were tunable has none of theirs (the device's own then stay)
KEPT_BEFORE_LAW = tuple(n for n in GAIN_NAMES if n not in LAW_TUNABLE)
#: how long the kept settings wait for the session's first published gains, s
WAIT_S = 10.0


def settings_at_end(link: LoopLink) -> dict[str, Any] | None:
    """The support mode (its command's name: ``impedance``, ``transparent``, ``aan``) and
    the gains (:data:`~exoleg.runtime.link.GAIN_NAMES`) a session ended with; None when
    it ran no walking controller (identification's plan publishes no gains)."""
    c = link.web_copy()
    gains = LoopLink.gains(c)
    if gains is None:
        return None
    return {"support_mode": SupportMode(int(c["support_mode"])).name.lower(),
            "gains": gains}


def settings_text(settings: dict[str, Any]) -> str:
    """The settings in an operator's words (one line)."""
    g = settings["gains"]

    def per_joint(name: str) -> str:
        return " / ".join(f"{x:.4g}" for x in g[name])

    mode = MODE_WORDS[SupportMode[settings["support_mode"].upper()]]
    return (f"{mode}, support {g['support'][0]:.2f}"
            + (f" (assist as needed between {per_joint('support_min')} and "
               f"{per_joint('support_max')} at {'/'.join(JOINTS)})"
               if settings["support_mode"] == "aan" else "")
            + f"; stance kp {per_joint('kp_stance')} N m/rad, kd "
            f"{per_joint('kd_stance')} N m s/rad; swing kp {per_joint('kp_swing')}, kd "
            f"{per_joint('kd_swing')}"
            + (f"; transparent law: inertia share {per_joint('inertia_share')}, its "
               f"acceleration estimate {per_joint('accel_filter_hz')} Hz" if set(LAW_TUNABLE)
               <= set(g) else "; transparent law: the device's own (not kept then)"))


def check_settings(settings: Any) -> str:
    """Why ``settings`` (as read back from the records) are not settings ('' if they
    are): a support mode by name and every gain by name with its values."""
    if not isinstance(settings, dict):
        return "not a table of settings"
    if settings.get("support_mode") not in {m.name.lower() for m in SupportMode}:
        return f"unknown support mode {settings.get('support_mode')!r}"
    g = settings.get("gains")
    if not isinstance(g, dict) or not set(KEPT_BEFORE_LAW) <= set(g) <= set(GAIN_NAMES):
        return f"gains: expected {', '.join(GAIN_NAMES)}"
    if not all(isinstance(v, list) and all(isinstance(x, (int, float)) for x in v)
               for v in g.values()):
        return "gains: expected lists of numbers"
    return ""


def kept_settings(registry: Any, child_id: str) -> tuple[dict[str, Any] | None, str]:
    """The settings child ``child_id``'s next session starts with, from the records
    (``registry``: a :class:`~exoleg.hmi.registry.Registry`, or None), and that said:
    None and why where it keeps the device's defaults."""
    settings = None if registry is None else registry.kept_settings(child_id)
    if settings is None:
        return None, "the device's default settings (no session of theirs yet)"
    why = check_settings(settings)
    if why:
        return None, f"the device's default settings (the kept ones are damaged: {why})"
    return settings, (f"the settings session {settings['session']} ended with: "
                      f"{settings_text(settings)}")


def apply_settings(api: OperatorRules, link: LoopLink, settings: dict[str, Any]) -> bool:
    """Give the session on ``link`` the ``settings`` kept from the child's last session
    (``settings["session"]``), as an operator's change is given: once the session has
    published its own gains (their bounds are set from those, the device's defaults),
    checked against the bounds, then the support mode through the supervisor. Said in the
    session's control.log either way; returns whether they were applied."""
    source = f"kept from session {settings.get('session', '?')}"
    why = check_settings(settings)
    deadline = time.monotonic() + WAIT_S
    while not why and not (api.gains()[0] and LoopLink.running(link.web_copy()) == "running"):
        if LoopLink.running(link.web_copy()) == "ended":
            why = "the session ended before it published its gains"
            break
        if time.monotonic() > deadline:
            why = (f"the session published no gains within {WAIT_S:g} s (not the walking "
                   "controller, or a slow start); the defaults stay")
            break
        time.sleep(0.005)
    if not why:
        why = api.check_gains(settings["gains"])
        why = why and f"outside the device's bounds now: {why}; the defaults stay"
    if not why:
        link.web_gains(settings["gains"])
        why, rid = api.send(settings["support_mode"])
        while not why and (done := api.outcome(rid)) is None and time.monotonic() < deadline:
            api.poll_applied()  # (the server's task does too: whichever comes first)
            time.sleep(0.002)
        if not why and done is not None and not done[0]:
            why = f"the gains were applied, the support mode refused: {done[1]}"
    api.record("session", "kept settings", not why,
               why=f"{source}: {why or settings_text(settings)}")
    return not why
