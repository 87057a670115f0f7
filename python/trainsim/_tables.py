"""Result containers: a table of numpy columns, a run's series, a run's metrics.
pandas and xarray views are made only when those packages are importable."""
import numpy as np

# series columns that are integers in a history file (stored exactly as doubles in memory)
INTEGER_DATASETS = ("elements/contact", "elements/pairs")


class Table:
    """Named numpy columns of one length (a dict of arrays): `t["mesh.p2p_mean"]`,
    `t.columns`, `len(t)`, `t.units` (a unit per column when known), `t.to_pandas()`."""

    def __init__(self, columns, units=None):
        self._cols = dict(columns)
        self.units = dict(units or {})

    @property
    def columns(self):
        return list(self._cols)

    def __getitem__(self, name):
        return self._cols[name]

    def __contains__(self, name):
        return name in self._cols

    def __iter__(self):
        return iter(self._cols)

    def __len__(self):
        return len(next(iter(self._cols.values()))) if self._cols else 0

    def items(self):
        return self._cols.items()

    def to_dict(self):
        return dict(self._cols)

    def to_pandas(self):
        import pandas as pd
        df = pd.DataFrame(self._cols)
        df.attrs["units"] = dict(self.units)
        return df

    def __repr__(self):
        return f"<trainsim.Table {len(self)} rows x {len(self._cols)} columns: {', '.join(self.columns[:6])}" + \
            (", ...>" if len(self._cols) > 6 else ">")


class Series:
    """A run's sampled history: `values` (samples x columns, float64), `names` and
    `units` of the columns. Column names follow the history file: `time`,
    `states/<name>`, `nodes/theta/<id>`, `nodes/omega/<id>`, `elements/<field>/<id>`
    (torque_left, torque_right, displacement, force, contact, pairs), `energy/<name>`,
    `inputs/<name>`.

    `s["nodes/omega/n1"]` is one column; `s["nodes/omega"]` the (samples x nodes)
    block of a dataset (its column ids: `s.ids("nodes/omega")`); contact and pairs come
    back as int32, as in the file. `s.time`, `s.to_pandas()`, `s.to_xarray()`."""

    def __init__(self, values, names, units):
        self.values = values
        self.names = list(names)
        self.units = dict(zip(self.names, units))
        self._index = {n: i for i, n in enumerate(self.names)}

    @property
    def time(self):
        return self.values[:, self._index["time"]]

    def __len__(self):
        return self.values.shape[0]

    def datasets(self):
        """The dataset names (`time`, `nodes/omega`, ...), in column order."""
        seen = []
        for n in self.names:
            d = _dataset(n)
            if d not in seen:
                seen.append(d)
        return seen

    def ids(self, dataset):
        return [n[len(dataset) + 1:] for n in self.names if _dataset(n) == dataset and n != dataset]

    def __getitem__(self, name):
        if name in self._index:
            col = self.values[:, self._index[name]]
            return col.astype(np.int32) if _dataset(name) in INTEGER_DATASETS else col
        cols = [self._index[n] for n in self.names if _dataset(n) == name]
        if not cols:
            raise KeyError(f"no series column or dataset '{name}'")
        block = self.values[:, cols]
        return block.astype(np.int32) if name in INTEGER_DATASETS else block

    def __contains__(self, name):
        return name in self._index or name in self.datasets()

    def to_pandas(self):
        import pandas as pd
        df = pd.DataFrame({n: self[n] for n in self.names if n != "time"}, index=pd.Index(self.time, name="time"))
        df.attrs["units"] = dict(self.units)
        return df

    def to_xarray(self):
        """An xarray.Dataset: one variable per dataset, dimensions (time, <dataset>_id)."""
        import xarray as xr
        data = {}
        for d in self.datasets():
            if d == "time":
                continue
            ids = self.ids(d)
            dim = d.replace("/", "_") + "_id"
            units = {self.units[f"{d}/{i}"] for i in ids}
            data[d.replace("/", "_")] = xr.DataArray(self[d], dims=("time", dim), coords={dim: ids},
                                                     attrs={"units": units.pop() if len(units) == 1 else "mixed"})
        return xr.Dataset(data, coords={"time": ("time", self.time, {"units": "s"})})

    def __repr__(self):
        return f"<trainsim.Series {len(self)} samples x {len(self.names)} columns: {', '.join(self.datasets())}>"


def _dataset(name):
    """`nodes/omega` of `nodes/omega/n1`; `time` of `time`. Ids hold no '/'."""
    return name.rsplit("/", 1)[0] if "/" in name else name


class Metrics(dict):
    """A run's metrics by name (`m["mesh.p2p_mean"]`), with `units` and `to_pandas()`."""

    def __init__(self, names, values, units):
        super().__init__(zip(names, (float(v) for v in values)))
        self.units = dict(zip(names, units))

    def to_table(self):
        return Table({"name": np.array(list(self)), "value": np.array(list(self.values())),
                      "unit": np.array([self.units[k] for k in self])})

    def to_pandas(self):
        return self.to_table().to_pandas().set_index("name")
