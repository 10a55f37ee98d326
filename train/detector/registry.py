"""Named parts of the detector, as OpenPCDet assembles them: a config section's `name` picks its builder.

Each part module registers its classes here under the names its config section allows
(train.config: `pillar_encoder.name`, `backbone_2d.name`, `fusion.name`, `head.name`,
`head.box_coder.name`); `build` makes the part a config section names.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Generic, TypeVar

Part = TypeVar("Part")


class Registry(Generic[Part]):
    """Builders of one kind of part, by name."""

    def __init__(self, kind: str) -> None:
        self.kind = kind
        self.builders: dict[str, Callable[..., Part]] = {}

    def register(self, *names: str) -> Callable[[Callable[..., Part]], Callable[..., Part]]:
        """Decorator: the class (or function) builds the part for each of `names`."""

        def add(builder: Callable[..., Part]) -> Callable[..., Part]:
            for name in names:
                if name in self.builders:
                    raise ValueError(f"{self.kind} {name!r} is registered twice")
                self.builders[name] = builder
            return builder

        return add

    def build(self, section: Any, *args: Any, **kwargs: Any) -> Part:
        """The part named by `section.name`, built from the section and the given arguments."""
        return self.builders[section.name](section, *args, **kwargs)


PILLAR_ENCODERS: Registry[Any] = Registry("pillar encoder")
BACKBONES_2D: Registry[Any] = Registry("2D backbone")
FUSIONS: Registry[Any] = Registry("fusion")
HEADS: Registry[Any] = Registry("dense head")
BOX_CODERS: Registry[Any] = Registry("box coder")
