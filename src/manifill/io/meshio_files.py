"""The files read and written through meshio (VTU reading; PLY, OFF, OBJ, STL, Gmsh), guarded against damage.

meshio's own readers loop forever or allocate for a lying count on some damaged
files (an OFF header without counts, a PLY header that never ends), and
``meshio.read`` calls ``sys.exit`` on an unparsable file: each header is checked
first, each format's reader is called directly, and every failure is one
:class:`~manifill.errors.ReadError` naming the file. Writes are atomic.
"""

import re
from pathlib import Path

import numpy as np

from ..errors import ReadError, WriteError
from .files import atomic_path, check_count, no_triangles, quiet, reading

__all__ = ["read_meshio", "write_meshio", "meshio_read"]


def read_meshio(path, fmt):
    """A surface through meshio's reader of one format, damaged files as one-line :class:`ReadError`.

    Parameters
    ----------
    path : Path
        A ``.vtu``, ``.ply``, ``.off``, ``.obj`` or ``.stl`` file.
    fmt : manifill.io.registry.MeshFormat
        Its format (for the messages).

    Returns
    -------
    V : (n, 3) float64 numpy array
    F : (m, 3) int64 numpy array
        Triangles, quads and polygons split into triangles.
    point_data : dict of str to numpy array

    Raises
    ------
    ReadError
        A damaged file, or one without triangles.
    """
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
            no_triangles(path, sorted({b.type for b in mesh.cells}))
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


def write_meshio(path, V, cells, point_data, fmt):
    """Write cells and point fields through meshio's writer of format ``fmt``, atomically.

    Parameters
    ----------
    path : str or Path
    V : (n, 3) array_like of float
    cells : list of (str, (m, k) numpy array)
        meshio's cell blocks, e.g. ``[("triangle", F)]``.
    point_data : dict of str to numpy array
    fmt : str
        meshio's format name (``"ply"``, ``"gmsh22"``).

    Raises
    ------
    WriteError
        meshio fails (nothing is left behind).
    """
    import meshio

    mesh = meshio.Mesh(np.asarray(V, dtype=np.float64), cells, point_data=point_data)
    with atomic_path(path) as tmp:
        try:
            with quiet():  # meshio prints its notes (e.g. Gmsh's "Appending zeros") itself
                meshio.write(tmp, mesh, file_format=fmt)
        except (meshio.WriteError, ValueError, KeyError, TypeError, OSError) as exc:
            raise WriteError(f"{Path(path).name}: could not write ({exc}); check the path and the fields") from None


def meshio_read(path, ext, fmt):
    """meshio's reader of one format, with a damaged file as one-line :class:`ReadError`.

    Parameters
    ----------
    path : Path
    ext : str
        The extension (for the message).
    fmt : str
        meshio's reader module (``"gmsh"``, ``"vtu"``).

    Returns
    -------
    meshio.Mesh
    """
    import meshio

    with reading(path, f"{ext[1:].upper()} mesh"):
        return getattr(meshio, fmt).read(str(path))  # not meshio.read: it sys.exit()s on bad files
