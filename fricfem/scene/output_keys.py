"""Checking the point and frame outputs of a scene: ``output.gauges`` (points
inside the plates) and ``output.frames`` (isochromatic frames at camera times).

Rules (docs/api.md, "Gauges and frames"):

* a gauge name is an identifier like a station's (1–64 letters, digits,
  ``_ - .``), unique ignoring case; its position ``[x1, x2]`` lies on a plate,
  0 <= x1 <= mesh.length, 0 < |x2| <= mesh.height, and not on the interface
  x2 = 0, where the two plates' nodes coincide (a gauge just above or below it
  is fine; the interface itself is ``output.stations``'); at most
  :data:`MAX_GAUGES` gauges;
* ``output.frames`` is a list of times or ``{start, interval, count}``; every
  frame time lies in (0, time.end], at least half a step, and two frames are
  at least one step apart (the interval at least one step); at most
  :data:`MAX_FRAMES` frames.
"""

from __future__ import annotations

import math

from ..keys import NUM, Key
from .schema import SceneError, shown
from .values import check_identifier, check_value

#: Most gauges a scene may ask for (each is sampled every ``output.gauges_every`` steps).
MAX_GAUGES = 10_000
#: Most isochromatic frames (each is a full field snapshot in fields.h5).
MAX_FRAMES = 1000
#: The keys of a camera table ``output.frames = {start, interval, count}``.
CAMERA = ("start", "interval", "count")


def _number(where: str, v, unit: str, low, high, doc: str, open_low=False) -> float:
    return float(check_value(where, Key(NUM, 0.0, unit, low, high, doc, open_low=open_low), v))


def check_gauges(table: dict, spec) -> dict:
    """The checked ``output.gauges``: {name: (x1, x2)} [m] (see the module's rules)."""
    if len(table) > MAX_GAUGES:
        raise SceneError(f"output.gauges: {len(table)} gauges; at most {MAX_GAUGES}")
    seen, out = {}, {}
    for name, pos in table.items():
        check_identifier("output.gauges: a gauge name", name, 64)
        if name.casefold() in seen:
            raise SceneError(f"output.gauges.{name}: the same name as output.gauges.{seen[name.casefold()]} "
                             f"(names must differ ignoring case)")
        seen[name.casefold()] = name
        where = f"output.gauges.{name}"
        if not isinstance(pos, list) or len(pos) != 2:
            raise SceneError(f"{where} = {shown(pos)}: expected [x1, x2] in m, a point inside a plate")
        x1 = _number(f"{where}[0]", pos[0], "m", 0.0, spec.length, "gauge position x1 along the plate")
        x2 = _number(f"{where}[1]", pos[1], "m", -spec.height, spec.height,
                     "gauge position x2 across the plates (< 0: lower plate, > 0: upper plate)")
        if x2 == 0.0:
            raise SceneError(f"{where}[1] = 0.0 m: on the interface, where the two plates' nodes coincide; put "
                             f"the gauge inside a plate (e.g. x2 = ±{min(spec.dy, spec.height) / 2:g} m) or use "
                             f"output.stations for the interface")
        out[name] = (x1, x2)
    return out


def frame_times(frames) -> list:
    """The frame times [s] of an ``output.frames`` value (a list, or a camera table),
    as given (unchecked: :func:`check_frames` checks them)."""
    if isinstance(frames, dict):
        start, interval, count = (frames.get(k) for k in CAMERA)
        return [start + k * interval for k in range(int(count))]
    return list(frames)


def check_frames(frames, t_end: float, step: float) -> list:
    """The checked frame times [s] of ``output.frames``; ``step``: the largest the
    run's step may be [s] (two frames must fall on different steps)."""
    if isinstance(frames, dict):
        for k in frames:
            if k not in CAMERA:
                raise SceneError(f"output.frames.{k}: unknown key; allowed: {', '.join(CAMERA)} (or give a list of "
                                 f"times)")
        for k in CAMERA:
            if k not in frames:
                raise SceneError(f"output.frames.{k}: missing; a camera table needs start [s], interval [s] and "
                                 f"count")
        start = _number("output.frames.start", frames["start"], "s", 0.0, t_end, "time of the first frame",
                        open_low=True)
        interval = _number("output.frames.interval", frames["interval"], "s", 0.0, 1.0,
                           "inter-frame time of the camera", open_low=True)
        count = frames["count"]
        if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= MAX_FRAMES:
            raise SceneError(f"output.frames.count = {shown(count)}: must be a whole number in [1, {MAX_FRAMES}]")
        if count > 1 and interval < step:
            raise SceneError(f"output.frames.interval = {interval!r} s: shorter than one step (up to {step:.3g} s "
                             f"on this mesh); frames would repeat")
        last = start + (count - 1) * interval
        if last > t_end * (1 + 1e-12):
            raise SceneError(f"output.frames: the last of {count} frames from {start!r} s every {interval!r} s is at "
                             f"{last:.6g} s, after time.end = {t_end!r} s; lower count to at most "
                             f"{int(math.floor((t_end - start) / interval + 1e-9)) + 1}")
        times = [min(t, t_end) for t in frame_times(frames)]
    else:
        if len(frames) > MAX_FRAMES:
            raise SceneError(f"output.frames: {len(frames)} frames; at most {MAX_FRAMES}")
        times = [_number(f"output.frames[{i}]", t, "s", 0.0, t_end, "frame time", open_low=True)
                 for i, t in enumerate(frames)]
    for i, t in enumerate(times):
        if t < 0.5 * step:
            raise SceneError(f"output.frames: the frame at {t!r} s is less than half a step (the step is up to "
                             f"{step:.3g} s): it would be the state at t = 0, which is not written")
    ordered = sorted(times)
    for a, b in zip(ordered[:-1], ordered[1:]):
        if b - a < step:
            raise SceneError(f"output.frames: frames at {a!r} s and {b!r} s are within one step (up to {step:.3g} s) "
                             f"of each other; both would be the same snapshot")
    return times


def check(scene, step: float) -> None:
    """Check a scene's ``output.gauges`` and ``output.frames`` (``step``: the run's
    largest possible step [s])."""
    check_gauges(scene.output.gauges, scene.mesh)
    check_frames(scene.output.frames, scene.t_end, step)
