"""The tuner's study store (docs/DESIGN.md §12): every evaluated candidate is an Optuna trial,
written the moment its runs are done, in a journal file (default: no server) or any RDB URL;
a study resumes from the store alone, and `optuna-dashboard FILE` opens it."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import optuna

DEFAULT_STUDY = "artro-tune"
# optuna is imported where a study is opened (~0.3 s), not by every `artro` command


def open_storage(where: str | Path) -> optuna.storages.BaseStorage:
    """An RDB for a URL (sqlite:///..., postgresql://...), else a journal file at that path."""
    from optuna.storages import JournalStorage, RDBStorage
    from optuna.storages.journal import JournalFileBackend

    text = str(where)
    if "://" in text:
        return RDBStorage(text)
    Path(text).parent.mkdir(parents=True, exist_ok=True)
    return JournalStorage(JournalFileBackend(text))


class StudyStore:
    """One tuning study: its settings (fixed at creation; other settings are refused) and its
    trials, each with the generation, the candidate's point in the unit box, its loss and the
    metrics of its runs."""

    def __init__(
        self, where: str | Path, settings: dict[str, Any], *, name: str = DEFAULT_STUDY
    ) -> None:
        import optuna

        optuna.logging.set_verbosity(optuna.logging.WARNING)
        self.where = str(where)
        self.study = optuna.create_study(
            study_name=name, storage=open_storage(where), direction="minimize", load_if_exists=True
        )
        wanted = json.loads(json.dumps(settings))  # as the store gives it back
        found = self.study.user_attrs.get("settings")
        if found is None:
            self.study.set_user_attr("settings", wanted)
        elif found != wanted:
            raise ValueError(
                f"the study {name!r} in {self.where} was run with other settings ({found}); "
                f"use another --study file, another --study-name or the same options"
            )

    def recorded(self) -> dict[int, list[dict[str, Any]]]:
        """Finished evaluations by generation: {"unit", "loss", "metrics"} each."""
        from optuna.trial import TrialState

        out: dict[int, list[dict[str, Any]]] = {}
        for trial in self.study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,)):
            attrs = trial.user_attrs
            out.setdefault(int(attrs["generation"]), []).append(
                {"unit": attrs["unit"], "loss": trial.value, "metrics": attrs["metrics"]}
            )
        return out

    def record(
        self,
        generation: int,
        unit: Sequence[float],
        values: dict[str, tuple[float, float, float]],
        loss: float,
        metrics: dict[str, Any],
    ) -> None:
        """One finished candidate: `values` maps each tuned field to (value, low, high)."""
        from optuna.distributions import FloatDistribution
        from optuna.trial import create_trial

        trial = create_trial(
            params={k: v for k, (v, _, _) in values.items()},
            distributions={k: FloatDistribution(lo, hi) for k, (_, lo, hi) in values.items()},
            value=loss,
            user_attrs={"generation": generation, "unit": [float(u) for u in unit],
                        "metrics": metrics},
        )  # fmt: skip
        self.study.add_trial(trial)
