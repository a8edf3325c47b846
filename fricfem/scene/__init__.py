"""Scenes: one run described as data — the schema (:mod:`.schema`), files with
inheritance and overrides (:mod:`.load`), validation into a :class:`Scene`
(:mod:`.validate`), and the size and cost of its run estimated before anything
is built (:mod:`.cost`).  docs/scenes.md states the format and every rule."""

from .load import SCENE_DIR, apply_overrides, parse_override, resolve, shipped
from .schema import SCHEMA, SceneError, describe_keys
from .validate import Scene, check_value, validate, validate_mesh


def load(ref, overrides=()) -> Scene:
    """Resolve, override and validate a scene (shipped name or .toml path), before any heavy work."""
    return validate(apply_overrides(resolve(ref), overrides))


__all__ = ["SCENE_DIR", "SCHEMA", "Scene", "SceneError", "apply_overrides", "check_value", "describe_keys",
           "load", "parse_override", "resolve", "shipped", "validate", "validate_mesh"]
