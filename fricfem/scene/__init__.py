"""Scenes: one run described as data — the schema (:mod:`.schema`), files with
inheritance and overrides (:mod:`.load`), validation (:mod:`.validate`, on the
value checks of :mod:`.values`) into a :class:`Scene` with typed settings
(:mod:`.settings`), and the size and cost of its run estimated before anything
is built (:mod:`.cost`).  docs/scenes.md states the format and every rule."""

from .load import SCENE_DIR, apply_overrides, parse_override, resolve, shipped
from .schema import SCHEMA, SceneError, describe_keys
from .settings import OutputSettings, Scene, WatchdogSettings
from .validate import validate, validate_mesh
from .values import check_identifier, check_value


def load(ref, overrides=()) -> Scene:
    """Resolve, override and validate a scene (shipped name or .toml path), before any heavy work."""
    return validate(apply_overrides(resolve(ref), overrides))


__all__ = ["SCENE_DIR", "SCHEMA", "OutputSettings", "Scene", "SceneError", "WatchdogSettings", "apply_overrides",
           "check_identifier", "check_value", "describe_keys", "load", "parse_override", "resolve", "shipped",
           "validate", "validate_mesh"]
