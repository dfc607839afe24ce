"""The writers of a series' steps, one per format (``.npy``, ``.h5``, ``.xdmf``, ``.pvd``; GIfTI's is
:class:`manifill.io.gifti_write.GiftiSeries`): each takes the :class:`manifill.io.series_write.SeriesWriter` that
opens it and has ``add`` (a chunk of steps), ``finish`` and ``abort``, through temporaries (:class:`Temp`) that
leave nothing at the output until the last step is written.
"""

import os
import re
import shutil
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

import numpy as np

from ..errors import WriteError
from .files import ACTIVE, remove_temporaries
from .series import need_h5py
from .vtkxml_write import write_unstructured

__all__ = ["Temp", "NpySteps", "H5Steps", "XdmfSteps", "PvdSteps"]

_PVD_STEP = "{stem}_{j:06d}.vtu"  # the VTU of step j in the folder <stem>/


class Temp:
    """A temporary file or folder beside ``final`` (hidden, named after it) that replaces it on commit."""

    def __init__(self, final, tag="tmp"):
        self.final = Path(final)
        self.path = self.final.with_name(f".{self.final.name}.{os.getpid()}.{tag}{self.final.suffix}")
        remove_temporaries(self.final)  # a killed run's, left beside the same output
        ACTIVE.add(self.path)  # a process stopped at once (the CLI's watchdog) removes it

    def commit(self):
        ACTIVE.discard(self.path)
        os.replace(self.path, self.final)

    def discard(self):
        ACTIVE.discard(self.path)
        if self.path.is_dir() and not self.path.is_symlink():
            shutil.rmtree(self.path, ignore_errors=True)
        elif self.path.exists() or self.path.is_symlink():
            self.path.unlink()


class NpySteps:
    """The (n, T) float64 array, column after column (Fortran order)."""

    def __init__(self, w):
        self.tmp = Temp(w.path)
        self.fh = open(self.tmp.path, "wb")
        try:
            np.lib.format.write_array_header_1_0(self.fh, {"descr": "<f8", "fortran_order": True,
                                                           "shape": (w.n, w.steps)})
        except BaseException:
            self.abort()
            raise

    def add(self, X, times, j0):
        self.fh.write(np.asarray(X, dtype="<f8").tobytes(order="F"))

    def finish(self):
        self.fh.close()
        self.tmp.commit()

    def abort(self):
        self.fh.close()
        self.tmp.discard()


