"""A study's plain arrays (`StudyTable`) and its NetCDF file written with h5netcdf alone: read
back with xarray, the file is the one xarray writes for the same Dataset (every variable,
coordinate, attribute, dtype, dimension and encoding), and HDF5 object for object; the
summary of the arrays is the summary of the Dataset."""

from __future__ import annotations

import functools

import h5py
import numpy as np
import pytest
import xarray as xr

from depsim.runtime.sweep import make_design, summarize
from depsim.runtime.sweep.storage import ENGINE, build_dataset, build_table, write_dataset
from depsim.runtime.sweep.table import StudyTable, write_table

from depsim.runtime.sweep.metrics import metric_attributes
from depsim.runtime.sweep.table import Column
from study_fixtures import deployment_study, hinge_module


def study_parts(time_grid: bool, failed=(3, 7), units=True):
    """The records and settings of a hand-made deployment study (`deployment_study`'s), with
    each output on a time grid when `time_grid`, errors with text beyond ASCII."""
    module = hinge_module(4)
    design = make_design(module.PARAMETERS, module.PARAMETER_DEFAULTS, runs=30, seed=4,
                         samples=["friction=uniform(0.5, 0.8)", "preload=normal(1.7, 0.1)"])
    grid = np.linspace(0.0, 2.0, 7) if time_grid else None
    records = {}
    for i, (friction, preload, length) in enumerate(design.matrix):
        if i in failed:
            records[i] = {"run": i, "failed": True, "error": "SolverError: t = 3 s, θ1 — Δ",
                          "values": {}, "wall": 0.01, "series": None}
            continue
        values = {"deployed": float(preload > 1.6), "time_to_deploy": 40 * friction,
                  "event.h1.latch.t": 10 + friction, "peak.h1.torque": 4 * preload,
                  "final.tip_y": 4 * length, "stats.accepted_steps": 1000.0 + i}
        if i % 5 == 0:
            values.pop("event.h1.latch.t")  # an event that never came: NaN
        series = [list(np.sin(grid * (k + 1)) + friction) for k in range(3)] if time_grid \
            else None
        records[i] = {"run": i, "failed": False, "error": "" if i % 4 else "metric x: nan",
                      "values": values, "wall": 0.002 * i, "series": series}
    settings = dict(static_metrics=["deployed", "time_to_deploy"], user_metrics=[],
                    output_names=module.OUTPUTS, time_grid=grid,
                    attrs={"title": "depsim parameter study of array", "study_kind": "monte_carlo",
                           "seed": 4, "runs": 30, "varied": "friction, preload", "tol": 1e-8,
                           "t_end": float("nan"), "spec": None},
                    describe=functools.partial(metric_attributes, module=module),
                    parameter_units=module.PARAMETER_UNITS if units else None)
    return records, design, settings


def encoding(variable) -> dict:
    """How xarray found a variable stored (chunks, filters, fill value, dtype), by repr."""
    return {k: repr(v) for k, v in variable.encoding.items() if k != "source"}


HIDDEN = {"DIMENSION_LIST", "REFERENCE_LIST", "_Netcdf4Coordinates", "_Netcdf4Dimid", "CLASS",
          "NAME"}  # netCDF-4's bookkeeping: read by name, in any order


def h5_attributes(item) -> tuple[list, dict]:
    """An HDF5 object's attributes: (name, HDF5 type class, size or "vlen", character set,
    shape, value), the visible ones in their order, netCDF's bookkeeping by name;
    references as the names they point to."""
    visible, hidden = [], {}
    for key in item.attrs:
        attribute = h5py.h5a.open(item.id, key.encode())
        kind = attribute.get_type()
        text = isinstance(kind, h5py.h5t.TypeStringID)
        value = item.attrs[key]
        if key == "DIMENSION_LIST":
            value = [[item.file[ref].name for ref in row] for row in value]
        elif key == "REFERENCE_LIST":
            value = sorted(item.file[entry[0]].name for entry in value)
        entry = (key, type(kind).__name__,
                 "vlen" if text and kind.is_variable_str() else kind.get_size(),
                 kind.get_cset() if text else None, attribute.get_space().shape, repr(value))
        if key in HIDDEN:
            hidden[key] = entry
        else:
            visible.append(entry)
    return visible, hidden


