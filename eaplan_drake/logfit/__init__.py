"""Recorded power logs: readers (PX4, Paparazzi, plain CSV) and the fit of the energy model to
them.

``powerlog`` reads the logs; ``fit`` fits the model (order and noise) and scores it, built on
``filtering`` (the model's Kalman filter and predictions over a series), ``noise`` (the noise
identification), ``result`` (the fitted model and its scenario fragment) and ``scores`` (the
baselines and the prediction scores).
"""
