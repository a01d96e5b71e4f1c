"""The terrain mesh as a file: DEM -> ``trimesh.Trimesh`` -> PLY / OBJ / GLB, and a
Mitsuba 3 scene XML that loads it as it is.

The mesh is the renderer's own (:func:`~skyrender.render.terrain.terrain_mesh_arrays`:
a vertex per cell centre, two triangles per quad split south-west to north-east). By
default vertices are local to the DEM centre (what the float32 renderer uses: the
offset is written in the XML's comment and the mesh's metadata); ``world=True`` writes
world coordinates (float64 in the file formats that keep it). ``curvature=True`` lowers
the terrain by the earth curvature and refraction drop seen from the DEM centre.
"""

from __future__ import annotations

import os

from ..dem import DEM
from ..errors import InputError
from .terrain import terrain_trimesh

MESH_SUFFIXES = (".ply", ".obj", ".glb")


def mitsuba_scene_xml(mesh_file: str) -> str:
    """A Mitsuba 3 scene holding the mesh file (PLY or OBJ, path relative to the XML)."""
    kind = os.path.splitext(mesh_file)[1].lower().lstrip(".")
    return (f'<scene version="3.0.0">\n'
            f'    <shape type="{kind}">\n'
            f'        <string name="filename" value="{os.path.basename(mesh_file)}"/>\n'
            f'    </shape>\n'
            f'</scene>\n')


def export_terrain(dem: DEM, out: str, *, world: bool = False, curvature: bool = False) -> list[str]:
    """Write the terrain mesh to ``out`` (.ply, .obj or .glb) and, for PLY and OBJ, the
    Mitsuba scene XML beside it (same name, ``.xml``). Returns the paths written."""
    suffix = os.path.splitext(out)[1].lower()
    if suffix not in MESH_SUFFIXES:
        raise InputError(f"--out must end in one of {', '.join(MESH_SUFFIXES)}, got {out!r}")
    mesh = terrain_trimesh(dem, world=world, curvature=curvature)
    written = [out]
    try:
        mesh.export(out)
        if suffix in (".ply", ".obj"):
            xml = os.path.splitext(out)[0] + ".xml"
            with open(xml, "w") as f:
                f.write(mitsuba_scene_xml(out))
            written.append(xml)
    except OSError as exc:
        raise InputError(f"cannot write {out}: {exc.strerror or exc}") from None
    return written
