"""Robots by name: calib-pin's own descriptions, example-robot-data's, or a URDF path.

A robot is resolved to a :class:`RobotDescription`: its URDF file, the default end
frame, and, where one is known, its standard DH table. calib-pin's own robots live in
the repository's ``robots/`` folder (a URDF plus a ``<name>.toml`` with the DH table,
the end frame and a default measurement set).
"""

from __future__ import annotations

import os
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import ArgumentError, RobotError
from ..util.arguments import shown_value

#: Folder of calib-pin's own robot descriptions (the repository's ``robots/``; in an
#: installed wheel, the copy shipped as ``calib_pin/robot_files``).
ROBOTS_DIR = next(
    (
        p
        for p in (
            Path(__file__).resolve().parents[2] / "robots",
            Path(__file__).resolve().parents[1] / "robot_files",
        )
        if (p / "irb120.urdf").is_file()
    ),
    Path(__file__).resolve().parents[2] / "robots",
)


@dataclass(frozen=True)
class DHTable:
    """Standard DH table (paper eq. 1): A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i).

    Attributes:
        a: Link lengths, shape (n,), in [m].
        d: Link offsets, shape (n,), in [m].
        alpha: Link twists, shape (n,), in [rad].
        theta_offset: Joint-angle offsets added to the joint reading, shape (n,), [rad].
    """

    a: np.ndarray
    d: np.ndarray
    alpha: np.ndarray
    theta_offset: np.ndarray

    @property
    def n_joints(self) -> int:
        return len(self.a)


#: The widest :attr:`RobotDescription.limit_margin` a caller may give, [deg]: beyond it the
#: angles are another robot's or a unit mistake, not a controller's wider limits.
MAX_LIMIT_MARGIN_DEG = 30.0


@dataclass(frozen=True)
class RobotDescription:
    """Where a robot's model comes from.

    Attributes:
        name: Name the robot was asked for by (``irb120``, ``ur5``, or a file stem).
        urdf: Path of the URDF file.
        end_frame: Default end frame (``tool0`` where the URDF has one).
        dh: Standard DH table from base to ``end_frame``, or None when none is known.
        default_data: Measurement set used when none is given, or None.
        package_dirs: Folders where ``package://`` URIs of the URDF resolve.
        limit_margin: How far beyond its URDF limits each revolute joint of a chain of
            this robot goes, [rad] (0: the URDF's limits; a controller that allows more:
            ``prepare(limit_margin_deg=...)``, ``calibrate --limit-margin-deg``).
    """

    name: str
    urdf: Path
    end_frame: str | None
    dh: DHTable | None = None
    default_data: Path | None = None
    package_dirs: tuple[Path, ...] = ()
    limit_margin: float = 0.0


def own_robot_names() -> list[str]:
    """Names of calib-pin's own robots (the ``*.toml`` files in ``robots/``)."""
    return sorted(p.stem for p in ROBOTS_DIR.glob("*.toml"))


def _read_dh(table: dict, source: Path) -> DHTable:
    keys = ("a_mm", "d_mm", "alpha_deg", "theta_offset_deg")
    missing = [k for k in keys if k not in table]
    if missing:
        raise RobotError(f"{source}: [dh] lacks {', '.join(missing)}")
    values = {k: np.asarray(table[k], dtype=float) for k in keys}
    if len({v.shape for v in values.values()}) != 1:
        raise RobotError(f"{source}: [dh] columns have different lengths")
    return DHTable(
        a=values["a_mm"] * 1e-3,
        d=values["d_mm"] * 1e-3,
        alpha=np.deg2rad(values["alpha_deg"]),
        theta_offset=np.deg2rad(values["theta_offset_deg"]),
    )


def _own_robot(name: str) -> RobotDescription:
    toml_path = ROBOTS_DIR / f"{name}.toml"
    with toml_path.open("rb") as f:
        spec = tomllib.load(f)
    default = spec.get("default_data")
    return RobotDescription(
        name=name,
        urdf=ROBOTS_DIR / spec["urdf"],
        end_frame=spec.get("end_frame"),
        dh=_read_dh(spec["dh"], toml_path) if "dh" in spec else None,
        default_data=ROBOTS_DIR / default if default else None,
    )


def _example_robot(name: str) -> RobotDescription | None:
    """Locate an example-robot-data URDF without building its geometry."""
    try:
        from example_robot_data import robots_loader
    except ImportError:  # pragma: no cover - a dependency of calib-pin
        return None
    loader = robots_loader.ROBOTS.get(name)
    if loader is None or not loader.urdf_filename:
        return None
    sub = str(Path(loader.path) / loader.urdf_subpath / loader.urdf_filename)
    model_path = loader.model_path or robots_loader.getModelPath(sub)
    urdf = Path(model_path) / sub
    return RobotDescription(
        name=name,
        urdf=urdf,
        end_frame="tool0" if "tool0" in urdf.read_text() else None,
        package_dirs=(Path(model_path).parent.parent,),
    )


def resolve_robot(robot: str | Path) -> RobotDescription:
    """Find a robot by name or URDF path.

    Args:
        robot: A name under ``robots/`` (``irb120``), a name example-robot-data knows
            (``ur5``, ``panda``, ...), or the path of a URDF file.

    Raises:
        RobotError: the name is none of these, with the names that are.
    """
    text = str(robot)
    if text in own_robot_names():
        return _own_robot(text)
    path = Path(text)
    if path.suffix.lower() == ".urdf" or path.is_file():
        if not path.is_file():
            raise RobotError(f"{path}: no such URDF file")
        return RobotDescription(
            name=path.stem,
            urdf=path,
            end_frame="tool0" if "tool0" in path.read_text(errors="replace") else None,
            package_dirs=(path.resolve().parent,),
        )
    found = _example_robot(text)
    if found is not None:
        return found
    raise RobotError(
        f"unknown robot '{text}': give a URDF path, one of calib-pin's robots "
        f"({', '.join(own_robot_names())}), or an example-robot-data name (ur5, panda, ...)"
    )


def as_robot(value: Any, arg: str = "robot") -> Any:
    """A robot: its name or URDF path (str or os.PathLike), or a resolved description.

    Args:
        value: The value to check.
        arg: The argument's name, for messages.

    Raises:
        ArgumentError: anything else, naming ``arg``.
    """
    if isinstance(value, RobotDescription):
        return value
    if isinstance(value, os.PathLike):
        return str(value)
    if isinstance(value, str) and value.strip():
        return value
    raise ArgumentError(arg, f"expected a robot name or URDF path (str), got {shown_value(value)}")


def robot_file(robot: str | None) -> str | None:
    """A robot argument when it names a file (a URDF path: an input), else None (a name)."""
    return robot if robot and os.path.isfile(robot) else None


def robot_inputs(robot: str | None) -> dict[str, str | None]:
    """The files a robot argument reads, by label.

    A URDF path; for one of calib-pin's own robots by name (``irb120``), its URDF, its DH
    table and its default data set, which an output given by path
    (``--out robots/irb120.urdf --force``) must never replace.
    """
    if robot_file(robot) or not robot or robot not in own_robot_names():
        return {"ROBOT": robot_file(robot)}
    found = resolve_robot(robot)
    return {f"ROBOT {robot}'s URDF": str(found.urdf), f"ROBOT {robot}'s DH table": str(ROBOTS_DIR / f"{robot}.toml"),
            f"ROBOT {robot}'s default data": str(found.default_data) if found.default_data else None}
