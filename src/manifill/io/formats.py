"""The one registry of file formats: every suffix manifill reads or writes, its kind, reader, writer and what it keeps.

Each format module registers its formats (:func:`register_format`): meshes and point clouds in
:mod:`manifill.io.mesh_formats`, samples and values in :mod:`manifill.io.sample_formats`, tetrahedra and grids in
:mod:`manifill.io.solids`, time series in :mod:`manifill.io.series_write`, barriers in :mod:`manifill.io.points`.
Reading and writing look a path up here (:func:`find_format`, :func:`lookup`) and call the format's ``read`` or
``write``; the tables other modules show (``MESH_FORMATS``, ``SAMPLE_FORMATS`` ...) are views of it
(:class:`FormatView`). No code outside this module compares a suffix with a literal (a test greps for it): what
differs between formats is an attribute of :class:`Format`.

The kinds:

- ``mesh``: a triangle surface and its named per-vertex fields; ``points``: a point cloud written as vertex cells;
- ``samples``: sample values at vertices or positions; ``values``: per-vertex values alone;
- ``tets``: a tetrahedral mesh; ``grid``: voxel values;
- ``series``: a field over time; ``barriers``: lines the field must not cross;
- ``stations``: stations on the globe and the globe's field (:mod:`manifill.adapters.globe`, registered when it
  loads); ``manifest``: a batch's jobs (:mod:`manifill.cluster.manifest`, likewise).

Examples
--------
>>> import manifill.io  # the format modules register on import
>>> f = find_format("mesh", "scalp.VTU")
>>> f.name, f.fields, "pyvista" in f.seen_by
('VTU', True, True)
>>> sorted(formats_of("tets"))
['.msh', '.vtk', '.vtu']
>>> find_format("mesh", "brain.nii.gz") is None
True
"""

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from ..errors import ReadError, WriteError

__all__ = ["KINDS", "Format", "register_format", "suffix_of", "find_format", "lookup", "formats_of", "FormatView",
           "suffix_list", "written_as"]

KINDS = ("mesh", "points", "samples", "values", "tets", "grid", "series", "barriers", "stations", "manifest")


@dataclass(frozen=True)
class Format:
    """One file format of one kind.

    Attributes
    ----------
    name : str
        Its usual name (for messages).
    kind : str
        One of :data:`KINDS`.
    suffixes : tuple of str
        Its lower-case suffixes (``.mgh.gz``: two of them).
    read, write : callable or None
        Its reader and writer; the signature is the kind's (the module that registers the kind says).
    fields : bool
        It holds named per-vertex fields (meshes) or several named fields (values).
    seen_by : tuple of str
        Common readers that show those fields (``meshio``, ``pyvista``, ``nibabel``).
    cells : bool
        It holds cells (faces, tetrahedra); False: points alone (``.xyz``, a CSV of ``x,y,z``).
    vertex_numbering : bool
        Reading keeps the file's vertex numbers (STL's reader merges the corners of its triangles).
    columns : bool
        A ``(n, p)`` field is stored as ``p`` scalar columns ``name_0 ...`` (PLY), not one ``p``-component array.
    vectors : bool
        It stores a 3-component field as one vector (VTK's files, which ParaView draws as glyphs).
    cell_fields : bool
        It stores named per-cell fields too (VTK's files: a vector field's face vectors).
    text : bool
        A text table (CSV): a field's name cannot hold a comma or a quote.
    plain_names : bool
        Field names are plain ASCII words there (PLY, legacy VTK, Gmsh): other characters become ``_``.
    reserved : callable or None
        ``name -> bool``: a name its reader would take for something else (prefixed ``field_`` when written).
    folder : bool
        A series: its steps are files in a folder ``<stem>/`` beside it (``.pvd``).
    beside : tuple of str
        What else writing it makes beside it, as names with ``{stem}`` (``.xdmf``: ``{stem}.h5``; ``.pvd``: the
        folder ``{stem}``), for what a batch's job writes.
    times : bool
        A series: it stores each step's time (``.npy`` does not: reading gives ``0 .. T-1``).
    static : bool
        A series: it stores static fields beside the steps (``static=``).
    needs_steps : bool
        A series: the number of steps must be given up front (``steps=T``).
    container : str or None
        The file is a ``"zip"`` archive (``.npz``) or ``"gzip"`` stream (``.mgz``) by design (a ZIP given for
        another format is refused as such).
    exact : bool
        It keeps float64 values (GIfTI keeps float32, what Workbench reads).
    extra : str or None
        The extra it needs (``neuro``: nibabel; ``series``: h5py).
    meshio : str or None
        meshio's name of it, where meshio reads or writes it.
    """

    name: str
    kind: str
    suffixes: tuple
    read: object = None
    write: object = None
    fields: bool = False
    seen_by: tuple = ()
    cells: bool = True
    vertex_numbering: bool = True
    columns: bool = False
    vectors: bool = False
    cell_fields: bool = False
    text: bool = False
    plain_names: bool = False
    reserved: object = None
    folder: bool = False
    beside: tuple = ()
    times: bool = False
    static: bool = False
    needs_steps: bool = False
    exact: bool = True
    container: str | None = None
    extra: str | None = None
    meshio: str | None = None


