"""Scenes: one run described as data — the schema (:mod:`.schema`), files with
inheritance and overrides (:mod:`.load`), validation into a :class:`Scene`
(:mod:`.validate`)."""

from .load import SCENE_DIR, apply_overrides, parse_override, resolve, shipped
from .schema import SCHEMA, SceneError, describe_keys
from .validate import Scene, check_value, validate


def load(ref, overrides=()) -> Scene:
    """Resolve, override and validate a scene (shipped name or .toml path), before any heavy work."""
    return validate(apply_overrides(resolve(ref), overrides))


__all__ = ["SCENE_DIR", "SCHEMA", "Scene", "SceneError", "apply_overrides", "check_value", "describe_keys",
           "load", "parse_override", "resolve", "shipped", "validate"]
