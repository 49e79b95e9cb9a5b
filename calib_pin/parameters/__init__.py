"""Parameter models by name, and the one rule that picks the default.

- ``dh`` (:class:`.dh.DHModel`): the paper's model, per joint (Δa, Δd, Δα, Δθ);
- ``hayati`` (:class:`.hayati.HayatiModel`): DH with a tilt β for parallel axes;
- ``placement`` (:class:`.placement.PlacementModel`): a 6D twist per joint origin and
  the end frame, for any URDF chain.
"""

from __future__ import annotations

from ..exceptions import RobotError
from ..robot.chain import Chain
from .base import ParameterModel
from .dh import DHModel, dh_transforms
from .hayati import HayatiModel
from .placement import PlacementModel

#: Parameter models calib-pin offers, by ``--model`` name.
MODELS = ("dh", "hayati", "placement")


def default_model(chain: Chain) -> str:
    """The parameter model used when none is named: ``dh`` with a DH table, else ``placement``.

    The DH table is the robot's ``robots/<name>.toml``.
    """
    return "dh" if chain.description.dh is not None else "placement"


def parameter_model(chain: Chain, name: str | None = None) -> ParameterModel:
    """The parameter model ``name`` (one of :data:`MODELS`; None: :func:`default_model`).

    ``dh`` and ``hayati`` need the robot's DH table (``robots/<name>.toml``);
    ``placement`` works for any URDF chain.

    Args:
        chain: The robot chain.
        name: ``dh``, ``hayati`` or ``placement``; None: :func:`default_model`.

    Raises:
        RobotError: the robot has no DH table for a DH model, or the name is unknown.
    """
    from ..robot.chain import as_chain
    from ..util.arguments import as_instance, as_optional

    as_chain(chain, "chain")
    return model_of(chain, as_optional(as_instance, name, "name", str, f"a parameter model's name ({', '.join(MODELS)})"))


def model_of(chain: Chain, name: str | None) -> ParameterModel:
    """:func:`parameter_model` of a chain and a name already checked (a calibration's own).

    Raises:
        RobotError: the robot has no DH table for a DH model, or the name is unknown.
    """
    name = name or default_model(chain)
    if name not in MODELS:
        raise RobotError(f"unknown parameter model '{name}' (valid: {', '.join(MODELS)})")
    if name == "placement":
        return PlacementModel(chain)
    if chain.description.dh is None:
        raise RobotError(
            f"robot '{chain.name}' has no DH table for the '{name}' model: use --model "
            f"placement (any URDF), or add a [dh] table in robots/{chain.name}.toml"
        )
    return (HayatiModel if name == "hayati" else DHModel)(chain, chain.description.dh)


__all__ = ["MODELS", "DHModel", "HayatiModel", "ParameterModel", "PlacementModel", "default_model",
           "dh_transforms", "model_of", "parameter_model"]
