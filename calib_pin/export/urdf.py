"""Corrected URDF: the input file with only its joint origins changed.

Each chain joint's ``<origin>`` is right-multiplied by its placement perturbation (in
Pinocchio the joint placement is the product of the fixed joints' origins before it
and its own origin, so the change lands on the joint's own origin). The end frame's
perturbation goes on the first fixed joint after the last moving joint, carried through
the fixed joints that follow, so that the whole tool chain (``flange``, ``tool0``) moves
rigidly. Names, limits, inertias, meshes, comments and every other element are kept.

A sensor's calibrated set-up may add frames (:class:`AddedFrame`: a camera, a board), each a
new link on a fixed joint from the end frame's link or the URDF's root link (the base).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin
from lxml import etree

from ..exceptions import RobotError
from ..robot.chain import Chain
from ..util.atomic import write_bytes


@dataclass(frozen=True)
class AddedFrame:
    """A frame a calibration adds to the URDF: a link ``name`` on the fixed joint ``name_joint``.

    Attributes:
        name: The new link's name.
        on: ``end`` (fixed to the end frame's link) or ``base`` (to the URDF's root link).
        placement: Its placement there (pin.SE3, [m]).
    """

    name: str
    on: str
    placement: pin.SE3


def frame_links(chain: Chain) -> tuple[str, str]:
    """The URDF links of the chain's base (the root link) and of its end frame."""
    root = etree.parse(str(chain.description.urdf)).getroot()
    joints = top_level_joints(root)
    children = {j.find("child").get("link") for j in joints.values()}
    links = [link.get("name") for link in root.iter("link") if link.getparent() is root]
    base = next((name for name in links if name not in children), links[0] if links else "base_link")
    end = chain.end_frame
    return base, joints[end].find("child").get("link") if end in joints else end


def _add_frames(root: etree._Element, chain: Chain, frames: Sequence[AddedFrame]) -> None:
    """Append each frame's link and fixed joint to ``root``.

    A frame the URDF already has on the same fixed joint (a URDF an earlier calibration
    wrote) is placed anew.

    Raises:
        RobotError: a frame whose link or joint name the URDF has otherwise.
    """
    taken = {e.get("name") for e in root if e.tag in ("link", "joint")}
    joints = top_level_joints(root)
    base, end = frame_links(chain)
    for frame in frames:
        joint_name = f"{frame.name}_joint"
        parent = end if frame.on == "end" else base
        earlier = joints.get(joint_name)
        if earlier is not None and earlier.get("type") == "fixed" and earlier.find("parent") is not None \
                and earlier.find("parent").get("link") == parent and earlier.find("child") is not None \
                and earlier.find("child").get("link") == frame.name:  # an earlier calibration's: placed anew
            _set_origin(earlier, frame.placement)
            continue
        clash = next((n for n in (frame.name, joint_name) if n in taken), None)
        if clash is not None:
            raise RobotError(f"the URDF of '{chain.name}' already has a link or joint '{clash}': the calibrated "
                             f"{frame.name} cannot be added under that name")
        taken.update((frame.name, joint_name))
        if len(root):
            root[-1].tail = "\n  "
        root.append(etree.Comment(f" added by calib-pin: {frame.name}, a calibrated sensor frame fixed to the "
                                  f"{'end frame' if frame.on == 'end' else 'base'} "))
        root[-1].tail = "\n  "
        etree.SubElement(root, "link", name=frame.name).tail = "\n  "
        joint = etree.SubElement(root, "joint", name=joint_name, type="fixed")
        joint.text = "\n    "
        origin = etree.SubElement(joint, "origin")
        origin.tail = "\n    "
        _set_origin(joint, frame.placement)
        etree.SubElement(joint, "parent", link=parent).tail = "\n    "
        etree.SubElement(joint, "child", link=frame.name).tail = "\n  "
        joint.tail = "\n"


def origin_of(joint: etree._Element) -> pin.SE3:
    """A URDF ``<joint>``'s ``<origin>`` as a placement ([m], rpy [rad]; identity when absent)."""
    element = joint.find("origin")
    xyz = np.zeros(3)
    rpy = np.zeros(3)
    if element is not None:
        xyz = np.array([float(v) for v in element.get("xyz", "0 0 0").split()])
        rpy = np.array([float(v) for v in element.get("rpy", "0 0 0").split()])
    return pin.SE3(pin.rpy.rpyToMatrix(rpy), xyz)


def _set_origin(joint: etree._Element, placement: pin.SE3) -> None:
    element = joint.find("origin")
    if element is None:
        element = etree.Element("origin")
        joint.insert(0, element)
    rpy = pin.rpy.matrixToRpy(placement.rotation)
    element.set("xyz", _numbers(placement.translation))
    element.set("rpy", _numbers(rpy))


def _numbers(values: np.ndarray) -> str:
    """Shortest exact text of each number; round-off residue below 1e-15 written as 0."""
    return " ".join(repr(float(v)) if abs(v) > 1e-15 else "0" for v in values)


def top_level_joints(root: etree._Element) -> dict[str, etree._Element]:
    """The ``<joint>`` elements directly under a URDF's ``<robot>``, by name."""
    return {j.get("name"): j for j in root.iter("joint") if j.getparent() is root}