_FORMATS: dict = {}


def register_format(fmt):
    """Add ``fmt`` under each of its suffixes for its kind (a later registration of one suffix replaces it)."""
    if fmt.kind not in KINDS:
        raise ValueError(f"kind {fmt.kind!r} is not one of {', '.join(KINDS)}")
    for s in fmt.suffixes:
        if s != s.lower() or not s.startswith("."):
            raise ValueError(f"suffix {s!r} is not a lower-case '.ext'")
        _FORMATS[(fmt.kind, s)] = fmt
    return fmt


def suffix_of(path):
    """The lower-case suffix of ``path``, two of them for a compressed file (``lh.thickness.mgh.gz``: ``.mgh.gz``).

    Examples
    --------
    >>> suffix_of("a/B.PLY"), suffix_of("x.mgh.gz"), suffix_of("lh.pial")
    ('.ply', '.mgh.gz', '.pial')
    """
    p = Path(path)
    ext = p.suffix.lower()
    if ext == ".gz" and len(p.suffixes) > 1:
        return "".join(p.suffixes[-2:]).lower()
    return ext


def find_format(kind, path, *, writing=False):
    """The :class:`Format` of ``path`` as a ``kind``, or None (also None when ``writing`` and it has no writer)."""
    fmt = _FORMATS.get((kind, suffix_of(path)))
    if fmt is None or (writing and fmt.write is None) or (not writing and fmt.read is None and fmt.write is None):
        return None
    return fmt


def formats_of(kind, *, writing=False, reading=False):
    """The formats of one kind, suffix -> :class:`Format` in registration order (those with a writer or reader)."""
    return {s: f for (k, s), f in _FORMATS.items() if k == kind and (not writing or f.write is not None)
            and (not reading or f.read is not None)}


class FormatView(Mapping):
    """The formats of one kind as a read-only mapping suffix -> :class:`Format`, always the registry's now (the
    tables ``MESH_FORMATS``, ``SERIES_FORMATS`` ... are such views)."""

    def __init__(self, kind, *, writing=False, reading=False):
        self.kind, self.writing, self.reading = kind, writing, reading

    def _now(self):
        return formats_of(self.kind, writing=self.writing, reading=self.reading)

    def __getitem__(self, key):
        return self._now()[key]

    def __iter__(self):
        return iter(self._now())

    def __len__(self):
        return len(self._now())

    def __repr__(self):
        return f"FormatView({self.kind!r}: {', '.join(self)})"


def written_as(path, kinds):
    """The :class:`Format` that writes ``path`` as the first of ``kinds`` that has one (None if none does)."""
    for kind in kinds:
        fmt = find_format(kind, path, writing=True)
        if fmt is not None:
            return fmt
    return None


def suffix_list(kind, *, writing=False, reading=False):
    """The suffixes of one kind, for messages (``'.vtu, .vtp, .vtk'``)."""
    return ", ".join(formats_of(kind, writing=writing, reading=reading))


def lookup(kind, path, *, writing=False, also=""):
    """The :class:`Format` of ``path`` as a ``kind``; else a :class:`~manifill.errors.ReadError` (``WriteError``
    when ``writing``) naming the suffixes there are (and ``also``, e.g. formats known by their first bytes).

    Examples
    --------
    >>> import manifill.io
    >>> lookup("grid", "a.png")
    Traceback (most recent call last):
    ...
    manifill.errors.ReadError: a.png: cannot read '.png' files; use one of .vti, .npy
    """
    fmt = find_format(kind, path, writing=writing)
    if fmt is None:
        ext = Path(path).suffix.lower()
        raise (WriteError if writing else ReadError)(
            f"{Path(path).name}: cannot {'write' if writing else 'read'} '{ext or '(no extension)'}' files; use one "
            f"of {suffix_list(kind, writing=writing, reading=not writing)}{also}")
    return fmt
