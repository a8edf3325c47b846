"""Reference wave speeds and the speed ranges a front can run in."""

from __future__ import annotations

import math

#: Reference wave speeds a front speed is compared with, slowest first.
SPEED_NAMES = ("c_R", "c_s", "sqrt2_c_s", "c_l")


def check_speeds(speeds) -> dict:
    missing = [k for k in SPEED_NAMES if k not in speeds]
    if missing:
        raise ValueError(f"speeds: missing {', '.join(missing)} [m/s] (use Material().speeds())")
    out = {k: float(speeds[k]) for k in SPEED_NAMES}
    for k, v in out.items():
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"speeds[{k!r}] = {v!r} m/s: must be positive")
    return out


def mach_numbers(speed: float, speeds: dict) -> dict:
    """|speed| over each reference wave speed: ``{"c_R": .., "c_s": .., "sqrt2_c_s": .., "c_l": ..}``."""
    sp = check_speeds(speeds)
    return {k: abs(float(speed)) / sp[k] for k in SPEED_NAMES}


def regime(speed: float, speeds: dict) -> str:
    """Name of the speed range |speed| falls in: ``sub-Rayleigh`` (< c_R),
    ``sub-shear`` (c_R .. c_s), ``intersonic`` (c_s .. √2 c_s), ``intersonic
    above sqrt2 c_s`` (√2 c_s .. c_l) or ``supersonic`` (≥ c_l)."""
    sp = check_speeds(speeds)
    v = abs(float(speed))
    if not math.isfinite(v):
        return "unknown"
    if v < sp["c_R"]:
        return "sub-Rayleigh"
    if v < sp["c_s"]:
        return "sub-shear"
    if v < sp["sqrt2_c_s"]:
        return "intersonic"
    if v < sp["c_l"]:
        return "intersonic above sqrt2 c_s"
    return "supersonic"
