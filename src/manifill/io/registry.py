"""Meshes and fields on disk: one registry of formats, what each holds and which readers see its fields.

Every mesh format is one entry of :data:`MESH_FORMATS`: how manifill reads and writes
it, whether it holds named per-vertex fields, which common readers see those
fields, and whether reading it keeps the file's vertex numbering (STL does not:
its reader merges the corners of its triangles). :func:`read_mesh_file` and
:func:`write_mesh` dispatch on the extension; FreeSurfer surfaces (``lh.pial``,
``rh.white``: no telling extension) are recognised by their first bytes.

Fields keep their names where the format allows any text (VTU, VTP, VTI); PLY
and legacy VTK store plain words, so there other characters become ``_``
(:func:`stored_names` says what was renamed). A name no format can store (empty,
or with line breaks or other control characters) is refused. Mask and label
arrays have one naming scheme everywhere: :data:`SAMPLE_MASK`,
:data:`CURVE_MASK`, :data:`PATCH_LABEL`, :data:`BOUNDARY_MASK`.

Every write is atomic (:func:`manifill.io.files.atomic_path`); every read of a
damaged file ends in one :class:`~manifill.errors.ReadError` naming the file.
Samples and per-vertex values are read and written by :mod:`manifill.io.samples`.
"""

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ManifillError, ReadError, WriteError
from .files import atomic_path, check_count, check_input_file, quiet, reading, suffix
from .samples import SAMPLE_FORMATS, VALUE_FORMATS, read_samples, write_values

__all__ = ["MESH_FORMATS", "MeshFormat", "MeshFile", "SAMPLE_MASK", "CURVE_MASK", "PATCH_LABEL", "BOUNDARY_MASK",
           "RESERVED_NAMES", "read_mesh", "read_mesh_file", "write_mesh", "stored_names", "check_field_names",
           "format_note", "write_cells", "atomic_path", "read_samples", "write_values", "SAMPLE_FORMATS",
           "VALUE_FORMATS"]

#: 1 where a vertex (or voxel) holds a sample
SAMPLE_MASK = "sample_mask"
#: 1 on the partition curves (their values were fixed before the harmonic fill)
CURVE_MASK = "curve_mask"
#: the patch of every vertex, -1 on the curves
PATCH_LABEL = "patch_label"
#: 1 on the boundary of a solid (tet vertices on its surface; voxels of D, filled from the surface)
BOUNDARY_MASK = "boundary_mask"
RESERVED_NAMES = (SAMPLE_MASK, CURVE_MASK, PATCH_LABEL, BOUNDARY_MASK)


@dataclass(frozen=True)
class MeshFormat:
    """One mesh format: how it is read and written, and what it keeps.

    Attributes
    ----------
    name : str
        Its usual name.
    reader : str
        Which reader parses it.
    write : bool
        manifill writes it.
    fields : bool
        It holds named per-vertex fields.
    seen_by : tuple of str
        Common readers that show those fields (``meshio``, ``pyvista``: VTK and
        ParaView read what pyvista reads).
    vertex_numbering : bool
        Reading keeps the file's vertex numbers (samples may refer to them).
    extra : str or None
        The extra it needs (``neuro``: nibabel).
    """

    name: str
    reader: str
    write: bool
    fields: bool
    seen_by: tuple = ()
    vertex_numbering: bool = True
    extra: str = None


MESH_FORMATS = {
    ".vtu": MeshFormat("VTU", "meshio", True, True, ("meshio", "pyvista")),
    ".vtp": MeshFormat("VTP", "vtkxml", True, True, ("pyvista",)),
    ".vtk": MeshFormat("legacy VTK", "legacy", True, True, ("meshio", "pyvista")),
    ".ply": MeshFormat("PLY", "meshio", True, True, ("meshio",)),
    ".off": MeshFormat("OFF", "meshio", True, False),
    ".obj": MeshFormat("OBJ", "meshio", True, False),
    ".stl": MeshFormat("STL", "meshio", True, False, vertex_numbering=False),
    ".gii": MeshFormat("GIfTI", "gifti", False, True, ("nibabel",), extra="neuro"),
}
#: FreeSurfer triangle surfaces, recognised by their magic number
FREESURFER = MeshFormat("FreeSurfer surface", "freesurfer", False, False, extra="neuro")
_READERS_SHOWN = {"meshio": "meshio", "pyvista": "pyvista/VTK/ParaView", "nibabel": "nibabel"}