def h5_layout(path) -> dict:
    """Everything of the file an HDF5 reader sees: the datasets in creation order, each with
    its dtype, string type, shape, maximum shape, chunks, fill value, layout, attribute
    order tracking, fill and allocation times, data and attributes; the file's attributes
    (`_NCProperties`, which names the writer, apart)."""
    out = {}
    with h5py.File(path, "r") as f:
        visible, hidden = h5_attributes(f)
        out["/"] = ([a for a in visible if a[0] != "_NCProperties"], hidden)
        assert f.attrs["_NCProperties"].startswith(b"version=2,")
        for name in f:
            item = f[name]
            plist = item.id.get_create_plist()
            out[name] = (str(item.dtype), repr(h5py.check_string_dtype(item.dtype)),
                         item.shape, item.maxshape, item.chunks, repr(item.fillvalue),
                         plist.get_layout(), plist.get_attr_creation_order(),
                         plist.get_fill_time(), plist.get_alloc_time(),
                         repr(item[...].tolist()), h5_attributes(item))
        out["order"] = list(f)
    return out


@pytest.mark.parametrize("time_grid, units", [(False, True), (True, True), (True, False)])
def test_the_table_file_reads_back_as_xarrays_own(tmp_path, time_grid, units):
    records, design, settings = study_parts(time_grid, units=units)
    ds = build_dataset(records, design, **settings)
    ds.to_netcdf(tmp_path / "xarray.nc", engine=ENGINE)  # the writer before StudyTable
    table = build_table(records, design, **settings)
    write_table(table, tmp_path / "table.nc")
    old = xr.load_dataset(tmp_path / "xarray.nc", engine=ENGINE)
    new = xr.load_dataset(tmp_path / "table.nc", engine=ENGINE)
    assert new.identical(old)  # values (NaN = NaN), dims, coords, attrs of all
    assert list(new.variables) == list(old.variables)
    assert list(new.dims) == list(old.dims) and dict(new.sizes) == dict(old.sizes)
    for name in old.variables:
        assert new[name].dtype == old[name].dtype, name
        assert new[name].dims == old[name].dims, name
        assert new[name].attrs == old[name].attrs, name
        assert encoding(new[name]) == encoding(old[name]), name  # _FillValue NaN: by repr
    assert repr(new.attrs) == repr(old.attrs)  # t_end NaN: by repr
    assert h5_layout(tmp_path / "table.nc") == h5_layout(tmp_path / "xarray.nc")


def test_the_table_is_the_dataset_in_plain_arrays():
    records, design, settings = study_parts(time_grid=True)
    table = build_table(records, design, **settings)
    ds = build_dataset(records, design, **settings)
    assert isinstance(table, StudyTable)
    assert table.to_xarray().identical(ds)
    assert table.sizes == {"run": 30, "parameter": 3, "time": 7}
    assert "friction" in table and "failed" in table and "nonsense" not in table
    assert list(table.data_vars) == list(ds.data_vars)
    assert table["error"].values[3] == "SolverError: t = 3 s, θ1 — Δ"
    np.testing.assert_array_equal(table["friction"].values, ds["friction"].values)


def test_write_dataset_takes_either(tmp_path):
    records, design, settings = study_parts(time_grid=False)
    write_dataset(build_table(records, design, **settings), tmp_path / "a.nc")
    write_dataset(build_dataset(records, design, **settings), tmp_path / "b.nc")
    assert xr.load_dataset(tmp_path / "a.nc", engine=ENGINE).identical(
        xr.load_dataset(tmp_path / "b.nc", engine=ENGINE))


@pytest.mark.parametrize("limits", [None, {"peak.h4.torque": 7.0, "time_to_deploy": 40.0}])
def test_the_summary_of_the_table_is_the_summary_of_the_dataset(limits):
    ds = deployment_study(runs=120)
    table = StudyTable({n: Column(v.dims, v.values, v.attrs) for n, v in ds.data_vars.items()},
                       {n: Column(v.dims, v.values, v.attrs) for n, v in ds.coords.items()},
                       dict(ds.attrs))
    assert summarize(table, limits=limits) == summarize(ds, limits=limits)
