"""What a flight produces for people: figures, the Meshcat replay, Graphviz diagrams, command-line
progress and the paper's reference table.
"""