@dataclass
class MeshFile:
    """A surface read from a file.

    Attributes
    ----------
    V : (n, 3) float64 numpy array
    F : (m, 3) int64 numpy array
    point_data : dict of str to (n,) or (n, p) numpy array
        The per-vertex arrays stored with it.
    format : MeshFormat
    path : Path
    """

    V: np.ndarray
    F: np.ndarray
    point_data: dict = field(default_factory=dict)
    format: MeshFormat = None
    path: Path = None

    @property
    def vertex_numbering(self):
        """None if vertex numbers in sample files refer to this mesh's vertices, else why they cannot."""
        if self.format is None or self.format.vertex_numbering:
            return None
        return (f"{self.path.name}: {self.format.name} does not keep vertex numbers (its reader merges the corners "
                f"of the triangles), so samples given by vertex index would land on other vertices")


def mesh_format(path, *, writing=False):
    """The :class:`MeshFormat` of ``path`` (by extension, else FreeSurfer by magic number).

    Raises
    ------
    ReadError or WriteError
        An extension manifill does not read (or write).
    """
    ext = Path(path).suffix.lower()
    fmt = MESH_FORMATS.get(ext)
    if writing:
        if fmt is None or not fmt.write:
            raise WriteError(f"{Path(path).name}: cannot write '{ext or '(no extension)'}' meshes; use one of "
                             f"{', '.join(e for e, f in MESH_FORMATS.items() if f.write)}")
        return fmt
    if fmt is None:
        from .neuro import sniff

        if Path(path).is_file() and sniff(path) == "freesurfer-surface":
            return FREESURFER
        raise ReadError(f"{Path(path).name}: cannot read '{ext or '(no extension)'}' files; use one of "
                        f"{', '.join(MESH_FORMATS)} or a FreeSurfer surface")
    return fmt


def read_mesh_file(path):
    """Read a triangle surface and the per-vertex fields stored with it.

    Formats: VTU, VTP, legacy VTK (POLYDATA or UNSTRUCTURED_GRID), PLY, OFF, OBJ,
    STL, GIfTI ``.surf.gii`` and FreeSurfer surfaces (the last two need the
    ``[neuro]`` extra). Quads and polygons are split into triangles; other cells
    are ignored.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    MeshFile

    Raises
    ------
    ReadError
        A missing file, an unknown extension, a damaged file (one line naming
        the file), or a file without triangles.
    """
    path = Path(path)
    fmt = mesh_format(path)
    check_input_file(path)
    if fmt.reader == "meshio":
        V, F, point_data = _read_meshio(path, fmt)
    elif fmt.reader == "vtkxml":
        from .vtkxml import read_polydata

        V, F, point_data = read_polydata(path)
    elif fmt.reader == "legacy":
        from .vtklegacy import read_legacy

        V, cells, point_data = read_legacy(path)
        F = cells.get("triangle")
        if F is None or len(F) == 0:
            _no_triangles(path, sorted(k for k, c in cells.items() if len(c)))
    elif fmt.reader == "gifti":
        from .neuro import read_gifti

        V, F, point_data = read_gifti(path)
    else:
        from .neuro import read_freesurfer_surface

        V, F = read_freesurfer_surface(path)
        point_data = {}
    V = np.asarray(V, dtype=np.float64)
    if V.ndim == 2 and V.shape[1] == 2:
        V = np.column_stack([V, np.zeros(len(V))])
    F = np.asarray(F, dtype=np.int64)
    check_cells(path, V, F, "face")
    point_data = {str(k): np.asarray(a) for k, a in point_data.items() if np.shape(a)[:1] == (len(V),)}
    return MeshFile(V, F, point_data, fmt, path)


