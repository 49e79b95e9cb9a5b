"""The corrected DH table: the columns and units of ``robots/<name>.toml``.

:func:`write_dh_table` writes ``a_mm``, ``alpha_deg``, ``d_mm``, ``theta_offset_deg`` (and
``beta_deg`` for the Hayati model) for the ``dh`` and ``hayati`` models; the placement
model has no DH table.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..exceptions import CalibPinError
from ..parameters.base import ParameterModel
from ..parameters.dh import DHModel
from ..util.atomic import write_text


def corrected_dh(params: ParameterModel, x: np.ndarray) -> tuple[dict[str, np.ndarray], tuple[int, ...]]:
    """The corrected DH columns of a dh or hayati model.

    Args:
        params: A :class:`calib_pin.parameters.DHModel` or ``HayatiModel``.
        x: The robot's deviations, shape (n_params,), [m, m or rad, rad, rad] per row.

    Returns:
        columns: ``a_mm``, ``alpha_deg``, ``d_mm``, ``theta_offset_deg`` (and ``beta_deg``
            for a Hayati model), shape (n,) each.
        hayati_rows: 0-based rows whose second deviation is beta, not d.

    Raises:
        CalibPinError: the placement model (it has no DH table) or a wrong length of x.
    """
    if not isinstance(params, DHModel):
        raise CalibPinError("the placement model has no DH table: --export dh needs --model dh or hayati "
                            "(urdf and yaml work for every model)")
    x = np.asarray(x, dtype=float)
    if x.shape != (len(params.names),):
        raise CalibPinError(f"{len(x)} deviations given, the {type(params).__name__} has {len(params.names)}")
    t, dev = params.table, x.reshape(-1, 4)
    rows = tuple(params.hayati_rows)
    second = dev[:, 1].copy()
    d = t.d + np.where(np.isin(np.arange(t.n_joints), rows), 0.0, second)
    columns = {
        "a_mm": (t.a + dev[:, 0]) * 1e3,
        "alpha_deg": np.rad2deg(t.alpha + dev[:, 2]),
        "d_mm": d * 1e3,
        "theta_offset_deg": np.rad2deg(t.theta_offset + dev[:, 3]),
    }
    if rows:
        beta = np.zeros(t.n_joints)
        beta[list(rows)] = second[list(rows)]
        columns["beta_deg"] = np.rad2deg(beta)
    return columns, rows


def _toml_list(values: np.ndarray) -> str:
    return "[" + ", ".join(repr(float(v)) if abs(v) > 1e-12 else "0.0" for v in values) + "]"


def write_dh_table(params: ParameterModel, x: np.ndarray, path: str | Path, notes: Sequence[str] = ()) -> Path:
    """Write the corrected DH table as a TOML ``[dh]`` table like ``robots/<name>.toml``.

    Columns ``a_mm``, ``alpha_deg``, ``d_mm``, ``theta_offset_deg`` (standard DH, paper eq. 1,
    A_i = Rz(theta_offset_i + q_i) Tz(d_i) Tx(a_i) Rx(alpha_i)); frame 0 is the URDF root,
    frame n the end frame (times the fixed end transform, written when not identity).

    For the Hayati model a fifth column ``beta_deg`` holds the tilt of the rows whose d
    the model replaced (parallel consecutive axes): A_i = Rz(theta_offset_i + q_i) Tz(d_i)
    Tx(a_i) Rx(alpha_i) Ry(beta_i), with d_i the nominal value. A standard 4-column DH
    reader does not know beta: the file's header says so, and the table is only exact
    with it.

    Args:
        params: A :class:`calib_pin.parameters.DHModel` or ``HayatiModel``.
        x: The robot's deviations, shape (n_params,), SI ([m], [rad]).
        path: The TOML file to write.

    Raises:
        CalibPinError: placement model, or x of the wrong length.
    """
    columns, rows = corrected_dh(params, x)
    assert isinstance(params, DHModel)
    chain = params.chain
    header = [
        (f"calib-pin: corrected DH table of robot '{chain.name}' ({type(params).__name__}), "
        f"frame 0 = URDF root, frame {chain.n_joints} = {chain.end_frame}"),
        "A_i = Rz(theta_offset_i + q_i) Tz(d_i) Tx(a_i) Rx(alpha_i)" + (" Ry(beta_i)" if rows else ""),
    ]
    if rows:
        header.append(f"beta_deg (Hayati) tilts rows {', '.join(str(r + 1) for r in rows)} about their y axis; "
                      "a 4-column DH reader that ignores beta_deg gets a different robot")
    lines = [f"# {h}" for h in [*header, *notes]] + ["[dh]"]
    lines += [f"{key} = {_toml_list(values)}" for key, values in columns.items()]
    end = params.end_transform
    if np.linalg.norm(pin.log6(end).vector) > 1e-12:
        lines += ["", f"# {chain.end_frame} in DH frame {chain.n_joints}", "[dh_end]",
                  f"xyz_mm = {_toml_list(end.translation * 1e3)}",
                  f"rpy_deg = {_toml_list(np.rad2deg(pin.rpy.matrixToRpy(end.rotation)))}"]
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text(path, "\n".join(lines) + "\n")
    return path
