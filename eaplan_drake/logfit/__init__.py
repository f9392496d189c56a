"""Recorded power logs: readers (PX4, Paparazzi, plain CSV) and the fit of the energy model to
them.
"""
