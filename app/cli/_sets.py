"""The one way every `artro` option that takes a parameter set reads it (`--params`, `--base`,
`--presets`): a file's path, else a built-in preset's name, else a preset saved in the data
directory; anything else is refused naming the presets there are."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from app.params.document import ParameterSet
from app.params.formats import load_parameter_set
from app.params.presets import (
    BUILTIN_DIR,
    SUFFIX,
    PresetError,
    PresetNotFound,
    PresetStore,
    builtin_presets,
    default_data_dir,
    not_a_file,
)

SETS_HELP = "a parameter-set file, or a built-in or saved preset's name"


@dataclass(frozen=True)
class ChosenSet:
    """A parameter set as an option named it: `spec` as typed, the file it was read from (None
    for the paper's values built into the code) and the set itself."""

    spec: str
    path: Path | None
    pset: ParameterSet
    builtin: bool = False


def preset_names(data_dir: Path | None = None) -> tuple[list[str], list[str]]:
    """The built-in presets' names and those saved in `data_dir` (default: the data directory
    `artro serve` keeps them in)."""
    store = PresetStore(data_dir or default_data_dir(), builtin_presets())
    infos = store.list()
    return [i.name for i in infos if i.builtin], [i.name for i in infos if not i.builtin]


def unknown_set(spec: str, option: str, data_dir: Path | None = None) -> str:
    """The sentence for a `spec` that is neither a file nor a preset: what there is instead."""
    directory = (data_dir or default_data_dir()) / "presets"
    builtins, saved = preset_names(data_dir)
    problem = not_a_file(Path(spec))
    what = f"{spec} {problem}" if problem else f"No such file or preset {spec!r}"
    return (
        f"{what} for {option}: give a parameter-set file or a preset's "
        f"name; built-in presets: {', '.join(builtins)}; saved presets (in {directory}): "
        f"{', '.join(saved) or 'none'}"
    )


def resolve_set(spec: str, option: str = "--params", data_dir: Path | None = None) -> ChosenSet:
    """The parameter set `spec` names for `option`: an existing file first (so a file called
    like a preset is still read), then a built-in preset, then a saved one (in `data_dir`, by
    default `default_data_dir()`). ValueError otherwise, naming
    the built-in and saved presets; a file that is not a parameter set says what is wrong."""
    path = Path(spec)
    if path.is_file():
        return ChosenSet(spec, path, load_parameter_set(path))
    builtins = builtin_presets()
    if spec in builtins:
        file = BUILTIN_DIR / f"{spec}{SUFFIX}"
        return ChosenSet(spec, file if file.is_file() else None, builtins[spec], builtin=True)
    store = PresetStore(data_dir or default_data_dir(), builtins)
    try:
        pset = store.get(spec)
    except PresetNotFound:
        raise ValueError(unknown_set(spec, option, data_dir)) from None
    except PresetError:
        if (store.directory / f"{spec}{SUFFIX}").is_file():
            raise  # a saved preset that cannot be read: its own error says why
        raise ValueError(unknown_set(spec, option, data_dir)) from None  # not a name at all
    return ChosenSet(spec, store.directory / f"{spec}{SUFFIX}", pset)


def resolve_sets(
    text: str, option: str = "--presets", data_dir: Path | None = None
) -> list[ChosenSet]:
    """A comma-separated list of `resolve_set` specs, each checked; ValueError for an empty
    list or an unknown name."""
    specs = [s.strip() for s in text.split(",") if s.strip()]
    if not specs:
        builtins, _saved = preset_names(data_dir)
        raise ValueError(
            f"{option} names no parameter set; built-in presets: {', '.join(builtins)}"
        )
    return [resolve_set(spec, option, data_dir) for spec in specs]