def check_cells(path, V, C, what):
    """Refuse points that are not ``(n, 3)`` or cells with a vertex index outside ``0..n-1`` (a damaged file).

    Parameters
    ----------
    path : Path
        The file read (for the message).
    V : (n, 3) float64 numpy array
    C : (m, k) int64 numpy array
    what : str
        What a cell is (``'face'``, ``'tetrahedron'``).

    Raises
    ------
    ReadError
        Points of another shape, or a cell using a vertex the file does not have.
    """
    if V.ndim != 2 or V.shape[1] != 3:
        raise ReadError(f"{path.name}: the points have shape {V.shape}, not (n, 3); the file is damaged, check it")
    bad = np.flatnonzero(((C < 0) | (C >= len(V))).any(axis=1)) if C.ndim == 2 else []
    if len(bad):
        i = int(bad[0])
        v = int(C[i][(C[i] < 0) | (C[i] >= len(V))][0])
        raise ReadError(f"{path.name}: {what} {i} uses vertex {v} but the file has {len(V):,} vertices "
                        f"(0..{len(V) - 1}); the file is damaged, check it")


def read_mesh(path):
    """Read a triangle mesh (see :func:`read_mesh_file` for the formats).

    Parameters
    ----------
    path : str or Path
        The file; its extension selects the format.

    Returns
    -------
    V : (n, 3) float64 numpy array
    F : (m, 3) int64 numpy array

    Raises
    ------
    ReadError
        A missing file, an unknown extension, a damaged file, or a file
        without triangles or quads.
    """
    m = read_mesh_file(path)
    return m.V, m.F


def _no_triangles(path, kinds):
    hint = "; for a solid of tetrahedra use 'manifill volume'" if "tetra" in kinds else ""
    raise ReadError(f"{Path(path).name}: holds no triangles (cells found: {', '.join(kinds) or 'none'}){hint}; "
                    f"pass a surface mesh")


def _read_meshio(path, fmt):
    """A surface through meshio's reader of one format, damaged files as one-line :class:`ReadError`."""
    import meshio

    ext = path.suffix.lower()
    if ext == ".off":
        _check_off_header(path)
    elif ext == ".ply":
        _check_ply_header(path)
    with reading(path, f"{fmt.name} mesh"):
        mesh = getattr(meshio, ext[1:]).read(str(path))  # not meshio.read: it sys.exit()s on bad files
        faces = []
        for block in mesh.cells:
            data = np.asarray(block.data)
            if block.type == "triangle":
                faces.append(data.reshape(-1, 3))
            elif block.type == "quad":
                q = data.reshape(-1, 4)
                faces.append(np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]]))
            elif block.type.startswith("polygon") and data.ndim == 2 and data.shape[1] > 4:
                faces += [data[:, [0, j, j + 1]] for j in range(1, data.shape[1] - 1)]
        if not faces:
            _no_triangles(path, sorted({b.type for b in mesh.cells}))
        F = np.concatenate(faces)
        if F.dtype.kind not in "iu":
            raise ReadError(f"{path.name}: the faces are stored as {F.dtype}, not integers; check the file")
        V = np.asarray(mesh.points, dtype=np.float64)
        point_data = {k: np.asarray(v) for k, v in mesh.point_data.items()}
    return V, F.astype(np.int64), point_data


