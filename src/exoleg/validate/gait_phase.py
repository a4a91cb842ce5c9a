"""The gait-phase detector against the simulator's true contact events, over children,
sensor noise levels and strides (``exoleg validate --gait-phase``).

Children: the device's design range (paper section 2: 8-12 years, GMFCS I-IV) at the
50th percentile of their growth charts, plus a typically developing child, each with the
personalized child + device model (:func:`exoleg.sizing.personalized_leg`) walking on the
treadmill (:func:`exoleg.sim.walk.simulate_walk`) as an actor (:mod:`exoleg.child`:
passive moments, their level's spasticity preset, their own effort). Noise: the sensors'
datasheet noise times 0 (ideal), 1 and 3. Reference for comparison: shank-gyroscope
detection in children with CP, onset error < 100 ms and > 99 % of phases detected
(Behboodi et al. 2019); in general, initial contact -25 ms, foot off < 75 ms, > 98 %
detected (Catalfamo et al. 2010).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from exoleg.device.faults import SensorFault, faulted

#: (label, age, sex, GMFCS level or None)
CHILDREN: tuple[tuple[str, float, str, int | None], ...] = (
    ("GMFCS I boy 12 y", 12.0, "male", 1),
    ("GMFCS III girl 10 y", 10.0, "female", 3),
    ("TD girl 9 y", 9.0, "female", None),
)
NOISE = (0.0, 1.0, 3.0)
#: slower walking, stride times (s): the issue's range reaches 4 s
SLOW = (2.0, 4.0)
#: each child walks as an actor (:mod:`exoleg.child`): their own effort with their
#: level's strength, and this spasticity preset by GMFCS level (0: typically developing)
SPASTICITY = {0: "none", 1: "mild", 2: "mild", 3: "moderate", 4: "moderate"}
#: Harder walkers, at the datasheet noise: (label, age, sex, GMFCS level, the actor's
#: :meth:`~exoleg.child.model.ChildModel.of` options, the operator's commands: "walk" --
#: walking from the standing start on --, "stop": walking, then a controlled stop two
#: thirds of the way and standing, or "again": a stop a third of the way, walking again
#: two thirds of the way). Crouch: Rozumalski & Schwartz 2009's clusters; the contracture:
#: Falisse et al. 2020's child with CP (``child-references.md``).
WORST: tuple[tuple[str, float, str, int | None, dict[str, Any], str], ...] = (
    ("GMFCS III girl 10 y, crouch (cluster 5), contracture, moderate spasticity", 10.0,
     "female", 3, {"contracture": "predictcpgait", "spasticity": "moderate", "crouch": 5},
     "walk"),
    ("GMFCS IV boy 11 y, crouch (cluster 4), contracture, half strength", 11.0, "male", 4,
     {"contracture": "predictcpgait", "spasticity": "moderate", "crouch": 4,
      "strength": 0.5}, "walk"),
    ("GMFCS II boy 9 y, contracture, moderate spasticity", 9.0, "male", 2,
     {"contracture": "predictcpgait", "spasticity": "moderate"}, "walk"),
    ("TD girl 9 y, walking, then a controlled stop", 9.0, "female", None, {}, "stop"),
    ("TD girl 9 y, walking, a controlled stop, walking again", 9.0, "female", None, {},
     "again"),
)


@dataclass(frozen=True)
class DetectionRun:
    child: str
    noise: float
    strides: int
    fault: bool
    stride_time: float = 1.1


@dataclass(frozen=True)
class GaitPhaseValidation:
    """What ``exoleg validate --gait-phase`` measures: the detection table over every
    walk at the expected stride time (``rows``) and over those the safety layer did not
    stop (``rows_ok``), the walks (``runs``), the sensor faults replayed over the latter
    (``faults``, :func:`fault_cases`), and per slower stride time (s) the table of the
    children walking so (``slow``) and each single source's over the same walks
    (``slow_sources``: :data:`SOURCES`), per harder walker (:data:`WORST`) each
    source's (``worst``), and per sensor fault injected into the walks (closed loop:
    the controller walking on the faulted readings, :data:`FAULTS`) the detection table
    over the children's walks at the datasheet noise (``closed``) and the children the
    safety layer stopped (``closed_stopped``)."""

    rows: list[dict[str, Any]]
    rows_ok: list[dict[str, Any]]
    runs: list[DetectionRun]
    faults: dict[str, list[dict[str, Any]]]
    slow: dict[float, list[dict[str, Any]]]
    slow_sources: dict[float, dict[str, list[dict[str, Any]]]]
    worst: dict[str, dict[str, list[dict[str, Any]]]]
    closed: dict[str, list[dict[str, Any]]]
    closed_stopped: dict[str, list[str]]


def _walker(age: float, sex: str, gmfcs: int | None,
            actor: dict[str, Any]) -> tuple[Any, float, float, Any]:
    """(personalized leg, body mass kg, ankle height m, the child as an actor) of a child
    at the 50th percentile of their growth charts
    (:func:`~exoleg.sizing.child.population_child`)."""
    from exoleg.child.model import ChildModel
    from exoleg.sizing import estimate_dimensions, fit_device, personalized_leg
    from exoleg.sizing.child import population_child

    child, _ = population_child(gmfcs, sex, age, 50.0)
    leg = personalized_leg(child, fit_device(child))
    return leg, child.mass, estimate_dimensions(child).ankle_height, ChildModel.of(child,
                                                                                  **actor)


def _stop(strides: int, stride_time: float, again: bool = False, standing: float = 1.0,
          dt: float = 1e-3) -> Any:
    """The operator's commands per tick for :func:`~exoleg.sim.walk.simulate_walk`: arm,
    walk after ``standing`` s, stand after two thirds of the strides -- or, ``again``,
    stand after a third and walk again after two thirds."""
    from exoleg.tick import Command

    n = int(round((standing + strides * stride_time) / dt))
    c = np.zeros(n + 1, dtype=np.int64)
    walk = int(round(standing / dt))
    c[0], c[walk] = Command.ARM, Command.WALK
    stop = walk + int(round((1 if again else 2) * strides / 3 * stride_time / dt))
    c[stop] = Command.STAND
    if again:
        c[walk + int(round(2 * strides / 3 * stride_time / dt))] = Command.WALK
    return c


def evaluate(strides: int = 20, noise: tuple[float, ...] = NOISE,
             children: tuple[tuple[str, float, str, int | None], ...] = CHILDREN,
             seed: int = 0, slow: tuple[float, ...] = SLOW,
             worst: tuple[tuple[str, float, str, int | None, dict[str, Any], str], ...]
             = WORST, closed: tuple[str, ...] | None = None,
             other_foot: bool = False) -> GaitPhaseValidation:
    """Each child walks ``strides`` strides at each noise level at the expected 1.1 s
    stride, and at the datasheet noise at each of the ``slow`` stride times (s) and with
    each sensor fault of ``closed`` (:data:`FAULTS`' names; None: all but the first, the
    walks' own readings); each of the ``worst`` walkers ``strides`` strides at the
    datasheet noise. ``other_foot``: every walk with the unassisted foot's insole fitted
    (the controller's detector reading both feet's FSRs), every replay with it too."""
    import functools

    from exoleg.control.safety import Limited
    from exoleg.sim.metrics import detection_table
    from exoleg.sim.walk import simulate_walk

    # with the insole: the device's board at each noise scale, the insole fitted
    walk = functools.partial(_with_insole, simulate_walk) if other_foot else simulate_walk
    replay = functools.partial(fault_cases, other_foot=other_foot)

    results: list[Any] = []  # (walk, run) at the expected stride
    runs: list[DetectionRun] = []
    slow_results: dict[float, list[Any]] = {s: [] for s in slow}
    known = faults_for(other_foot)
    cases = tuple(known)[1:] if closed is None else closed
    closed_walks: dict[str, list[Any]] = {c: [] for c in cases}
    stopped: dict[str, list[str]] = {c: [] for c in cases}
    for label, age, sex, gmfcs in children:
        leg, m, ankle, actor = _walker(age, sex, gmfcs, {"spasticity": SPASTICITY[gmfcs or 0]})
        for case in cases:
            r = walk(leg, m, strides=strides, seed=seed + 1, ankle_height=ankle,
                              child=actor, faults=known[case])
            closed_walks[case].append(r)
            if np.any(r.safety_status & Limited.FAULT):
                stopped[case].append(label)
        walks = [(n, 1.1, k) for k, n in enumerate(noise)] + [
            (1.0, st, len(noise) + k) for k, st in enumerate(slow)]
        for n, st, k in walks:
            r = walk(leg, m, strides=strides, noise_scale=n, seed=seed + k,
                              ankle_height=ankle, child=actor, stride_time=st)
            run = DetectionRun(label, n, strides, bool(np.any(r.safety_status & Limited.FAULT)),
                               st)
            runs.append(run)
            if k < len(noise):
                results.append((r, run))
            else:
                slow_results[st].append(r)
    hard = {}
    for k, (label, age, sex, gmfcs, options, how) in enumerate(worst):
        leg, m, ankle, actor = _walker(age, sex, gmfcs, options)
        r = walk(leg, m, strides=strides, seed=seed + 10 + k, ankle_height=ankle,
                          child=actor, commands=None if how == "walk" else
                          _stop(strides, 1.1, again=how == "again"))
        runs.append(DetectionRun(label, 1.0, strides,
                                 bool(np.any(r.safety_status & Limited.FAULT))))
        hard[label] = replay([r], 1.1, SOURCES)
    walks_ = [r for r, _ in results]
    ok = [r for r, run in results if not run.fault]
    return GaitPhaseValidation(detection_table(walks_), detection_table(ok) if ok else [],
                               runs, replay(ok),
                               {st: detection_table(rs) for st, rs in slow_results.items()},
                               {st: replay(rs, st, SOURCES)
                                for st, rs in slow_results.items()}, hard,
                               {c: detection_table(rs) for c, rs in closed_walks.items()},
                               stopped)


def _with_insole(walk: Any, *args: Any, noise_scale: float = 1.0, **kw: Any) -> Any:
    """``walk`` (:func:`~exoleg.sim.walk.simulate_walk`) on the shipped foot board at
    ``noise_scale`` with the unassisted foot's insole fitted."""
    import dataclasses

    from exoleg.device.sensors import FootSensors

    board = dataclasses.replace(FootSensors.default(noise_scale), other_foot=True)
    return walk(*args, noise_scale=noise_scale, sensors=board, **kw)


#: Sensor faults (:class:`~exoleg.device.faults.SensorFault`), replayed over the walks'
#: readings through the controller's own detector (open loop: each walk itself ran on
#: its clean readings, :func:`fault_cases`) and injected into walks (closed loop:
#: ``closed`` of :func:`evaluate`).
FAULTS: dict[str, tuple[SensorFault, ...]] = {
    "none (the walks' own readings, replayed)": (),
    "heel sensor failed (reads 0)": (SensorFault("heel", "dead"),),
    "hallux sensor failed (reads 0)": (SensorFault("hallux", "dead"),),
    "first metatarsal preloaded by the strap (+25 % of full scale)":
        (SensorFault("met1", "offset", value=0.25),),
    "every sensor drifting up, +50 % of its reading per minute":
        (SensorFault("fsrs", "drift", value=0.5 / 60.0),),
    "gyroscope failed (no reading: the FSRs alone)": (SensorFault("gyro", "missing"),),
    "FSRs failed (no reading: the IMU alone)": (SensorFault("fsrs", "missing"),),
    "FSRs reading zeros (their cable off: the IMU alone once silent)":
        (SensorFault("fsrs", "dead"),),
    "foot board frozen: FSRs repeating a reading from 2 s":
        (SensorFault("fsrs", "frozen", 2.0),),
    "gyroscope frozen: repeating a reading from 2 s": (SensorFault("gyro", "frozen", 2.0),),
    "preloaded metatarsal, gyroscope failed":
        (SensorFault("met1", "offset", value=0.25), SensorFault("gyro", "missing")),
}
#: The insole's own fault, a case where it is fitted (``other_foot``): its cable off, the
#: device's foot's sensors alone once it is silent.
INSOLE_FAULTS: dict[str, tuple[SensorFault, ...]] = {
    "the other foot's insole reading zeros (its cable off)": (SensorFault("insole", "dead"),),
}


def faults_for(other_foot: bool) -> dict[str, tuple[SensorFault, ...]]:
    """The sensor fault cases (:data:`FAULTS`, and :data:`INSOLE_FAULTS` with the
    insole)."""
    return {**FAULTS, **INSOLE_FAULTS} if other_foot else FAULTS


#: The single sources, as :data:`FAULTS` cases: both, the FSRs alone, the IMU alone.
SOURCES = ("none (the walks' own readings, replayed)",
           "gyroscope failed (no reading: the FSRs alone)",
           "FSRs failed (no reading: the IMU alone)")


def fault_cases(results: list[Any], stride_time: float = 1.1,
                cases: tuple[str, ...] | None = None, other_foot: bool = False
                ) -> dict[str, list[dict[str, Any]]]:
    """Per :data:`FAULTS` case (or those named in ``cases``), the detection table
    (:func:`exoleg.control.replay.event_rows`) of the controller's detector replayed from
    a fresh state over each walk's readings with the fault, against the walk's true
    events; ``other_foot``: with the unassisted foot's insole too (the walks' own,
    ``fsr_other``: walked with it fitted; the fault is the device foot's board's)."""
    from exoleg.control import gait_phase as gp
    from exoleg.control.replay import detect_all, event_rows
    from exoleg.system.config import DeviceConfig

    cfg = DeviceConfig.load()
    d = cfg.detector.record(cfg.fsr_floor_counts, stride_time, cfg.sensors.gyro_range,
                            cfg.sensors.accel_range, other_foot)
    out = {}
    known = faults_for(other_foot)
    for name in cases or tuple(known):
        series = []
        for r in results:
            counts, gyro, accel, other = faulted(
                known[name], r.fsr, r.gyro, r.accel, r.t, cfg.sensors,
                np.ascontiguousarray(r.fsr_other) if other_foot else None)
            bits = detect_all(d, gp.new_state(d), counts, gyro, accel, r.t, other)
            walking = r.t >= r.walk_start
            series.append((r.t[walking], bits[walking], r.true_events()[walking]))
        out[name] = event_rows(series)
    return out
