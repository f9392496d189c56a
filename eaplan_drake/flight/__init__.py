"""The flight side: implicit paths, the Zamboni-like coverage plan and the authors' plan files, the
fixed-wing plant, vector-field guidance and the stage sequencer.
"""
