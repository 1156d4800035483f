"""rvflex: rigid–flexible Exudyn models of RV reducers for loaded transmission error,
lost motion and backlash. SI units throughout; see README.md for conventions."""

__version__ = "0.1.0"
