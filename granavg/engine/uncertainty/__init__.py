"""Honest errors: the time blocking of correlated frames and the replicates of derived
numbers (:mod:`granavg.engine.uncertainty.blocking`), and the frozen structure of one
packing counted through each cell's sectors (:mod:`granavg.engine.uncertainty.structure`).
"""
