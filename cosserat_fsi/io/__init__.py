"""Output: CSV time series (no dolfinx needed) and moving-mesh XDMF/HDF5 fields."""

from cosserat_fsi.io.timeseries import TimeSeriesWriter, read_timeseries

__all__ = ["MovingMeshXDMF", "TimeSeriesWriter", "read_timeseries"]


def __getattr__(name):
    # imported lazily: xdmf needs dolfinx, the time series do not
    if name == "MovingMeshXDMF":
        from cosserat_fsi.io.xdmf import MovingMeshXDMF

        return MovingMeshXDMF
    raise AttributeError(name)
