"""The energy side: the Fourier energy model, the computation load, the Rint battery, the power
sensor and the Kalman estimator.
"""
