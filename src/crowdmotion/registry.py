"""Method name -> method: the only place that knows every method."""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any

from pydantic import ValidationError

from crowdmotion._validation import error_lines

# name -> module exposing ``Params`` (frozen dataclass) and
# ``run_scenario(scene, groups, params, rng, progress) -> (Trajectories, extras, summary)``; optional
# ``check_scenario(scene, groups, params)`` (refuses a scenario at load) and ``write_plots``
_METHODS = {"mdp": "crowdmotion.mdp.adapter", "rvo": "crowdmotion.rvo.adapter", "pso": "crowdmotion.pso.adapter",
            "formation": "crowdmotion.formation.adapter"}


@dataclass(frozen=True)
class Method:
    name: str
    module: Any

    @property
    def params_type(self):
        return self.module.Params

    def run(self, scene, groups, params, rng, progress: bool = True):
        return self.module.run_scenario(scene, groups, params, rng, progress)


def available() -> list[str]:
    return sorted(_METHODS)


def get_method(name: str) -> Method:
    if name not in _METHODS:
        raise ValueError(f"unknown method {name!r}; available: {available()}")
    return Method(name, importlib.import_module(_METHODS[name]))


def method_params(name: str, block: dict):
    """The method's parameter object from its scenario block (errors name ``method.field``)."""
    cls = get_method(name).params_type
    try:
        return cls.model_validate(block)
    except ValidationError as exc:
        raise ValueError("; ".join(error_lines(exc, name, known=cls.model_fields))) from None
    except (TypeError, ValueError) as exc:
        msg = str(exc)
        raise ValueError(msg if msg.startswith(f"{name}.") else f"{name}: {msg}") from None
