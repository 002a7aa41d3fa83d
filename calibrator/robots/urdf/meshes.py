"""Collision meshes a URDF names: found as ROS finds them, read with bounds."""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from calibrator.robots.description import (
    DescriptionError,
)
from calibrator.robots.urdf.chain import (
    MM_PER_M,
    Chain,
    numbers,
)

#: A collision mesh wider than this once scaled (mm) is no arm link's: a mesh in
#: millimetres without its scale, or a scale that would make the clearance
#: sweep sample its surface by the billion (``scale="300"``: gigabytes).
MAX_MESH_EXTENT_MM = 10_000.0
#: The largest collision mesh surface (m^2) the clearance sweep samples, every
#: :data:`SURFACE_SPACING_MM` (50 m^2: half a million points; a 2 x 2 x 3 m link has 32).
#: Faces folded on one another within the extent could otherwise ask for billions.
MAX_MESH_AREA_M2 = 50.0
#: The largest collision mesh file read (bytes).
MAX_MESH_BYTES = 64 * 2**20


class MeshMissing(Exception):
    """A collision mesh the URDF names and that cannot be found (its file name)."""


def mesh_file(urdf: Path, filename: str) -> Path | None:
    """The file a URDF's ``<mesh filename>`` names, where it can be found.

    ``package://pkg/rest`` is looked for as ROS finds it: in ``pkg`` beside
    the URDF's folder (the URDF in ``pkg/urdf/``), in a folder ``pkg`` in
    any folder above the URDF (a workspace), and in each folder of
    ``ROS_PACKAGE_PATH``. Other names are relative to the URDF's folder.
    """
    if not filename.startswith("package://"):
        found = urdf.parent / filename.removeprefix("file://")
        return found if found.is_file() else None
    package, _, rest = filename[len("package://") :].partition("/")
    roots = [p for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
    candidates = [urdf.parent.parent / rest]
    candidates += [up / package / rest for up in urdf.resolve().parents]
    candidates += [Path(root) / package / rest for root in roots]
    return next((c for c in candidates if c.is_file()), None)


def load_mesh(
    chain: Chain, shape: ET.Element, at: np.ndarray, where: str
) -> tuple[np.ndarray, np.ndarray] | None:
    """A ``<mesh>``'s vertices in the link frame (mm) and faces, or None if it has none."""
    filename = str(shape.get("filename") or "")
    found = mesh_file(chain.path, filename)
    if found is None:
        raise MeshMissing(filename)
    import trimesh

    # The scale first: a bad one is refused before the mesh file is even read.
    scale = numbers(shape.get("scale"), 3, (1.0, 1.0, 1.0), f"{where} mesh scale")
    if not np.all(np.abs(scale) > 0):
        raise DescriptionError(f"{where}: mesh scale {shape.get('scale')!r} has a zero factor")
    size = found.stat().st_size
    if size > MAX_MESH_BYTES:
        raise DescriptionError(
            f"{where}: mesh {found.name} is {size / 2**20:.0f} MiB, more than the "
            f"{MAX_MESH_BYTES // 2**20} MiB a collision mesh is read up to"
        )
    try:
        mesh = trimesh.load(found, force="mesh")
    except Exception as exc:  # trimesh raises many kinds for bad files
        raise DescriptionError(f"{where}: cannot read mesh {found.name} ({exc})") from None
    points = np.asarray(getattr(mesh, "vertices", []), dtype=float)
    faces = np.asarray(getattr(mesh, "faces", np.empty((0, 3))), dtype=int).reshape(-1, 3)
    if points.ndim != 2 or len(points) < 3 or not len(faces):
        # A file trimesh opens but finds nothing in (not a mesh, a format it does not
        # know): named, never dropped as if the link had no collision geometry.
        raise DescriptionError(f"{where}: mesh {found.name} holds no triangles that could be read")
    if not np.all(np.isfinite(points)):
        raise DescriptionError(f"{where}: mesh {found.name} has vertices that are not numbers")
    # The extent from the file's numbers and the scale, compared before anything
    # is scaled (a scale of 1e308 would overflow into infinities).
    ratio = float(
        np.max(np.ptp(points, axis=0) * (np.abs(scale) * (MM_PER_M / MAX_MESH_EXTENT_MM)))
    )
    if not ratio <= 1.0:
        spans = (
            f"{ratio * (MAX_MESH_EXTENT_MM / MM_PER_M):.4g}"
            if np.isfinite(ratio)
            else "beyond 1e300"
        )
        raise DescriptionError(
            f"{where}: mesh {found.name} spans {spans} m once scaled: no arm link's "
            '(URDF meshes are metres; a mesh in millimetres needs scale="0.001 0.001 0.001")'
        )
    if faces.min() < 0 or faces.max() >= len(points):
        raise DescriptionError(f"{where}: mesh {found.name} has faces of vertices it does not hold")
    points = points * scale * MM_PER_M
    corners = points[faces]
    area_m2 = 0.5e-6 * float(
        np.linalg.norm(
            np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
        ).sum()
    )
    if area_m2 > MAX_MESH_AREA_M2:
        raise DescriptionError(
            f"{where}: mesh {found.name} has {area_m2:.4g} m^2 of surface once scaled, more "
            f"than any arm link's ({MAX_MESH_AREA_M2:g} m^2)"
        )
    points = points @ at[:3, :3].T + at[:3, 3]
    return points, faces