class H5Steps:
    """An (n, T) dataset named after the field, ``times`` and the static fields."""

    def __init__(self, w):
        h5py = need_h5py(w.path)
        self.tmp = Temp(w.path)
        self.fh = h5py.File(self.tmp.path, "w")
        try:
            rows = min(w.n, 1 << 15)
            cols = max(1, min(w.steps, (1 << 15) // rows))  # chunks of 256 KB at most, whole columns
            self.values = self.fh.create_dataset(w.name, shape=(w.n, w.steps), dtype="<f8", chunks=(rows, cols))
            self.times = self.fh.create_dataset("times", shape=(w.steps,), dtype="<f8")
            for key, arr in w.static.items():
                self.fh.create_dataset(key, data=arr)
            self.fh.attrs["field"] = w.name
        except BaseException:
            self.abort()
            raise

    def add(self, X, times, j0):
        self.values[:, j0:j0 + X.shape[1]] = X
        self.times[j0:j0 + X.shape[1]] = times

    def finish(self):
        self.fh.close()
        self.tmp.commit()

    def abort(self):
        try:
            self.fh.close()
        finally:
            self.tmp.discard()


_XDMF_TYPES = {"float64": ("Float", "8"), "int32": ("Int", "4"), "int64": ("Int", "8"), "uint8": ("UChar", "1")}


def _attribute_type(arr):
    p = 1 if arr.ndim == 1 else arr.shape[1]
    return {1: "Scalar", 2: "Vector", 3: "Vector", 6: "Tensor6", 9: "Tensor"}.get(p, "Matrix")


class XdmfSteps:
    """XDMF text streamed step by step, its arrays in ``<stem>.h5``; the mesh in the first step's grid."""

    def __init__(self, w):
        h5py = need_h5py(w.path)
        if ":" in w.path.stem:
            raise WriteError(f"{w.path.name}: an XDMF file's name cannot hold ':' (it separates the HDF5 file from "
                             f"the dataset); rename the output")
        self.w = w
        self.h5name = w.path.stem + ".h5"
        self.xml = Temp(w.path)
        self.h5 = Temp(w.path.with_name(self.h5name))
        self.fh = self.hf = None
        try:
            self.hf = h5py.File(self.h5.path, "w")
            self.fh = open(self.xml.path, "w", encoding="utf-8", newline="\n")
            self.hf.create_dataset("mesh/points", data=w.V)
            self.hf.create_dataset("mesh/cells", data=w.C)
            self.static = []
            for i, (key, arr) in enumerate(w.static.items()):
                self.hf.create_dataset(f"static/{i}", data=arr)
                self.static.append(self._attribute(key, arr, f"static/{i}"))
            self.fh.write(f'<?xml version="1.0"?>\n<Xdmf Version="3.0" xmlns:xi="http://www.w3.org/2001/XInclude">\n'
                          f'  <Domain>\n    <Grid Name={quoteattr(w.name)} GridType="Collection" '
                          f'CollectionType="Temporal">\n')
        except BaseException:
            self.abort()
            raise

    def _item(self, arr, where):
        kind, prec = _XDMF_TYPES[arr.dtype.name]
        dims = " ".join(str(s) for s in arr.shape)
        return (f'<DataItem DataType="{kind}" Dimensions="{dims}" Format="HDF" Precision="{prec}">'
                f'{escape(self.h5name)}:/{where}</DataItem>')

    def _attribute(self, key, arr, where):
        return (f'        <Attribute Name={quoteattr(key)} AttributeType="{_attribute_type(arr)}" Center="Node">'
                f'{self._item(arr, where)}</Attribute>\n')

    def add(self, X, times, j0):
        w = self.w
        topo = {1: 'Polyvertex" NodesPerElement="1', 3: "Triangle"}.get(w.C.shape[1], "Tetrahedron")
        parts = []
        for i in range(X.shape[1]):
            j = j0 + i
            col = np.ascontiguousarray(X[:, i])
            self.hf.create_dataset(f"steps/{j}", data=col)
            parts.append(f'      <Grid Name="step_{j}" GridType="Uniform">\n')
            if j == 0:
                parts.append(f'        <Geometry GeometryType="XYZ">{self._item(w.V, "mesh/points")}</Geometry>\n'
                             f'        <Topology TopologyType="{topo}" NumberOfElements="{len(w.C)}">'
                             f'{self._item(w.C, "mesh/cells")}</Topology>\n')
            else:
                parts.append('        <xi:include xpointer="xpointer(//Grid[@Name=&quot;step_0&quot;]/*[self::'
                             'Topology or self::Geometry])"/>\n')
            parts.append(f'        <Time Value="{float(times[i])!r}"/>\n')
            parts.append(self._attribute(w.name, col, f"steps/{j}"))
            parts.extend(self.static)
            parts.append("      </Grid>\n")
        self.fh.write("".join(parts))

    def finish(self):
        self.fh.write("    </Grid>\n  </Domain>\n</Xdmf>\n")
        self.fh.close()
        self.hf.close()
        self.h5.commit()  # the arrays first: the XDMF file appears only when what it names is there
        self.xml.commit()

    def abort(self):
        try:
            for fh in (self.fh, self.hf):
                if fh is not None:
                    fh.close()
        finally:
            self.xml.discard()
            self.h5.discard()


class PvdSteps:
    """``<stem>.pvd`` and a folder ``<stem>/`` of one VTU per step, built under temporary names."""

    def __init__(self, w):
        self.w = w
        stem = w.path.stem
        self.folder = w.path.with_name(stem)
        step = re.compile(re.escape(stem) + r"_[0-9]{6,}\.vtu")
        if self.folder.exists() or self.folder.is_symlink():
            if not self.folder.is_dir() or self.folder.is_symlink() or any(
                    not step.fullmatch(p.name) for p in self.folder.iterdir()):
                raise WriteError(f"{w.path.name}: its steps go to {self.folder}, which exists and holds other files; "
                                 f"remove it or choose another output name")
        self.xml = Temp(w.path)
        self.dir = Temp(self.folder)
        self.fh = None
        self.encoded = {}  # the mesh and the masks, encoded for the first step's file and reused
        try:
            self.dir.path.mkdir()
            self.fh = open(self.xml.path, "w", encoding="utf-8", newline="\n")
            self.fh.write('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" '
                          'byte_order="LittleEndian">\n  <Collection>\n')
        except BaseException:
            self.abort()
            raise

    def add(self, X, times, j0):
        w = self.w
        lines = []
        for i in range(X.shape[1]):
            name = _PVD_STEP.format(stem=w.path.stem, j=j0 + i)
            write_unstructured(self.dir.path / name, w.V, w.C, {w.name: X[:, i], **w.static}, cache=self.encoded,
                               constant=w.static)
            lines.append(f'    <DataSet timestep="{float(times[i])!r}" group="" part="0" '
                         f'file={quoteattr(self.folder.name + "/" + name)}/>\n')
        self.fh.write("".join(lines))

    def finish(self):
        self.fh.write("  </Collection>\n</VTKFile>\n")
        self.fh.close()
        old = Temp(self.folder, "old")
        if self.folder.exists():
            os.replace(self.folder, old.path)  # steps of an earlier run, moved aside and removed at the end
        self.dir.commit()
        self.xml.commit()
        old.discard()

    def abort(self):
        try:
            if self.fh is not None:
                self.fh.close()
        finally:
            self.xml.discard()
            self.dir.discard()