def _check_off_header(path):
    """Reject an OFF file without its counts line, or with counts the file cannot hold."""
    words = []
    try:
        with open(path, "rb") as fh:
            for raw in fh:
                line = raw.split(b"#")[0].strip()
                if line:
                    words.extend(line.split())
                if len(words) >= 4:
                    break
    except OSError as exc:
        raise ReadError(f"{path.name}: could not read ({exc})") from None
    counts = None
    if len(words) >= 4 and words[0].endswith(b"OFF"):
        try:
            counts = [int(w) for w in words[1:4]]
        except ValueError:
            counts = None
    if counts is None:
        raise ReadError(f"{path.name}: not a readable OFF mesh (no 'OFF' line followed by vertex, face "
                        f"and edge counts); check the file")
    check_count(counts[0], path, "vertices", bytes_each=6)
    check_count(counts[1], path, "faces", bytes_each=8)


#: bytes of one PLY property value in a binary file
_PLY_SIZES = {"char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2, "int16": 2, "uint16": 2,
              "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4, "float32": 4, "int64": 8, "uint64": 8,
              "double": 8, "float64": 8}
_PLY_END = re.compile(rb"^[ \t\r\v\f]*end_header[ \t\r\v\f]*$", re.M)


def _check_ply_header(path):
    """Reject a PLY file whose header never ends (meshio would wait for it forever) or whose counts lie."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(1 << 16)
    except OSError as exc:
        raise ReadError(f"{path.name}: could not read ({exc})") from None
    end = _PLY_END.search(head)
    if end is None:
        raise ReadError(f"{path.name}: not a readable PLY mesh (no 'end_header' line closes its header); the file "
                        f"is truncated or damaged, check it")
    lines = [line.split() for line in head[:end.start()].decode("latin-1").splitlines()]
    binary = any(w[:1] == ["format"] and len(w) > 1 and w[1].startswith("binary") for w in lines)
    elements = []  # [name, count, fewest bytes of one]
    for w in lines:
        if w[:1] == ["element"] and len(w) >= 3:
            if not re.fullmatch(r"[0-9]{1,30}", w[2]):
                raise ReadError(f"{path.name}: the header line 'element {w[1]} {w[2][:40]}' gives no count; the "
                                f"file is damaged, check it")
            elements.append([w[1], int(w[2]), 0])
        elif w[:1] == ["property"] and elements:
            kind = w[2] if len(w) > 2 and w[1] == "list" else (w[1] if len(w) > 1 else "")
            elements[-1][2] += _PLY_SIZES.get(kind, 1) if binary else 2
    for name, n, each in elements:
        check_count(n, path, f"'{name}' elements", bytes_each=max(each, 1), start=end.end() + 1)


_CONTROL = re.compile(r"[\x00-\x1f\x7f]")


def check_field_names(names, path=None, *, masks=True):
    """Refuse field names that no format can store, or that a mask of manifill's uses.

    Parameters
    ----------
    names : iterable of str
    path : str or Path, optional
        The output (for the message).
    masks : bool, optional
        Also refuse :data:`RESERVED_NAMES` (the output gets those masks).

    Raises
    ------
    WriteError
        An empty name, a name with a line break or another control character,
        a comma or quote for a CSV ``path``, or a reserved name; the message
        says how to rename it.
    """
    where = f"{Path(path).name}: " if path is not None else ""
    for name in names:
        name = str(name)
        if not name.strip():
            raise WriteError(f"{where}a field has an empty name; give every value column a name")
        if _CONTROL.search(name):
            raise WriteError(f"{where}field name {name!r} holds a line break or control character, which no mesh "
                             f"format can store; rename the value column")
        if path is not None and Path(path).suffix.lower() == ".csv" and ("," in name or '"' in name):
            raise WriteError(f"{where}field name {name!r} holds a comma or quote, which a CSV header cannot hold; "
                             f"rename the value column or write .npy")
        if masks and name in RESERVED_NAMES:
            raise WriteError(f"{where}field name {name!r} is the name of manifill's mask in the output; rename the "
                             f"value column")


def stored_names(names, ext):
    """The name each field gets in a file of extension ``ext``.

    VTU, VTP and VTI keep any text; PLY, legacy VTK and Gmsh hold plain ASCII
    words, so there every other character becomes ``_`` (and PLY's ``x``, ``y``, ``z``, a
    leading digit or a repeated name get a ``field_`` prefix).

    Parameters
    ----------
    names : iterable of str
    ext : str
        The extension, with its dot.

    Returns
    -------
    dict of str to str

    Raises
    ------
    WriteError
        As :func:`check_field_names` (reserved names allowed).

    Examples
    --------
    >>> stored_names(["temp (K)", "x"], ".ply")
    {'temp (K)': 'temp__K_', 'x': 'field_x'}
    >>> stored_names(["temp (K)"], ".vtu")
    {'temp (K)': 'temp (K)'}
    """
    names = [str(n) for n in names]
    check_field_names(names, masks=False)
    if ext not in (".ply", ".vtk", ".msh"):
        return {n: n for n in names}
    out, taken = {}, set()
    for name in names:
        key = re.sub(r"[^0-9A-Za-z_]", "_", name)
        if ext == ".ply" and (key in ("x", "y", "z") or key[0].isdigit()):
            key = f"field_{key}"
        if ext == ".vtk" and (key.lower().startswith("metadata") or key == "NULL_ARRAY"):
            key = f"field_{key}"  # VTK's reader takes such a line for a section of its own
        while key in taken:
            key = f"field_{key}"
        taken.add(key)
        out[name] = key
    return out


def format_note(path):
    """One line telling which common readers will not see the fields of ``path`` (None if all do).

    Examples
    --------
    >>> print(format_note("out.ply"))
    note: out.ply: pyvista/VTK/ParaView do not show PLY files' named fields (meshio does); write .vtu for every reader
    """
    fmt = MESH_FORMATS.get(Path(path).suffix.lower())
    if fmt is None or not fmt.fields:
        return None
    missing = [r for r in ("meshio", "pyvista") if r not in fmt.seen_by]
    if not missing:
        return None
    shown = " and ".join(_READERS_SHOWN[r] for r in missing)
    seen = ", ".join(_READERS_SHOWN[r] for r in fmt.seen_by)
    verb = "does" if len(fmt.seen_by) == 1 else "do"
    return (f"note: {Path(path).name}: {shown} do not show {fmt.name} files' named fields ({seen} {verb}); write "
            f".vtu for every reader")


def _field_array(name, arr, n):
    arr = np.asarray(arr)
    if np.iscomplexobj(arr) or not (arr.dtype == bool or np.issubdtype(arr.dtype, np.number)):
        raise WriteError(f"field {name!r} is {arr.dtype}; pass real numbers")
    if arr.ndim not in (1, 2):
        raise WriteError(f"field {name!r} has shape {arr.shape}; pass (n,) or (n, p) per-vertex values")
    if arr.shape[0] != n:
        raise WriteError(f"field {name!r} has {arr.shape[0]} values for {n} vertices; pass one per vertex")
    if arr.dtype == bool:
        return arr.astype(np.uint8)
    if np.issubdtype(arr.dtype, np.integer):
        i32 = np.iinfo(np.int32)
        if arr.size and (int(arr.min()) < i32.min or int(arr.max()) > i32.max):
            raise WriteError(f"field {name!r} holds integers beyond 32 bits; store it as floats")
        return arr.astype(np.int32)
    return arr.astype(np.float64)


def write_mesh(path, V, F, point_data=None):
    """Write a triangle mesh with named per-vertex fields, atomically.

    Parameters
    ----------
    path : str or Path
        Destination; the extension selects the format. Fields need VTU, VTP,
        legacy VTK or PLY (see :data:`MESH_FORMATS` for who reads them back).
    V : (n, 3) numpy array, or a mesh object with ``F=None``
        Vertex positions.
    F : (m, 3) numpy array of int
        Triangles.
    point_data : dict of str to (n,) or (n, p) numpy array, optional
        Named fields. A ``(n, p)`` field is one ``p``-component array in VTU,
        VTP and VTK, and ``p`` scalar fields ``name_0 ... name_{p-1}`` in PLY.
        Boolean fields (masks) are stored as 0/1 bytes, integer fields (labels)
        as 32-bit integers, the rest as float64.

    Returns
    -------
    dict of str to str
        The name each field was written under (see :func:`stored_names`).

    Raises
    ------
    WriteError
        Unknown extension, fields for a format that cannot hold them, names no
        format can store, a missing folder, or a failure while writing
        (nothing is left behind).
    """
    from ..mesh.objects import mesh_arrays
    from ..validate import as_mesh

    fmt = mesh_format(path, writing=True)
    point_data = dict(point_data or {})
    if point_data and not fmt.fields:
        raise WriteError(
            f"{Path(path).name}: {fmt.name} cannot store per-vertex fields; write .vtu, .vtp, .vtk or .ply "
            f"(or the values alone as .csv/.npy)"
        )
    try:
        V, F = as_mesh(*mesh_arrays(V, F), allow_degenerate=True, allow_unreferenced=True, allow_unwelded=True)
    except ManifillError as exc:
        raise WriteError(f"{Path(path).name}: not written, the mesh is malformed: {exc}") from None
    return write_cells(path, V, F, point_data)


def write_cells(path, V, C, point_data=None):
    """Write validated triangles or tetrahedra with named per-vertex fields, atomically, by extension.

    Parameters
    ----------
    path : str or Path
        ``.vtu``, ``.vtp`` (triangles), ``.vtk``, ``.ply``, ``.off``, ``.obj``,
        ``.stl`` (triangles, no fields there) or ``.msh`` (Gmsh).
    V : (n, 3) float64 numpy array
    C : (m, 3) or (m, 4) int64 numpy array
    point_data : dict of str to (n,) or (n, p) numpy array, optional

    Returns
    -------
    dict of str to str
        The name each field was written under.

    Raises
    ------
    WriteError
        As :func:`write_mesh`.
    """
    ext = Path(path).suffix.lower()
    kind = "triangle" if C.shape[1] == 3 else "tetra"
    names = stored_names(point_data or {}, ext)
    out = {}
    for name, arr in (point_data or {}).items():
        arr = _field_array(name, arr, len(V))
        key = names[str(name)]
        if arr.ndim == 2 and ext == ".ply":
            for j in range(arr.shape[1]):
                out[f"{key}_{j}"] = np.ascontiguousarray(arr[:, j])
        else:
            out[key] = arr
    if ext == ".vtp":
        from .vtkxml import write_polydata

        write_polydata(path, V, C, out)
    elif ext == ".vtu":
        from .vtkxml import write_unstructured

        write_unstructured(path, V, C, out)
    elif ext == ".vtk":
        from .vtklegacy import write_legacy

        write_legacy(path, V, kind, C, out)
    else:
        _write_meshio(path, V, [(kind, C.astype(np.int32))], out, "gmsh22" if ext == ".msh" else ext[1:])
    return names


def _write_meshio(path, V, cells, point_data, fmt):
    import meshio

    mesh = meshio.Mesh(np.asarray(V, dtype=np.float64), cells, point_data=point_data)
    with atomic_path(path) as tmp:
        try:
            with quiet():  # meshio prints its notes (e.g. Gmsh's "Appending zeros") itself
                meshio.write(tmp, mesh, file_format=fmt)
        except (meshio.WriteError, ValueError, KeyError, TypeError, OSError) as exc:
            raise WriteError(f"{Path(path).name}: could not write ({exc}); check the path and the fields") from None



def meshio_read(path, ext, fmt):
    """meshio's reader of one format, with a damaged file as one-line :class:`ReadError`."""
    import meshio

    with reading(path, f"{ext[1:].upper()} mesh"):
        return getattr(meshio, fmt).read(str(path))  # not meshio.read: it sys.exit()s on bad files