def tool_chain(joints: dict[str, etree._Element], chain: Chain) -> list[etree._Element]:
    """Fixed joints from the last moving joint's link down to the end frame's link."""
    by_child = {j.find("child").get("link"): j for j in joints.values()}
    end = chain.end_frame
    link = joints[end].find("child").get("link") if end in joints else end
    last_link = joints[chain.joint_names[-1]].find("child").get("link")
    path = []
    while link != last_link:
        joint = by_child.get(link)
        if joint is None or joint.get("type") != "fixed":
            raise RobotError(f"cannot find the fixed joints from '{last_link}' to '{end}'")
        path.append(joint)
        link = joint.find("parent").get("link")
    return path[::-1]


def check_end_frame_writable(chain: Chain) -> None:
    """Refuse a chain whose end frame's correction has no fixed joint to go in: an end
    frame that is the last moving joint's own link (the URDF and its joint origins, the
    yaml, write it on the first fixed joint after that joint). Checked before a fit that
    exports either, not after it.

    Raises:
        RobotError: naming the end frame, its joint, and what to do.
    """
    joints = top_level_joints(etree.parse(str(chain.description.urdf)).getroot())
    if not tool_chain(joints, chain):
        raise RobotError(
            f"end frame '{chain.end_frame}' is the link of joint '{chain.joint_names[-1]}': a calibration moves the end "
            "frame, and the URDF (or yaml) has no fixed joint after that joint to hold it: add a fixed tool frame to "
            f"the URDF (a fixed joint from '{chain.end_frame}' to a new link) and calibrate at it (the DH table "
            "export of the dh and hayati models needs none)")


def corrected_origins(
    joints: dict[str, etree._Element], chain: Chain, deltas: Sequence[pin.SE3]
) -> dict[str, pin.SE3]:
    """Corrected ``<origin>`` of each chain joint and of the tool chain's first fixed joint.

    Args:
        joints: The URDF's joints by name (:func:`top_level_joints`).
        chain: The nominal chain.
        deltas: ``n_joints + 1`` transforms from a parameter model.

    Returns:
        Joint name -> origin relative to its parent link, base to end.

    Raises:
        RobotError: the end frame has a deviation but no fixed joint to carry it.
    """
    out = {name: origin_of(joints[name]) * delta for name, delta in zip(chain.joint_names, deltas[:-1], strict=True)}
    tool = tool_chain(joints, chain)
    end_delta = deltas[-1]
    if tool:
        rest = pin.SE3.Identity()
        for joint in tool[1:]:
            rest = rest * origin_of(joint)
        out[tool[0].get("name")] = origin_of(tool[0]) * rest * end_delta * rest.inverse()
    elif np.linalg.norm(pin.log6(end_delta).vector) > 1e-15:
        check_end_frame_writable(chain)
    return out


def calibrated_urdf(chain: Chain, deltas: Sequence[pin.SE3], robot_name: str | None = None,
                    notes: Sequence[str] = (), frames: Sequence[AddedFrame] = ()) -> bytes:
    """The bytes :func:`write_calibrated_urdf` writes: the chain's URDF with perturbed joint origins.

    UTF-8.

    Args:
        chain: The nominal robot chain.
        deltas: The perturbation of each joint placement and of the end frame.
        robot_name: The ``<robot name>`` to write; None: the URDF's own.
        notes: Lines written as comments before the root (what the data determined).
        frames: Frames of a sensor's set-up added as links on fixed joints (a camera, a board).

    Raises:
        RobotError: the end frame has a deviation but no fixed joint to carry it; an added
            frame whose name the URDF has.
    """
    tree = etree.parse(str(chain.description.urdf), etree.XMLParser(remove_blank_text=False))
    root = tree.getroot()
    joints = top_level_joints(root)
    for name, placement in corrected_origins(joints, chain, deltas).items():
        _set_origin(joints[name], placement)
    _add_frames(root, chain, frames)
    if robot_name:
        root.set("name", robot_name)
    for note in notes:  # "--" may not appear in an XML comment
        root.addprevious(etree.Comment(" " + note.replace("--", "- -") + " "))
    # Top-level comments one per line around the root (lxml keeps no text between them).
    nodes = [*reversed(list(root.itersiblings(preceding=True))), root, *root.itersiblings()]
    body = b"\n".join(etree.tostring(node, encoding="utf-8", with_tail=False) for node in nodes)
    return b'<?xml version="1.0" encoding="utf-8"?>\n' + body + b"\n"


def write_calibrated_urdf(
    chain: Chain, deltas: Sequence[pin.SE3], path: str | Path, robot_name: str | None = None,
    notes: Sequence[str] = (), frames: Sequence[AddedFrame] = (),
) -> Path:
    """Write the chain's URDF with perturbed joint origins.

    Args:
        chain: The nominal chain (its URDF is the source).
        deltas: ``n_joints + 1`` transforms from a parameter model.
        path: Output file.
        robot_name: New ``<robot name>``, or None to keep the source's.
        notes: Lines written as comments before the root (what the data determined).
        frames: Frames of a sensor's set-up added as links on fixed joints.

    Raises:
        RobotError: the end frame has a deviation but no fixed joint to carry it; an added
            frame whose name the URDF has.
    """
    data = calibrated_urdf(chain, deltas, robot_name, notes, frames)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_bytes(path, data)
    return path
