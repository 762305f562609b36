"""Effect kinds by name, in registration order (the order the plant applies and the search tries them)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from sparc_quad.effects.base import EffectKind

EFFECTS: dict[str, type[EffectKind]] = {}


class PlantEffectsError(ValueError):
    """A plant file or effect entry that cannot be used."""


class UnknownEffect(PlantEffectsError):
    pass


def register(cls: type[EffectKind]) -> type[EffectKind]:
    """Add an effect kind (usable as a class decorator); its NAME must be new."""
    if not cls.NAME or cls.NAME in EFFECTS:
        raise ValueError(f"effect kind name {cls.NAME!r} is empty or already registered")
    EFFECTS[cls.NAME] = cls
    return cls


def unregister(name: str) -> None:
    EFFECTS.pop(name)


def kind(name: str) -> type[EffectKind]:
    try:
        return EFFECTS[name]
    except KeyError:
        raise UnknownEffect(f"unknown effect {name!r}; known: {', '.join(EFFECTS)}") from None


def names() -> tuple[str, ...]:
    return tuple(EFFECTS)

