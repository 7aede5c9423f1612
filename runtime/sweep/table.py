"""A study's results as plain numpy arrays (`StudyTable`) and its NetCDF file written from them
with h5py alone: what `depsim sweep` makes, summarises and writes without importing
xarray (whose import, with the dask modules it probes and the `distributed` that writing asks
about, took 1.2 s of the command's 2.4 s of fixed cost; bench/NOTES.md, Studies).

A StudyTable reads like the few parts of an xarray Dataset that the summary and the plot use
(`table[name].values`, `.attrs`, `.dims`, `table.data_vars`, `table.coords`, `table.attrs`,
`table.sizes`, `name in table`), and `to_xarray()` gives the Dataset itself. `write_table`
writes what xarray's h5netcdf backend writes for the same Dataset (the CF encoding of its
variables: NaN fill values of floats, booleans as int8 with `dtype: bool`, text as
variable-length UTF-8, the `coordinates` attributes; netCDF-4's dimension scales and ids),
so the file reads back with xarray as the Dataset's would, HDF5 object for object
(tests/runtime/test_study_table.py): h5netcdf's own writer spent 4 to 6 ms a variable.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..output import atomic_path

__all__ = ["Column", "StudyTable", "write_table"]


@dataclasses.dataclass(frozen=True, slots=True)
class Column:
    """One variable of a study: its dimensions' names, its values (shape: the dimensions'
    sizes) and its attributes (`units`, `long_name`, `description`)."""

    dims: tuple[str, ...]
    values: np.ndarray
    attrs: dict = dataclasses.field(default_factory=dict)


@dataclasses.dataclass(frozen=True, slots=True)
class StudyTable:
    """A study: data variables and coordinates by name, in the file's order, and the global
    attributes. Dimensions `run`, `parameter`, and `time` with a time grid."""

    data_vars: dict[str, Column]
    coords: dict[str, Column]
    attrs: dict

    def __getitem__(self, name: str) -> Column:
        column = self.data_vars.get(name)
        if column is None:
            column = self.coords[name]
        return column

    def __contains__(self, name: object) -> bool:
        return name in self.data_vars or name in self.coords

    @property
    def sizes(self) -> dict[str, int]:
        """Each dimension's length."""
        out: dict[str, int] = {}
        for column in (*self.data_vars.values(), *self.coords.values()):
            out.update(zip(column.dims, column.values.shape))
        return out

    def to_xarray(self):
        """The study as an xarray Dataset (imports xarray)."""
        import xarray as xr

        def items(columns: Mapping[str, Column]) -> dict:
            return {name: (c.dims, c.values, c.attrs) for name, c in columns.items()}

        return xr.Dataset(items(self.data_vars), coords=items(self.coords), attrs=self.attrs)


def write_table(table: StudyTable, path: str | os.PathLike) -> Path:
    """Write the study as NetCDF-4 (HDF5) with h5py, through `output.atomic_path` (a
    temporary file, then a rename: never a half-written file)."""
    import h5py

    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w", track_order=True) as f:
            _write_file(f, table)
    return Path(path)


def _write_file(f, table: StudyTable) -> None:
    """The study's groups, datasets and attributes as h5netcdf writes the Dataset (netCDF's
    HDF5 conventions: each dimension a coordinate variable made an HDF5 dimension scale, its
    id in `_Netcdf4Dimid`, every variable's dimension ids in `_Netcdf4Coordinates`, the
    scales attached to the variables' axes; `_NCProperties`), in xarray's order: the data
    variables, then the coordinates."""
    import h5py

    for key, value in table.attrs.items():
        f.attrs[key] = _attribute(value)
    columns = {**table.data_vars, **table.coords}
    dims = {name: k for k, name in enumerate(_dimensions(columns))}
    listed = _coordinates(table)
    unlisted = sorted(set(_non_dimension_coords(table)) - {
        n for names in listed.values() for n in names.split()})
    if unlisted:  # coordinates no variable names (xarray's global attribute)
        f.attrs["coordinates"] = " ".join(unlisted)
    for name, column in columns.items():
        _write_column(f, name, column, listed.get(name))
    for name in dims:  # each dimension's coordinate variable, an HDF5 dimension scale
        assert name in table.coords, f"dimension {name} without its coordinate variable"
        f[name].make_scale(name)
    for name, column in columns.items():
        dataset = f[name]
        ids = [dims[d] for d in column.dims]
        if column.dims != (name,):
            for axis, dim in enumerate(column.dims):
                dataset.dims[axis].attach_scale(f[dim])
        dataset.attrs["_Netcdf4Coordinates"] = np.array(ids, dtype=np.int32)
        dataset.attrs["_Netcdf4Dimid"] = np.array(ids[0], dtype=np.int32)
    properties = (f"version=2,depsim={_version()},hdf5={h5py.version.hdf5_version},"
                  f"h5py={h5py.__version__}")
    f.attrs["_NCProperties"] = np.array(
        properties, dtype=h5py.string_dtype(encoding="ascii", length=len(properties)))


def _version() -> str:
    from importlib.metadata import version

    return version("depsim")


def _attribute(value):
    """An attribute's value as netCDF writes it: a number as an array of one."""
    if np.isscalar(value) and not isinstance(value, (str, bytes)):
        return np.atleast_1d(value)
    return value


def _dimensions(columns: Mapping[str, Column]) -> dict[str, int]:
    """The dimensions in the order the variables first use them."""
    out: dict[str, int] = {}
    for column in columns.values():
        for dim, size in zip(column.dims, column.values.shape):
            out.setdefault(dim, size)
    return out


def _non_dimension_coords(table: StudyTable) -> list[str]:
    return [name for name, c in table.coords.items() if c.dims != (name,)]


def _coordinates(table: StudyTable) -> dict[str, str]:
    """Each variable's `coordinates` attribute, as xarray's CF encoding writes it: the
    non-dimension coordinates whose dimensions the variable has, sorted (none on the
    coordinates themselves or on a dimension's own variable)."""
    extra = _non_dimension_coords(table)
    out = {}
    for name, column in {**table.data_vars, **table.coords}.items():
        if name in extra or name in column.dims:
            continue
        names = sorted(c for c in extra if set(table.coords[c].dims) <= set(column.dims))
        if names:
            out[name] = " ".join(names)
    return out


def _write_column(f, name: str, column: Column, coordinates: str | None) -> None:
    """One variable, encoded as xarray's CF encoder does for its dtype: a float with NaN as
    its fill value (`_FillValue`), a boolean as int8 with `dtype: bool`, text as
    variable-length UTF-8."""
    import h5py

    values = np.asarray(column.values)
    attrs = dict(column.attrs)
    if coordinates:
        attrs["coordinates"] = coordinates
    fill = None
    if values.dtype.kind == "b":
        values = values.astype(np.int8)
        attrs["dtype"] = "bool"
    elif values.dtype.kind in "US":
        values = values.astype(str).astype(object)
    elif values.dtype.kind == "f":
        fill = values.dtype.type(np.nan)
    dtype = h5py.string_dtype() if values.dtype == object else values.dtype
    dataset = f.create_dataset(name, data=values, dtype=dtype, fillvalue=fill,
                               track_order=True)
    if fill is not None:
        dataset.attrs["_FillValue"] = np.atleast_1d(fill)
    for key, value in attrs.items():
        dataset.attrs[key] = _attribute(value)
