"""Studies: seeded random worlds and sweeps over many flights (joblib locally, Dask on a cluster);
the shipped study files live beside these modules.
"""
