"""The `fitted:` section of a robot description (docs/FIT.md): the variation a fit to the
robot's own recording found (`artro fit`), with each field's uncertainty; the description's
nominal values stay as they were, every command walks the fitted robot as varied by it."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import yaml
from pydantic import BaseModel, ConfigDict, Field, Strict

Real = Annotated[float, Strict()]


class Fitted(BaseModel):
    """What a fit found: `variation` in `artro run --vary` form (docs/DESIGN.md §8), `sigma`
    each searched coordinate's standard deviation, `identified` those the recording told."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    variation: str = Field(max_length=2000, description="key=value,... (artro run --vary)")
    sigma: dict[str, Real] = Field(default_factory=dict, description="1 σ per fitted coordinate")
    identified: tuple[str, ...] = Field((), description="the coordinates the recording told")
    recording: str = Field("", max_length=1000, description="the recording fitted")
    routine: str = Field("", max_length=200)


def write_fitted(description: BaseModel, fitted: Fitted, path: Path) -> None:
    """`description` (its nominal values untouched) with `fitted`, as YAML in `path`."""
    data = description.model_dump(mode="json", exclude_none=True)
    data["fitted"] = fitted.model_dump(mode="json")
    text = yaml.safe_dump(data, sort_keys=False, allow_unicode=True)
    path.write_text(
        "# a robot fitted to its recording by `artro fit` (docs/FIT.md)\n" + text, encoding="utf-8"
    )
